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
order, which moves a smooth pixel's value by far less. A NaN in the model (classic mode's Q3)
is written as 0 or 255 by C programs (std::min(1.f, NaN) is 1; a cast of NaN is 0 on x86):
both match.

Where the model is numerically unstable (a ray grazing a silhouette, directly or seen in a
mirror; a deep chain of glass), two correct programs can disagree by many codes. The model is
therefore also rendered with the camera turned by tiny fractions of a pixel
(compare/render/models.py); the largest move u of any of those renders is the model's own
spread at that pixel, and a test value within x -/+ u (stored as above) matches: "unstable".
Where the renders agree, u is 0 and the rule is the one above.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from compare.judge.arrays import F32
from compare.judge.images import linear_to_srgb

BOOL = NDArray[np.bool_]
ENCODINGS = ("linear", "srgb", "float")
VALUE_SLACK = 2.0**-16
FLOAT_TOLERANCE = 2.0**-11
FLOAT_FLOOR = 2.0**-14
SPREAD_FACTOR = 1.0  # docs/metrics.md, "Exact match": the measurements behind it
# An effect passes with at most ceil(sqrt(pixels) / STRAY_DIVISOR) stray pixels (at most 1 % of
# a small effect, at least one): what float chaos alone leaves a correct program outside the
# model's spread. Chaos lives on curves (silhouettes, shadow edges), whose length grows as the
# square root of an effect's area; measured at most 3 per effect (docs/metrics.md).
STRAY_DIVISOR = 16
ENCODING_WORDS = {
    "linear": "8-bit linear quantisation",
    "srgb": "8-bit sRGB quantisation",
    "float": "half-float precision",
}


@dataclass(frozen=True)
class EffectMatch:
    pixels: int
    differing: int
    unstable: int  # matched only within the model's own spread (spread_bounds)
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
            "unstable": self.unstable,
            "allowed": self.allowed,
            "status": "pass" if self.passed else "fail",
        }


@dataclass(frozen=True)
class ExactMatch:
    """Which pixels of a test image are what a demo model computes, up to their storage.

    An effect (or, without masks, the region) passes with at most allowed_differing(pixels)
    differing pixels: ceil(sqrt(pixels) / 16), at most 1 %, at least 1.

    Attributes
    ----------
    model : str
        The demo model's name ("classic", "classic+Q2", ...).
    encoding : str
        How the test was stored: "linear" (8-bit, PPM), "srgb" (8-bit, PNG) or "float".
    matches : BOOL
        H x W: every channel is a way to store the model's value, or within its spread.
    unstable : BOOL
        H x W: matched, but only within the model's own spread (the perturbed renders).
    renders : int
        The model renders used: the pixel-centre one plus the perturbed ones.
    per_effect : dict[str, EffectMatch]
        Each effect's counts within the region, for the masks with pixels there; default
        empty.
    region : BOOL or None
        H x W pixels judged; default None: every pixel.
    differing : int
        Pixels of the region that do not match (read-only).
    unstable_pixels : int
        Pixels of the region that match only within the spread (read-only).
    passed : bool
        Every effect passes; without effects, the region does (read-only).
    """

    model: str
    encoding: str
    matches: BOOL
    unstable: BOOL
    renders: int
    per_effect: dict[str, EffectMatch] = field(default_factory=dict)
    region: BOOL | None = None

    @property
    def differing(self) -> int:
        m = ~self.matches if self.region is None else ~self.matches & self.region
        return int(m.sum())

    @property
    def unstable_pixels(self) -> int:
        a = self.unstable if self.region is None else self.unstable & self.region
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
            "unstable": self.unstable_pixels,
            "stray_rule": f"ceil(sqrt(pixels) / {STRAY_DIVISOR}), at most 1 %, at least 1",
            "per_effect": {k: e.as_dict() for k, e in self.per_effect.items()},
        }


