"""Scene constants a program hard-codes, fitted as values rather than picked from a short list:
the background colour read off the image where the camera rays miss every sphere, and, once a
seed ior or bias of the sweep helped (switches.py), that value refined by a few renders and
snapped to the roundest value that fits as well (a student types 1.5 or 1e-3, not 1.4962).

Each fit costs a handful of renders, in batches that render in parallel; the recursion depth
is not fitted here (search.py bisects it).
"""

from __future__ import annotations

import math

import numpy as np

from compare.diagnose.candidate import RGB, Candidate
from compare.diagnose.refine import best_of, snapped
from compare.diagnose.trials import Trials

# The ior grid: each round tries two steps either side of the best so far, the step shrinking
# (steps that divide 0.1, so that the grid holds the values a student types).
IOR_STEPS = (0.1, 0.02, 0.01)
IOR_RANGE = (1.0, 3.0)
# Indices students hard-code (water, glass, crown glass, flint, the scratchapixel scene's):
# the fitted ior snaps to one of them where the image cannot tell them apart.
COMMON_IORS = (1.1, 1.2, 1.33, 1.4, 1.45, 1.5, 1.52, 1.6, 1.7, 2.0, 2.42)
# The bias grid, in decades: one step either side of the best, the step shrinking.
BIAS_STEPS = (0.5, 0.25, 0.1)
BIAS_RANGE = (1e-7, 1.0)
# An 8-bit image stores a channel to 1/255; a background channel at or above this reads as 1
# (clipped): any value >= 1 looks the same.
CLIPPED = 254.5 / 255
# The background is read only where at least this share of the miss pixels agree with the
# median (a background the image shows, not a sky of reflections or noise).
AGREE_MIN = 0.9


def background_seen(test: np.ndarray, misses: np.ndarray) -> RGB | None:
    """The colour the image shows where the model's camera rays miss every sphere (the
    background mask): the median per channel; in an 8-bit image (every value a multiple of
    1/255) a channel at or above CLIPPED reads as 1 (any value >= 1 looks the same). None
    where there are no miss pixels or they do not agree on one colour."""
    if not misses.any():
        return None
    seen = np.asarray(test, np.float64)[misses]
    median = np.median(seen, axis=0)
    agree = np.all(np.abs(seen - median) <= 1.5 / 255, axis=1).mean()
    if agree < AGREE_MIN:
        return None
    eight_bit = bool(np.allclose(seen * 255, np.round(seen * 255), atol=1e-3))
    rgb = [_channel(float(v), eight_bit) for v in median]
    return (rgb[0], rgb[1], rgb[2])


def _channel(v: float, eight_bit: bool) -> float:
    """A channel's value as a student would type it: two decimals where they are within half
    an 8-bit step (77/255 -> 0.3, whichever way the writer rounded 76.5), else three; 1 where
    an 8-bit image clips it."""
    if eight_bit and v >= CLIPPED:
        return 1.0
    two = round(v, 2)
    return two if abs(two - v) * 255 <= 0.5 + 1e-3 else round(v, 3)


def fitted_ior(trials: Trials, c: Candidate) -> Candidate:
    """c (whose ior is a seed that helped) with the ior refined on a narrowing grid (about
    twelve renders), then snapped to a common index that fits as well."""
    assert c.ior is not None
    best = c
    for step in IOR_STEPS:
        assert best.ior is not None
        values = [_clamp(best.ior + step * k, IOR_RANGE, 2) for k in (-2, -1, 1, 2)]
        best = best_of(trials, best, [best.ior_refit(v) for v in values])
    assert best.ior is not None
    near = sorted(COMMON_IORS, key=lambda v: abs(v - (best.ior or 0.0)))[:2]
    return snapped(trials, best, [best.ior_refit(v) for v in near])


def fitted_bias(trials: Trials, c: Candidate) -> Candidate:
    """c (whose bias is a seed that helped) with the bias refined on a log scale (six
    renders), then snapped to 1, 2, 3 or 5 times a power of ten where that fits as well."""
    assert c.bias is not None
    best = c
    for step in BIAS_STEPS:
        assert best.bias is not None
        log = math.log10(best.bias)
        values = [_clamp(10 ** (log + step * k), BIAS_RANGE, None) for k in (-1, 1)]
        best = best_of(trials, best, [best.with_bias(_sig(v, 2)) for v in values])
    assert best.bias is not None
    return snapped(trials, best, [best.with_bias(v) for v in _round_biases(best.bias)])


def _round_biases(bias: float) -> list[float]:
    """The 1-2-3-5 values of bias's decade and its neighbours, nearest (on a log scale) first."""
    decade = math.floor(math.log10(bias))
    values = [_sig(m * 10.0**d, 1) for d in (decade - 1, decade, decade + 1) for m in (1, 2, 3, 5)]
    return sorted(values, key=lambda v: abs(math.log10(v) - math.log10(bias)))[:2]


def _sig(v: float, digits: int) -> float:
    """v to `digits` significant digits."""
    return float(f"{v:.{digits}g}")


def _clamp(v: float, bounds: tuple[float, float], digits: int | None) -> float:
    v = min(bounds[1], max(bounds[0], v))
    return round(v, digits) if digits is not None else v
