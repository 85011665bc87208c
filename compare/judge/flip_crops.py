"""FLIP evaluated only where it can be non-zero.

FLIP at a pixel is a function of both images within FLIP_REACH pixels of it (its widest
filters at 67 ppd, the CSF's and the feature detector's, reach 10 px; tests pin it). Where
the two images are equal over that whole neighbourhood, every filtered value, hence the
pixel's FLIP, is exactly 0. So NVIDIA's flip-evaluator runs here over crops that cover the
pixels near a difference, each crop widened by the reach, and the rest of the map is 0: the
whole-image evaluation's values, at a cost in proportion to the pixels that differ (a render
under a constant sky differs from the reference in a fraction of its pixels).

HDR-FLIP (Andersson et al. 2021) is the maximum of LDR-FLIP over exposures of the two
images, each tone mapped (ACES fit) to [0, 1]. Its exposures come from the whole reference:
the start exposure maps the reference's largest luminance, the stop exposure its median, to
the tone mapper's 0.85; their number is max(2, ceil(stop - start)), evenly spaced. A
reference of small dynamic range (a white sky seen directly and in mirrors: maximum =
median) has start = stop, and the exposures that coincide are evaluated once.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from compare.judge.arrays import F32

BOOL = NDArray[np.bool_]
FLIP_PPD = 67.0
FLIP_REACH = 10  # the filters' reach at 67 ppd (tests/test_flip_crops.py: 9 is short)
CALL_COST = 1024  # pixels' worth of one flip-evaluator call's fixed cost
MIN_SIDE = 32  # boxes this small are not split further
# ACES filmic fit (Narkowicz 2016) with its 0.6 pre-exposure folded in, as HDR-FLIP uses
# it: (k0 x^2 + k1 x + k2) / (k3 x^2 + k4 x + k5).
ACES = tuple(
    np.float32(k) for k in (0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14)
)
TONE_TARGET = 0.85  # the tone-mapped value the start and stop exposures aim at
SAME_EXPOSURE = 1e-4  # stops: exposures this close give the same map up to float noise


def _dilate(mask: BOOL, reach: int) -> BOOL:
    """Pixels within `reach` (Chebyshev) of a True pixel: a square window is separable, so
    rows then columns, each window's count from a cumulative sum (no scipy to import: it
    costs a diagnosis more than its FLIP)."""
    return _dilate_axis(_dilate_axis(mask, reach, 0), reach, 1)


def _dilate_axis(mask: BOOL, reach: int, axis: int) -> BOOL:
    n = mask.shape[axis]
    pad = [(0, 0), (0, 0)]
    pad[axis] = (reach + 1, reach)
    counts = np.cumsum(np.pad(mask, pad).astype(np.int32), axis=axis)
    hi = np.take(counts, np.arange(2 * reach + 1, 2 * reach + 1 + n), axis=axis)
    lo = np.take(counts, np.arange(0, n), axis=axis)
    return np.asarray(hi - lo > 0, bool)


Box = tuple[int, int, int, int]  # y0, y1, x0, x1


def _cost(box: Box, reach: int) -> int:
    """Pixels FLIP evaluates for a box (widened by the reach) plus a call's fixed cost."""
    y0, y1, x0, x1 = box
    return (y1 - y0 + 2 * reach) * (x1 - x0 + 2 * reach) + CALL_COST


def _cover(need: BOOL, box: Box, reach: int) -> list[Box]:
    """Boxes covering the True pixels of `need` inside `box`: its tight bounding box, or
    the covers of its two halves (split across its longer side) where they cost less."""
    y0, y1, x0, x1 = box
    sub = need[y0:y1, x0:x1]
    rows, cols = np.flatnonzero(sub.any(axis=1)), np.flatnonzero(sub.any(axis=0))
    if rows.size == 0:
        return []
    y0, y1, x0, x1 = (
        y0 + int(rows[0]),
        y0 + int(rows[-1]) + 1,
        x0 + int(cols[0]),
        x0 + int(cols[-1]) + 1,
    )
    tight = (y0, y1, x0, x1)
    if max(y1 - y0, x1 - x0) <= MIN_SIDE:
        return [tight]
    if y1 - y0 >= x1 - x0:
        mid = (y0 + y1) // 2
        halves = [(y0, mid, x0, x1), (mid, y1, x0, x1)]
    else:
        mid = (x0 + x1) // 2
        halves = [(y0, y1, x0, mid), (y0, y1, mid, x1)]
    split = [b for half in halves for b in _cover(need, half, reach)]
    return split if sum(_cost(b, reach) for b in split) < _cost(tight, reach) else [tight]


def crops(changed: BOOL, reach: int = FLIP_REACH) -> list[Box]:
    """Boxes (y0, y1, x0, x1) that cover every pixel within `reach` of a changed pixel, at
    a small total cost (_cover)."""
    need = _dilate(changed, reach)
    return _cover(need, (0, need.shape[0], 0, need.shape[1]), reach)


