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
    metrics: Metrics
    verdict: Verdict  # the per-pixel tolerances inside this effect's pixels


@dataclass(frozen=True)
class ExactInputs:
    """What exact judging needs besides the reference: the model's name, its renders at
    sub-pixel offsets (the reference is the pixel-centre one) and the test's encoding."""

    model: str
    offsets: Sequence[F32]
    encoding: str  # linear | srgb | float (images.Image.encoding)
    cache: dict[str, tuple[Bounds, Bounds]] | None = (
        None  # across a class (exact_match.model_bounds)
    )


@dataclass
class Evaluation:
    ref: F32
    test: F32
    tolerances: Tolerances
    hdr: bool = False
    region: BOOL | None = None
    masks: dict[str, BOOL] = field(default_factory=dict)
    score: Score | None = None  # with effect masks: the rubric's (or the exact) scored verdict
    exact: ExactMatch | None = None  # judged against a demo model
    flip: bool = True  # False: the maps' FLIP is NaN (evaluate_pair's cheap first look)

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
    """evaluate_pair's options; each is described in its docstring."""

    hdr: bool  # default False
    tolerances: Tolerances  # default Tolerances()
    region: BOOL | None
    masks: dict[str, BOOL] | None
    rules: dict[str, EffectRule] | None
    flip_at_zero: float  # default FLIP_AT_ZERO_SCORE
    pass_score: float | None
    flip: bool  # default True
    exact: ExactInputs | None


def evaluate_pair(ref: F32, test: F32, **options: Unpack[PairOptions]) -> Evaluation:
    """Every metric of `test` against `ref`, globally (over `region`) and per effect (over each
    non-empty mask, intersected with `region`), the tolerance verdicts and, with masks, the
    score under `rules`. With `exact`, `ref` is a demo model's pixel-centre render and the
    verdict and score are the exact match's. flip=False leaves FLIP out of the maps (its
    metrics are NaN, so a `max_flip` tolerance fails): a cheap first look whose verdict is
    final when it passes without `max_flip`. Raises metrics.SizeMismatch for images of
    different sizes."""

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
        if result.masks:
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
