"""Statistical check of a test image against a stochastic reference, as Mitsuba's own
render tests do (src/render/tests/test_renders.py): per pixel and channel,
z = |test - ref| * sqrt(test_spp / max(ref_var, 1e-4)), p = 2 (1 - Phi(z)); a pixel fails
when p < the Sidak-corrected significance 1 - (1 - alpha)^(1 / pixels); the image passes
when at least 99.75 % of pixels pass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from compare.judge.arrays import F32

VARIANCE_FLOOR = 1e-4
PASS_FRACTION = 0.9975


@dataclass
class ZTestResult:
    p_values: NDArray[np.float64]  # H x W x 3
    alpha_sidak: float
    pass_fraction: float
    passed: bool


def two_sided_p(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """2 (1 - Phi(|z|)) = erfc(|z| / sqrt 2)."""
    from scipy.special import erfc

    return np.asarray(erfc(np.abs(z) / math.sqrt(2.0)))


def z_test(
    test_mean: F32, test_spp: int, ref_mean: F32, ref_variance: F32, *, alpha: float = 0.01
) -> ZTestResult:
    if test_mean.shape != ref_mean.shape or ref_variance.shape != ref_mean.shape:
        raise ValueError(
            f"shapes differ: test {test_mean.shape}, reference {ref_mean.shape}, "
            f"variance {ref_variance.shape}"
        )
    if test_spp < 1:
        raise ValueError(f"test_spp must be >= 1, got {test_spp}")
    var = np.maximum(ref_variance.astype(np.float64), VARIANCE_FLOOR)
    z = np.abs(test_mean.astype(np.float64) - ref_mean) * np.sqrt(test_spp / var)
    z = np.where(np.isfinite(z), z, np.inf)
    p = two_sided_p(z)
    pixels = test_mean.shape[0] * test_mean.shape[1]
    alpha_sidak = 1.0 - (1.0 - alpha) ** (1.0 / pixels)
    ok = (p > alpha_sidak).all(axis=-1)
    frac = float(ok.mean())
    return ZTestResult(
        p_values=p, alpha_sidak=alpha_sidak, pass_fraction=frac, passed=frac >= PASS_FRACTION
    )