def _ldr_flip(ref: F32, test: F32, srgb: bool) -> F32:
    import flip_evaluator

    out = flip_evaluator.evaluate(
        np.ascontiguousarray(ref),
        np.ascontiguousarray(test),
        "LDR",
        inputsRGB=srgb,
        applyMagma=False,
        parameters={"ppd": FLIP_PPD},
    )[0]
    return np.asarray(out, np.float32).reshape(ref.shape[:2])


def cropped_ldr_flip(ref: F32, test: F32, *, srgb: bool = True) -> F32:
    """LDR-FLIP map of two [0, 1] images (sRGB-encoded, or linear with srgb=False), computed
    over the crops around their differences; 0 elsewhere (the map of test against itself)."""
    return updated_ldr_flip(ref, test, test, np.zeros(ref.shape[:2], np.float32), srgb=srgb)


def updated_ldr_flip(
    ref: F32,
    test: F32,
    known_ref: F32,
    known: F32,
    *,
    srgb: bool = True,
    stale: BOOL | None = None,
) -> F32:
    """The LDR-FLIP map of (ref, test) from `known`, the map of (known_ref, test): a pixel
    whose neighbourhood (FLIP_REACH) is the same in ref as in known_ref keeps its value
    there, the crops around where they differ are evaluated again. `stale`: where `known`
    was not computed (it holds 0 there, and the values next to it are a crop's at least
    2 x FLIP_REACH inside that crop's edge): the crops around the stale pixels where ref and
    test differ are evaluated too (where they agree over a neighbourhood, FLIP is 0)."""
    h, w = ref.shape[:2]
    out = known.copy()
    r = FLIP_REACH
    changed = np.asarray((ref != known_ref).any(axis=-1), bool)
    if stale is not None:
        changed |= stale & (ref != test).any(axis=-1)
    for y0, y1, x0, x1 in crops(changed):
        cy0, cy1, cx0, cx1 = max(0, y0 - r), min(h, y1 + r), max(0, x0 - r), min(w, x1 + r)
        part = _ldr_flip(ref[cy0:cy1, cx0:cx1], test[cy0:cy1, cx0:cx1], srgb)
        out[y0:y1, x0:x1] = part[y0 - cy0 : y1 - cy0, x0 - cx0 : x1 - cx0]
    return out


def _aces(x: F32) -> F32:
    k0, k1, k2, k3, k4, k5 = ACES
    return np.clip((k0 * x * x + k1 * x + k2) / (k3 * x * x + k4 * x + k5), 0, 1).astype(np.float32)


def _aces_input(t: float) -> np.float32:
    """The input the ACES fit maps to t (the positive root of its quadratic)."""
    k0, k1, k2, k3, k4, k5 = ACES
    tt = np.float32(t)
    c0 = (k1 - k4 * tt) / (k0 - k3 * tt)
    c1 = (k2 - k5 * tt) / (k0 - k3 * tt)
    return np.float32(-0.5 * c0 + np.sqrt((0.5 * c0) ** 2 - c1))


def hdr_exposures(ref: F32) -> list[float]:
    """HDR-FLIP's exposures (stops) for a non-negative reference with some light, in float32
    as flip-evaluator computes them (its reported start and stop, bit for bit); coinciding
    ones once."""
    lum = (
        ref[..., 0] * np.float32(0.2126)
        + ref[..., 1] * np.float32(0.7152)
        + ref[..., 2] * np.float32(0.0722)
    ).ravel()
    # flip-evaluator floors the median at float32's epsilon: a mostly black reference
    # spans some 24 stops, from its brightest pixel down to there.
    median = max(np.partition(lum, lum.size // 2)[lum.size // 2], np.finfo(np.float32).eps)
    x = _aces_input(TONE_TARGET)
    start, stop = np.log2(x / lum.max()), np.log2(x / median)
    count = max(2, math.ceil(stop - start))  # float32, as flip-evaluator counts them
    step = (stop - start) / np.float32(count - 1)
    exposures = [float(start + np.float32(i) * step) for i in range(count)]
    return exposures if stop - start > SAME_EXPOSURE else exposures[:1]


def cropped_hdr_flip(ref: F32, test: F32) -> F32:
    """HDR-FLIP map of two non-negative linear images: the maximum over hdr_exposures(ref)
    of the LDR-FLIP of both, exposed and tone mapped, each over the crops of their
    differences."""
    out = np.zeros(ref.shape[:2], np.float32)
    for exposure in hdr_exposures(ref):
        scale = np.exp2(np.float32(exposure))
        a, b = _aces(ref * scale), _aces(test * scale)
        np.maximum(out, cropped_ldr_flip(a, b, srgb=False), out=out)
    return out
