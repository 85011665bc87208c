"""A conductor whose Fresnel curve approximates the paper's `0.1 + 0.9 (1 - cos)^3`.

The paper weights mirror reflections with that curve; Mitsuba's `conductor` has the exact
Fresnel equations of a metal with complex index eta + i k. The fit is least squares over
cos theta in [0, 1]; its error is reported with the export.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


def paper_fresnel(cos_theta: F64) -> F64:
    return np.asarray(0.1 + 0.9 * (1.0 - cos_theta) ** 3)


def conductor_fresnel(cos_theta: F64, eta: float, k: float) -> F64:
    """Unpolarised reflectance of a conductor (air outside), exact Fresnel equations."""
    c2 = cos_theta * cos_theta
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * cos_theta * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / (t3 + t4)
    return np.asarray(0.5 * (rs + rp))


@dataclass(frozen=True)
class ConductorFit:
    eta: float
    k: float
    rms_error: float
    max_error: float


def fit_paper_conductor(samples: int = 257) -> ConductorFit:
    """Grid search refined three times; deterministic, a few milliseconds."""
    cos = np.linspace(0.0, 1.0, samples)
    target = paper_fresnel(cos)

    def rms(eta: F64, k: F64) -> F64:
        f = conductor_fresnel(cos[None, None, :], eta[:, :, None], k[:, :, None])  # type: ignore[arg-type]
        return np.asarray(np.sqrt(np.mean((f - target) ** 2, axis=-1)))

    lo_eta, hi_eta, lo_k, hi_k = 0.05, 6.0, 0.0, 8.0
    best = (1.0, 1.0)
    for _ in range(4):
        etas = np.linspace(lo_eta, hi_eta, 121)
        ks = np.linspace(lo_k, hi_k, 121)
        e, kk = np.meshgrid(etas, ks, indexing="ij")
        err = rms(e, kk)
        i, j = np.unravel_index(int(np.argmin(err)), err.shape)
        best = (float(etas[i]), float(ks[j]))
        de, dk = (hi_eta - lo_eta) / 20, (hi_k - lo_k) / 20
        lo_eta, hi_eta = max(0.01, best[0] - de), best[0] + de
        lo_k, hi_k = max(0.0, best[1] - dk), best[1] + dk
    diff = conductor_fresnel(cos, *best) - target
    return ConductorFit(
        eta=best[0],
        k=best[1],
        rms_error=float(np.sqrt(np.mean(diff**2))),
        max_error=float(np.max(np.abs(diff))),
    )
