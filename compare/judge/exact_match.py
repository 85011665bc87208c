"""Exact match against a demo model: is every pixel what the model computes, up to the way the
test image was stored? (docs/metrics.md, "Exact match".)

A test pixel matches when each channel is a value the model's own float could have been
written as in the test's encoding:

  linear  8-bit linear (PPM): code v matches model value x when v lies in
          [floor(255 c(x_lo)), floor(255 c(x_hi) + 0.5)], c = clamp to [0, 1]; the two ends are
          the truncating ((unsigned char)(x * 255)) and the rounding writer's codes
  srgb    8-bit sRGB (PNG): the same in the encoded domain, c = clamp then the sRGB curve
  float   EXR / PFM: |t - x| <= 2^-11 max(|x|, 2^-14): half-float precision, the coarsest
          float an EXR may hold

x_lo, x_hi = x (1 -/+ 2^-16): another float32 program evaluates the same formula in another
order; 2^-16 (256 float32 ulps) covers that through the scene's ray tree, and only moves a
code when x sits on a code boundary. A NaN in the model (classic mode's Q3) is written as
0 or 255 by C programs (std::min(1.f, NaN) is 1; a cast of NaN is 0 on x86): both match.

Pixels where the pixel-centre ray grazes a silhouette or a shadow edge have two right answers
between two float32 programs. The model is therefore also rendered with the camera turned by
a tiny fraction of a pixel (compare/render/models.py); a pixel matches when the test matches
any of those renders, and one that matches only a turned render is counted "edge-ambiguous".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from compare.judge.images import linear_to_srgb

F32 = NDArray[np.float32]
BOOL = NDArray[np.bool_]
ENCODINGS = ("linear", "srgb", "float")
VALUE_SLACK = 2.0**-16
FLOAT_TOLERANCE = 2.0**-11
FLOAT_FLOOR = 2.0**-14
# An effect passes when at most this share of its pixels differ (and always with one stray
# pixel): an exact implementation differs nowhere once edge-ambiguous pixels are accepted.
MAX_DIFFERING_SHARE = 0.001
ENCODING_WORDS = {
    "linear": "8-bit linear quantisation",
    "srgb": "8-bit sRGB quantisation",
    "float": "half-float precision",
}


@dataclass(frozen=True)
class EffectMatch:
    pixels: int
    differing: int
    ambiguous: int  # matched only a render at a sub-pixel offset
    allowed: int  # differing pixels allowed

    @property
    def share(self) -> float:
        return self.differing / self.pixels if self.pixels else 0.0

    @property
    def passed(self) -> bool:
        return self.differing <= self.allowed

    def as_dict(self) -> dict[str, Any]:
        return {
            "pixels": self.pixels,
            "differing": self.differing,
            "differing_share": self.share,
            "edge_ambiguous": self.ambiguous,
            "allowed": self.allowed,
            "status": "pass" if self.passed else "fail",
        }


@dataclass(frozen=True)
class ExactMatch:
    model: str
    encoding: str
    matches: BOOL  # H x W: within quantisation of some model render
    ambiguous: BOOL  # H x W: matched, but not the pixel-centre render
    renders: int  # model renders used (the centre one plus the offsets)
    per_effect: dict[str, EffectMatch] = field(default_factory=dict)
    region: BOOL | None = None

    @property
    def differing(self) -> int:
        m = ~self.matches if self.region is None else ~self.matches & self.region
        return int(m.sum())

    @property
    def edge_ambiguous(self) -> int:
        a = self.ambiguous if self.region is None else self.ambiguous & self.region
        return int(a.sum())

    @property
    def passed(self) -> bool:
        if self.per_effect:
            return all(e.passed for e in self.per_effect.values())
        n = int(self.matches.size if self.region is None else self.region.sum())
        return self.differing <= allowed_differing(n)

    def sentence(self, effect: str) -> str:
        """'2,310 px (41 %) differ from classic beyond 8-bit linear quantisation'."""
        e = self.per_effect[effect]
        pct = 100 * e.share
        share = f"{pct:.0f}" if pct >= 10 else f"{pct:.2g}"  # .2g alone writes 100 as 1e+02
        return (
            f"{e.differing:,} px ({share} %) differ from {self.model} beyond "
            f"{ENCODING_WORDS[self.encoding]}"
        )

    def as_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "encoding": self.encoding,
            "rule": ENCODING_WORDS[self.encoding],
            "renders": self.renders,
            "status": "pass" if self.passed else "fail",
            "differing": self.differing,
            "edge_ambiguous": self.edge_ambiguous,
            "max_differing_share": MAX_DIFFERING_SHARE,
            "per_effect": {k: e.as_dict() for k, e in self.per_effect.items()},
        }


def allowed_differing(pixels: int) -> int:
    return max(1, int(MAX_DIFFERING_SHARE * pixels))


def _encode(v: NDArray[np.float64], encoding: str) -> NDArray[np.float64]:
    c = np.clip(v, 0.0, 1.0)
    if encoding == "srgb":
        c = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return np.asarray(255.0 * c)


def stored_codes(test: F32, encoding: str) -> NDArray[np.float64]:
    """The 8-bit codes the test image was read from (read_image decoded them to linear)."""
    if encoding == "srgb":
        return np.asarray(np.rint(255.0 * linear_to_srgb(test).astype(np.float64)))
    return np.asarray(np.rint(255.0 * np.nan_to_num(test.astype(np.float64), nan=0.0)))


@dataclass(frozen=True)
class Bounds:
    """What a model render allows per channel in one encoding: [lo, hi] (8-bit codes, or float
    values), and where the model is NaN. Computed once per model and encoding (the grading
    workers keep them), so judging an image is only comparisons."""

    lo: NDArray[np.float32]
    hi: NDArray[np.float32]
    nan: BOOL


def bounds(model: F32, encoding: str) -> Bounds:
    x = model.astype(np.float64)
    nan = np.isnan(x)
    if encoding == "float":
        with np.errstate(invalid="ignore"):
            tol = FLOAT_TOLERANCE * np.maximum(np.abs(x), FLOAT_FLOOR)
        inf = np.isinf(x)  # an infinity allows only itself
        lo, hi = np.where(inf, x, x - tol), np.where(inf, x, x + tol)
    else:
        x0 = np.where(nan, 0.0, x)
        a, b = x0 * (1 - VALUE_SLACK), x0 * (1 + VALUE_SLACK)
        lo = np.floor(_encode(np.minimum(a, b), encoding))
        hi = np.floor(_encode(np.maximum(a, b), encoding) + 0.5)
    return Bounds(lo.astype(np.float32), hi.astype(np.float32), nan)


def _within(b: Bounds, t: NDArray[np.float64], encoding: str, where: BOOL | None) -> BOOL:
    lo, hi, nan = (b.lo, b.hi, b.nan) if where is None else (b.lo[where], b.hi[where], b.nan[where])
    with np.errstate(invalid="ignore"):
        inside = (t >= lo) & (t <= hi)
    if encoding == "float":
        ok = (inside & ~nan) | (nan & np.isnan(t))
    else:
        ok = (inside & ~nan) | (nan & ((t == 0) | (t == 255)))
    return np.asarray(ok.all(axis=-1))


def _stored(test: F32, encoding: str) -> NDArray[np.float64]:
    return test.astype(np.float64) if encoding == "float" else stored_codes(test, encoding)


def channel_matches(model: F32, test: F32, encoding: str) -> BOOL:
    """H x W: every channel of the test is a way to store the model's value (module doc)."""
    return _within(bounds(model, encoding), _stored(test, encoding), encoding, None)