def allowed_differing(pixels: int) -> int:
    return max(1, min(pixels // 100, math.ceil(math.sqrt(pixels) / STRAY_DIVISOR)))


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
    """The codes (or floats) that store the model's value `model` in `encoding`."""
    x = model.astype(np.float64)
    return interval_bounds(x, x, encoding)


def interval_bounds(low: NDArray[np.float64], high: NDArray[np.float64], encoding: str) -> Bounds:
    """The codes (or floats) that store some value in [low, high] (NaN where the model is)."""
    nan = np.isnan(low) | np.isnan(high)
    if encoding == "float":
        with np.errstate(invalid="ignore"):
            lo = low - FLOAT_TOLERANCE * np.maximum(np.abs(low), FLOAT_FLOOR)
            hi = high + FLOAT_TOLERANCE * np.maximum(np.abs(high), FLOAT_FLOOR)
        # an infinity allows only itself
        lo, hi = np.where(np.isinf(low), low, lo), np.where(np.isinf(high), high, hi)
    else:
        a, b = np.where(nan, 0.0, low), np.where(nan, 0.0, high)
        a = np.minimum(a * (1 - VALUE_SLACK), a * (1 + VALUE_SLACK))
        b = np.maximum(b * (1 - VALUE_SLACK), b * (1 + VALUE_SLACK))
        lo = np.floor(_encode(a, encoding))
        hi = np.floor(_encode(b, encoding) + 0.5)
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


def spread_bounds(renders: Sequence[F32], encoding: str) -> Bounds:
    """What the model itself could have produced at each pixel: its pixel-centre value x0 plus
    or minus its spread u, the largest move of any perturbed render (per channel). A perturbation
    far below any real feature moves a pixel only where the model is numerically unstable (a
    ray grazing a silhouette, a deep chain of glass and mirrors); another program's rounding
    moves it there by a like amount, either way. Where the renders agree, u is 0."""
    x0 = renders[0].astype(np.float64)
    u = np.zeros_like(x0)
    nan = np.isnan(x0)
    for r in renders[1:]:
        x = r.astype(np.float64)
        nan |= np.isnan(x)
        with np.errstate(invalid="ignore"):
            u = np.fmax(u, np.abs(x - x0))
    b = interval_bounds(x0 - SPREAD_FACTOR * u, x0 + SPREAD_FACTOR * u, encoding)
    return Bounds(b.lo, b.hi, b.nan | nan)


def model_bounds(renders: Sequence[F32], encoding: str) -> tuple[Bounds, Bounds]:
    """(pixel-centre bounds, spread bounds): all exact judging needs of the model."""
    return bounds(renders[0], encoding), spread_bounds(renders, encoding)


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
    """Judge `test` against a demo model's renders: is every pixel what the model computes?

    A test channel matches when it is a value the model's own float could have been stored
    as in `encoding`, or lies within the model's spread over its perturbed renders (where
    the model is numerically unstable); the module's docstring gives the rules.

    Parameters
    ----------
    renders : Sequence[F32]
        The model's linear renders, H x W x 3: ``renders[0]`` at pixel centres, the rest
        perturbed renders of it (the camera turned by fractions of a pixel).
    test : F32
        The test image, linear RGB H x W x 3 as read_image decoded it.
    encoding : {"linear", "srgb", "float"}
        How the test was stored (Image.encoding): 8-bit linear, 8-bit sRGB or float.
    model : str
        The model's name, for the sentences.
    masks : dict[str, BOOL] or None, optional
        Effect masks, H x W; each with pixels in the region is judged apart. Default None.
    region : BOOL or None, optional
        H x W pixels to judge; default None: every pixel.
    cache : dict[str, tuple[Bounds, Bounds]] or None, optional
        encoding -> model_bounds(renders, encoding), filled on first use; saves recomputing
        them for every image of a class. Default None: no cache.

    Returns
    -------
    ExactMatch

    Raises
    ------
    ValueError
        `encoding` is not one of ENCODINGS, or `renders` is empty.
    """
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding must be one of {', '.join(ENCODINGS)}, got {encoding!r}")
    if not renders:
        raise ValueError("exact_match needs at least the model's pixel-centre render")
    if cache is not None and encoding not in cache:
        cache[encoding] = model_bounds(renders, encoding)
    pair = cache[encoding] if cache is not None else model_bounds(renders, encoding)
    return match_bounds(pair, len(renders), test, encoding, model=model, masks=masks, region=region)


def match_bounds(
    pair: tuple[Bounds, Bounds],
    renders: int,
    test: F32,
    encoding: str,
    *,
    model: str,
    masks: dict[str, BOOL] | None = None,
    region: BOOL | None = None,
) -> ExactMatch:
    """exact_match from the model's bounds (model_bounds of its `renders` renders)."""
    centre_b, spread_b = pair
    t = _stored(test, encoding)
    centre = _within(centre_b, t, encoding, None)
    matches = centre.copy()
    rest = ~centre
    if rest.any():  # an exact image leaves a handful
        matches[rest] = _within(spread_b, t[rest], encoding, rest)
    unstable = matches & ~centre
    per_effect = {}
    for name, mask in (masks or {}).items():
        pixels = mask if region is None else mask & region
        n = int(pixels.sum())
        if not n:
            continue
        per_effect[name] = EffectMatch(
            n,
            int((~matches & pixels).sum()),
            int((unstable & pixels).sum()),
            allowed_differing(n),
        )
    return ExactMatch(model, encoding, matches, unstable, renders, per_effect, region)
