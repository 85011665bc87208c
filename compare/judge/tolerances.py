"""Pass / warn / fail for one comparison, in the style of OIIO idiff (plus SSIM and FLIP).

A pixel's error is the largest channel difference of the display values. Exit codes:
0 pass, 1 warn, 2 fail, 3 size mismatch, 4 unreadable input. NaN or Inf in the test image
where the reference has none always fails (as Falcor's tests do).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from compare.judge.metrics import BOOL, Maps, Metrics

EXIT_PASS, EXIT_WARN, EXIT_FAIL, EXIT_SIZE, EXIT_UNREADABLE = 0, 1, 2, 3, 4
STATUS_CODE = {"pass": EXIT_PASS, "warn": EXIT_WARN, "fail": EXIT_FAIL}


@dataclass(frozen=True)
class Tolerances:
    """The per-pixel tolerances of a verdict, in the style of OIIO idiff.

    A pixel's error is the largest channel difference of the display values (clamped to
    [0, 1], sRGB-encoded). Each tolerance is checked when made: a finite number in range.

    Attributes
    ----------
    fail : float
        A pixel's error above this counts as failing; default 0.01. Also the threshold of
        the metrics' ``over_threshold``.
    failpercent : float
        The share of pixels, in % (0 to 100), that may fail before the verdict does;
        default 0.
    hardfail : float
        Any pixel's error above this fails the verdict; default inf (None is read as inf).
    warn : float
        A pixel's error above this counts as a warning; default 1/255.
    warnpercent : float
        The share of pixels, in % (0 to 100), that may warn before the verdict does;
        default 0.
    min_ssim : float or None
        The verdict fails with a mean SSIM below this (or NaN); default None: no SSIM test.
    max_flip : float or None
        The verdict fails with a mean LDR FLIP above this (or NaN); default None: no FLIP
        test.

    Raises
    ------
    ValueError
        A tolerance that is not a finite number in its range (`hardfail` may be inf;
        `min_ssim` from -1 to 1; the others >= 0); the message names its option.
    """

    fail: float = 0.01
    failpercent: float = 0.0
    hardfail: float = math.inf
    warn: float = 1.0 / 255.0
    warnpercent: float = 0.0
    min_ssim: float | None = None
    max_flip: float | None = None

    def __post_init__(self) -> None:
        """Every tolerance is a user's number: finite and in range (NaN compares false with
        everything, so an unchecked NaN would silently pass every test)."""
        if self.hardfail is None:  # as_dict() writes an infinite hardfail as null
            object.__setattr__(self, "hardfail", math.inf)
        rules: dict[str, tuple[float, float, bool]] = {  # lo, hi, may be +inf
            "fail": (0.0, math.inf, False),
            "failpercent": (0.0, 100.0, False),
            "hardfail": (0.0, math.inf, True),
            "warn": (0.0, math.inf, False),
            "warnpercent": (0.0, 100.0, False),
            "min_ssim": (-1.0, 1.0, False),
            "max_flip": (0.0, math.inf, False),
        }
        for name, (lo, hi, inf_ok) in rules.items():
            v = getattr(self, name)
            if v is None and name in ("min_ssim", "max_flip"):
                continue
            ok = (
                not isinstance(v, bool)
                and isinstance(v, (int, float))
                and (math.isfinite(v) or (inf_ok and v == math.inf))
                and lo <= v <= hi
            )
            if not ok:
                option = "--" + name.replace("_", "-")
                span = f">= {lo:g}" if hi == math.inf else f"from {lo:g} to {hi:g}"
                raise ValueError(f"tolerance {option}: expected a finite number {span}, got {v!r}")

    def as_dict(self) -> dict[str, Any]:
        return {
            k: (None if isinstance(v, float) and math.isinf(v) else v)
            for k, v in asdict(self).items()
        }


@dataclass
class Verdict:
    """Pass, warn or fail under the tolerances, and why.

    A NaN or infinity in the test image where the reference has none always fails.

    Attributes
    ----------
    status : str
        "pass", "warn" or "fail".
    reasons : list[str]
        Why it fails or warns; default empty.
    failing_pixels : int
        Pixels whose error exceeds the `fail` tolerance (against a demo model: the pixels
        that differ from it); default 0.
    warning_pixels : int
        Pixels whose error exceeds the `warn` tolerance; default 0.
    max_display_error : float
        The largest pixel error (display values); default 0.
    exit_code : int
        The command's exit status for `status`: 0 pass, 1 warn, 2 fail (read-only).
    """

    status: str
    reasons: list[str] = field(default_factory=list)
    failing_pixels: int = 0
    warning_pixels: int = 0
    max_display_error: float = 0.0

    @property
    def exit_code(self) -> int:
        return STATUS_CODE[self.status]


def judge_metrics(
    metrics: Metrics, maps: Maps, tol: Tolerances, region: BOOL | None = None
) -> Verdict:
    err = maps.abs_display if region is None else maps.abs_display[region]
    n = max(int(err.size), 1)
    failing = int((err > tol.fail).sum())
    warning = int((err > tol.warn).sum())
    worst = float(err.max()) if err.size else 0.0
    v = Verdict("pass", failing_pixels=failing, warning_pixels=warning, max_display_error=worst)
    fails: list[str] = []
    if metrics.nan_test > metrics.nan_ref or metrics.inf_test > metrics.inf_ref:
        fails.append(
            f"{metrics.nan_test} NaN and {metrics.inf_test} Inf pixels in the test image "
            f"(reference: {metrics.nan_ref}, {metrics.inf_ref})"
        )
    if worst > tol.hardfail:
        fails.append(f"max error {worst:.4g} > hardfail {tol.hardfail:g}")
    if 100.0 * failing / n > tol.failpercent:
        fails.append(
            f"{failing} pixels ({100.0 * failing / n:.3f} %) over {tol.fail:.4g}, "
            f"allowed {tol.failpercent:g} %"
        )
    if tol.min_ssim is not None and not metrics.ssim >= tol.min_ssim:
        fails.append(f"SSIM {metrics.ssim:.5f} < {tol.min_ssim:g}")
    if tol.max_flip is not None and not metrics.flip_ldr <= tol.max_flip:
        fails.append(f"FLIP {metrics.flip_ldr:.5f} > {tol.max_flip:g}")
    if fails:
        v.status, v.reasons = "fail", fails
    elif 100.0 * warning / n > tol.warnpercent:
        v.status = "warn"
        v.reasons = [
            f"{warning} pixels ({100.0 * warning / n:.3f} %) over {tol.warn:.4g}, "
            f"allowed {tol.warnpercent:g} %"
        ]
    return v


def diff_image(ref_display: np.ndarray, test_display: np.ndarray, gain: float = 8.0) -> np.ndarray:
    """|ref - test| of display values times `gain`, clamped: the picture for people."""
    return np.asarray(np.clip(np.abs(ref_display - test_display) * gain, 0.0, 1.0), np.float32)
