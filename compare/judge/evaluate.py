"""The one evaluation of an image pair, used by every command (compare, check, report, grade,
stress): reference and test (linear RGB), optional effect masks, a region of interest, the
per-pixel tolerances and the rubric's rules in; a typed result out. The expensive maps (SSIM,
FLIP) are computed once per pair, on first use; every region only indexes them. Verdicts,
scores and sentences read the result.

Judged against a demo model (`exact`: the model's renders and the test's encoding), the score
comes from the exact match (compare/judge/exact_match.py), and FLIP is computed only when an
effect fails it, for the reason's "FLIP 0.31": an exact image never pays for FLIP or SSIM.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TypedDict, Unpack

import numpy as np

from compare.judge.arrays import F32
from compare.judge.effects import EFFECTS
from compare.judge.exact_match import Bounds, ExactMatch, exact_match
from compare.judge.metrics import (
    BOOL,
    FLIP_MARGIN,
    Maps,
    Metrics,
    check_same_size,
    compute_maps,
    compute_metrics,
    flip_ldr_map,
)
from compare.judge.scoring import (
    FLIP_AT_ZERO_SCORE,
    EffectRule,
    Score,
    score_effects,
    score_exact,
)
from compare.judge.tolerances import Tolerances, Verdict, judge_metrics


@dataclass(frozen=True)
class EffectResult:
    """One effect's metrics and tolerance verdict, over its pixels within the region.

    Attributes
    ----------
    metrics : Metrics
        Every metric over the effect's pixels.
    verdict : Verdict
        The per-pixel tolerances inside the effect's pixels.
    """

    metrics: Metrics
    verdict: Verdict


@dataclass(frozen=True)
class ExactInputs:
    """What exact judging needs besides the reference (the model's pixel-centre render).

    Attributes
    ----------
    model : str
        The demo model's name ("classic", "classic+Q2", ...).
    offsets : Sequence[F32]
        The model's linear renders at sub-pixel offsets (the camera turned by fractions of
        a pixel), H x W x 3 each.
    encoding : str
        How the test was stored: "linear", "srgb" or "float" (Image.encoding).
    cache : dict[str, tuple[Bounds, Bounds]] or None
        encoding -> exact_match.model_bounds, kept across a class of images of one model;
        default None: no cache.
    """

    model: str
    offsets: Sequence[F32]
    encoding: str
    cache: dict[str, tuple[Bounds, Bounds]] | None = None


@dataclass
class Evaluation:
    """The evaluation of an image pair (evaluate_pair): metrics, verdicts and score.

    The maps, metrics, verdicts and per-effect results are computed on first use; the
    expensive maps (SSIM, FLIP) once, every region only indexes them.

    Attributes
    ----------
    ref, test : F32
        Reference and test, linear RGB, float32 H x W x 3.
    tolerances : Tolerances
        The per-pixel tolerances of every verdict.
    hdr : bool
        HDR inputs: the maps add HDR FLIP; default False.
    region : BOOL or None
        H x W region of interest; default None: every pixel.
    masks : dict[str, BOOL]
        Effect masks (H x W) by name; default empty.
    score : Score or None
        With effect masks, the rubric's (or, judged exactly, the exact) scored verdict;
        default None.
    exact : ExactMatch or None
        The exact match, when judged against a demo model; default None.
    flip : bool
        False: the maps' FLIP is NaN (evaluate_pair's cheap first look); default True.
    maps : Maps
        The whole image's per-pixel maps.
    metrics : Metrics
        Every metric over the region.
    verdict : Verdict
        The tolerances over the region; against a demo model, the exact match decides.
    per_effect : dict[str, EffectResult]
        Metrics and verdict of each effect with pixels in the region.
    absent_effects : tuple[str, ...]
        Effects whose mask has no pixel in the region: they have no metrics and no score.
    """

    ref: F32
    test: F32
    tolerances: Tolerances
    hdr: bool = False
    region: BOOL | None = None
    masks: dict[str, BOOL] = field(default_factory=dict)
    score: Score | None = None
    exact: ExactMatch | None = None
    flip: bool = True

    @cached_property
    def maps(self) -> Maps:
        return compute_maps(self.ref, self.test, hdr=self.hdr, flip=self.flip)

    @cached_property
    def metrics(self) -> Metrics:
        """Over the region of interest (every pixel without one)."""
        return compute_metrics(
            self.ref, self.test, self.maps, mask=self.region, threshold=self.tolerances.fail
        )

    @cached_property
    def verdict(self) -> Verdict:
        """The per-pixel tolerances over the same pixels; against a demo model, the exact
        match decides instead."""
        if self.exact is not None:
            return Verdict(
                "pass" if self.exact.passed else "fail",
                [] if self.exact.passed else self.exact_reasons(),
                failing_pixels=self.exact.differing,
            )
        return judge_metrics(self.metrics, self.maps, self.tolerances, self.region)

    @cached_property
    def per_effect(self) -> dict[str, EffectResult]:
        out = {}
        for name in EFFECTS:
            pixels = self._pixels(name)
            if pixels is None:
                continue
            m = compute_metrics(
                self.ref, self.test, self.maps, mask=pixels, threshold=self.tolerances.fail
            )
            out[name] = EffectResult(m, judge_metrics(m, self.maps, self.tolerances, pixels))
        return out

    def _pixels(self, name: str) -> BOOL | None:
        if name not in self.masks:
            return None
        pixels = self.masks[name] if self.region is None else self.masks[name] & self.region
        return pixels if np.any(pixels) else None

    def effect_flip(self, name: str) -> float:
        """Mean LDR FLIP over one effect's pixels. Judged exactly, before the full maps exist,
        FLIP is computed only over the crop around the effects that fail (the maps are
        unchanged inside it, metrics.FLIP_MARGIN)."""
        pixels = self._pixels(name)
        if pixels is None:
            return float("nan")
        if "maps" in self.__dict__ or self.exact is None:
            return float(self.maps.flip_ldr[pixels].mean())
        (y0, x0), crop = self._failing_flip
        h, w = crop.shape
        inside = pixels[y0 : y0 + h, x0 : x0 + w]
        if int(inside.sum()) != int(pixels.sum()):  # not a failing effect: the whole map
            return float(self.maps.flip_ldr[pixels].mean())
        return float(crop[inside].mean())

    @cached_property
    def _failing_flip(self) -> tuple[tuple[int, int], F32]:
        assert self.exact is not None
        union: BOOL = np.zeros(self.ref.shape[:2], bool)
        for k, e in self.exact.per_effect.items():
            if not e.passed:
                union |= self.masks[k]
        if not union.any():
            union[0, 0] = True  # asked for no failing effect: a tiny crop, never read
        found = np.nonzero(union)
        ys, xs = found[0], found[1]
        h, w = union.shape[:2]
        y0, y1 = max(0, int(ys.min()) - FLIP_MARGIN), min(h, int(ys.max()) + 1 + FLIP_MARGIN)
        x0, x1 = max(0, int(xs.min()) - FLIP_MARGIN), min(w, int(xs.max()) + 1 + FLIP_MARGIN)
        return (y0, x0), flip_ldr_map(self.ref[y0:y1, x0:x1], self.test[y0:y1, x0:x1])

    def known_flip(self) -> tuple[F32, BOOL] | None:
        """The whole image's LDR-FLIP values computed so far (metrics.flip_ldr_map of ref
        and test; 0 outside the failing effects' crop) and where they hold: inside that crop
        less its margin (FLIP_MARGIN, twice the filters' reach, on the sides inside the
        image), as flip_crops.updated_ldr_flip takes them. None before any is computed."""
        if "_failing_flip" not in self.__dict__:
            return None
        (y0, x0), crop = self._failing_flip
        h, w = self.ref.shape[:2]
        y1, x1 = y0 + crop.shape[0], x0 + crop.shape[1]
        flip = np.zeros((h, w), np.float32)
        flip[y0:y1, x0:x1] = crop
        valid = np.zeros((h, w), bool)
        m = FLIP_MARGIN
        valid[y0 + m * (y0 > 0) : y1 - m * (y1 < h), x0 + m * (x0 > 0) : x1 - m * (x1 < w)] = True
        return flip, valid

    def effect_metrics(self) -> dict[str, Metrics]:
        return {k: v.metrics for k, v in self.per_effect.items()}

    @property
    def absent_effects(self) -> tuple[str, ...]:
        """Effects whose mask (within the region) has no pixel: they do not occur here, so
        they have no metrics and no score."""
        return tuple(k for k in EFFECTS if k in self.masks and self._pixels(k) is None)

    def exact_reasons(self) -> list[str]:
        """'refraction: 2,310 px (41 %) differ from classic beyond 8-bit linear quantisation;
        FLIP 0.31' for every failing effect, the most differing first."""
        assert self.exact is not None
        if not self.exact.per_effect:
            return [] if self.exact.passed else [f"{self.exact.differing:,} px differ"]
        bad = [(k, e) for k, e in self.exact.per_effect.items() if not e.passed]
        bad.sort(key=lambda kv: kv[1].differing, reverse=True)
        return [f"{k}: {self.exact.sentence(k)}; FLIP {self.effect_flip(k):.2f}" for k, _ in bad]