def hull(parts: Sequence[Bounds]) -> Bounds:
    """Everything any of the renders allows, per channel: the model's own spread. Where its
    renders agree this is the pixel-centre render's bounds; where they disagree (a ray grazing
    a silhouette, a chaotic chain of glass and mirrors) every value between them is one the
    model itself could have produced."""
    lo = np.minimum.reduce([b.lo for b in parts])
    hi = np.maximum.reduce([b.hi for b in parts])
    nan = np.logical_or.reduce([b.nan for b in parts])
    return Bounds(lo, hi, nan)


def model_bounds(renders: Sequence[F32], encoding: str) -> tuple[Bounds, Bounds]:
    """(pixel-centre bounds, hull of every render's bounds): all exact judging needs."""
    parts = [bounds(r, encoding) for r in renders]
    return parts[0], hull(parts)


def exact_match(
    renders: Sequence[F32],
    test: F32,
    encoding: str,
    *,
    model: str,
    masks: dict[str, BOOL] | None = None,
    region: BOOL | None = None,
    cache: dict[str, tuple[Bounds, Bounds]] | None = None,
) -> ExactMatch:
    """`renders[0]` is the model at pixel centres, the rest perturbed renders of it. `cache`
    (encoding -> model_bounds) saves recomputing them for every image of a class."""
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding must be one of {', '.join(ENCODINGS)}, got {encoding!r}")
    if not renders:
        raise ValueError("exact_match needs at least the model's pixel-centre render")
    if cache is not None and encoding not in cache:
        cache[encoding] = model_bounds(renders, encoding)
    centre_b, hull_b = cache[encoding] if cache is not None else model_bounds(renders, encoding)
    t = _stored(test, encoding)
    centre = _within(centre_b, t, encoding, None)
    matches = centre.copy()
    rest = ~centre
    if rest.any():  # an exact image leaves a handful
        matches[rest] = _within(hull_b, t[rest], encoding, rest)
    ambiguous = matches & ~centre
    per_effect = {}
    for name, mask in (masks or {}).items():
        pixels = mask if region is None else mask & region
        n = int(pixels.sum())
        if not n:
            continue
        per_effect[name] = EffectMatch(
            n,
            int((~matches & pixels).sum()),
            int((ambiguous & pixels).sum()),
            allowed_differing(n),
        )
    return ExactMatch(model, encoding, matches, ambiguous, len(renders), per_effect, region)
