"""Time to the converged error: how long Mitsuba's Whitted reference and the demo's physical
mode each take to reach the error the report calls converged.

The report's reference is converged by declaration at REFERENCE_SPP; its error is its mean
per-pixel standard error (`rtval.mean_stderr`, from its own per-sample variance channels,
linear radiance). Mitsuba reaches it in the reference render's own time. The demo's physical
mode is deterministic (stratum centres), so it has no variance: its error at k spp is taken
as the mean per-pixel |render_k - render_finest| against its own finest render (a slight
underestimate, since the finest is not exact), and it is converged at the first k whose error
is at most the reference's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from compare.judge.images import Image


def _seconds(image: Image) -> float:
    return float(image.header.get("rtval.render_seconds", "nan"))


def time_to_converged(reference: Image, demo_by_spp: dict[int, Image]) -> dict[str, Any]:
    """`demo_by_spp`: the demo's physical renders by spp; the largest is its own yardstick."""
    target = float(reference.header.get("rtval.mean_stderr", "nan"))
    ref_seconds = _seconds(reference)
    finest_spp = max(demo_by_spp)
    finest = np.nan_to_num(demo_by_spp[finest_spp].rgb.astype(np.float64))
    errors = {
        spp: float(np.abs(np.nan_to_num(img.rgb) - finest).mean())
        for spp, img in sorted(demo_by_spp.items())
        if spp != finest_spp
    }
    reached = [spp for spp, err in errors.items() if np.isfinite(target) and err <= target]
    demo_spp = reached[0] if reached else None
    demo_seconds = _seconds(demo_by_spp[demo_spp]) if demo_spp else float("nan")
    ratio = ref_seconds / demo_seconds if demo_spp and demo_seconds > 0 else float("nan")
    return {
        "target_error": target,
        "reference_spp": int(reference.header.get("rtval.spp", "0") or 0),
        "reference_seconds": ref_seconds,
        "demo_errors": {str(k): v for k, v in errors.items()},
        "demo_yardstick_spp": finest_spp,
        "demo_spp": demo_spp,
        "demo_seconds": demo_seconds,
        "speedup": ratio,
    }


def mitsuba_to_converged(
    reference: Image, candidates: list[dict[str, Any]], same_estimator: set[str]
) -> dict[str, Any]:
    """Which Mitsuba configurations reach the reference's error, and the fastest that does.

    `candidates`: {"key", "label", "spp", "image"} per Mitsuba render, the reference included.
    Those whose key is in `same_estimator` estimate the reference's very image (same
    integrator, lights and pixel filter, independent samples): their error at k spp is the
    mean standard error the reference's per-sample variance predicts, mean sqrt(var / k),
    the same measure as the target. Any other (another integrator, pixel centres) is
    measured by its mean per-pixel |difference| from the reference, which its bias keeps
    above the target.
    """
    target = float(reference.header.get("rtval.mean_stderr", "nan"))
    var = [reference.aovs[f"var.{c}"] for c in "RGB" if f"var.{c}" in reference.aovs]
    per_sample = np.stack(var, -1).astype(np.float64) if len(var) == 3 else None
    rows = []
    for c in candidates:
        img: Image = c["image"]
        if c["key"] in same_estimator and per_sample is not None:
            error = float(np.mean(np.sqrt(per_sample / max(int(c["spp"]), 1))))
            measure = "predicted standard error"
        else:
            error = float(np.abs(np.nan_to_num(img.rgb) - reference.rgb).mean())
            measure = "mean |difference| from the reference"
        rows.append(
            {
                "key": c["key"],
                "label": c["label"],
                "spp": int(c["spp"]),
                "seconds": _seconds(img),
                "error": error,
                "measure": measure,
                # float32 variance round trip: allow a relative 1e-4 at the target itself
                "reaches": bool(np.isfinite(target) and error <= target * (1 + 1e-4)),
            }
        )
    reaching = [r for r in rows if r["reaches"] and np.isfinite(r["seconds"])]
    fastest = min(reaching, key=lambda r: r["seconds"]) if reaching else None
    return {"target_error": target, "configurations": rows, "fastest": fastest}