class PairOptions(TypedDict, total=False):
    """evaluate_pair's options, keywords that may each be left out.

    Attributes
    ----------
    hdr : bool
        The inputs are HDR: the maps add HDR FLIP of the linear values. Default False.
    tolerances : Tolerances
        The per-pixel tolerances of every verdict. Default ``Tolerances()``.
    region : BOOL or None
        H x W region of interest: the global metrics cover it and every mask is
        intersected with it. Default None: every pixel.
    masks : dict[str, BOOL] or None
        Effect masks (effect_masks); each non-empty one is measured and judged apart, and
        with any, the result is scored. Default None.
    rules : dict[str, EffectRule] or None
        Each effect's scoring rule (a Rubric's effects); an effect without one gets
        ``EffectRule()``. Default None.
    flip_at_zero : float
        The mean FLIP that scores 0 (not used with `exact`). Default FLIP_AT_ZERO_SCORE.
    pass_score : float or None
        The overall score needed to pass. Default None: passing every effect suffices.
    flip : bool
        False leaves FLIP out of the maps: its metrics are NaN, so a ``max_flip`` tolerance
        fails. A cheap first look, whose verdict is final when it passes without
        ``max_flip``. Default True.
    exact : ExactInputs or None
        Judge against a demo model: `ref` is its pixel-centre render, and the verdict and
        score are the exact match's (FLIP is computed only for a failing effect's reason).
        Default None.
    scored : bool
        With `exact`, False stops at the exact match: no score, so no FLIP (a look at
        whether an image passes). Default True.
    """

    hdr: bool
    tolerances: Tolerances
    region: BOOL | None
    masks: dict[str, BOOL] | None
    rules: dict[str, EffectRule] | None
    flip_at_zero: float
    pass_score: float | None
    flip: bool
    exact: ExactInputs | None
    scored: bool


def evaluate_pair(ref: F32, test: F32, **options: Unpack[PairOptions]) -> Evaluation:
    """Every metric of `test` against `ref`, overall and per effect, with verdicts and score.

    Parameters
    ----------
    ref, test : F32
        Linear RGB, float32 H x W x 3, of one size (else SizeMismatch is raised).
    hdr : bool, default False
        HDR inputs: the maps add HDR FLIP of the linear values.
    tolerances : Tolerances, default Tolerances()
    region : BOOL or None, default None
        H x W pixels of interest (None: all); every mask is intersected with it.
    masks : dict[str, BOOL] or None, default None
        Effect masks (effect_masks); each non-empty one is judged apart, and the result scored.
    rules : dict[str, EffectRule] or None, default None
    flip_at_zero : float, default FLIP_AT_ZERO_SCORE
    pass_score : float or None, default None
    flip : bool, default True
        False leaves FLIP NaN, so `max_flip` fails: a cheap first look (see PairOptions).
    exact : ExactInputs or None, default None
        Judge against a demo model: `ref` is its pixel-centre render; the exact match decides.

    Returns
    -------
    Evaluation"""
    check_same_size(ref, test)
    region, masks = options.get("region"), options.get("masks")
    tolerances = options.get("tolerances", Tolerances())
    hdr, flip = options.get("hdr", False), options.get("flip", True)
    result = Evaluation(ref, test, tolerances, hdr, region, dict(masks or {}), flip=flip)
    rules, pass_score = options.get("rules"), options.get("pass_score")
    exact = options.get("exact")
    if exact is not None:
        result.exact = exact_match(
            [ref, *exact.offsets],
            test,
            exact.encoding,
            model=exact.model,
            masks=result.masks,
            region=region,
            cache=exact.cache,
        )
        if result.masks and options.get("scored", True):
            result.score = score_exact(
                result.exact,
                result.effect_flip,
                rules,
                pass_score=pass_score,
                absent=result.absent_effects,
            )
        return result
    if result.masks:
        result.score = score_effects(
            result.effect_metrics(),
            rules,
            flip_at_zero=options.get("flip_at_zero", FLIP_AT_ZERO_SCORE),
            pass_score=pass_score,
            absent=result.absent_effects,
        )
    return result
