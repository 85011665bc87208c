"""The one evaluation of an image pair, used by every command (compare, check, report, grade,
stress): reference and test (linear RGB), optional effect masks, a region of interest, the
per-pixel tolerances and the rubric's rules in; a typed result out. The expensive maps (SSIM,
FLIP) are computed once per pair; every region only indexes them. Verdicts, scores and
sentences read the result."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from compare.judge.effects import EFFECTS
from compare.judge.metrics import BOOL, F32, Maps, Metrics, compute_maps, compute_metrics
from compare.judge.scoring import FLIP_AT_ZERO_SCORE, EffectRule, Score, score_effects
from compare.judge.tolerances import Tolerances, Verdict, judge


@dataclass(frozen=True)
class EffectResult:
    metrics: Metrics
    verdict: Verdict  # the per-pixel tolerances inside this effect's pixels


@dataclass
class Evaluation:
    ref: F32
    test: F32
    maps: Maps
    metrics: Metrics  # over the region of interest (every pixel without one)
    verdict: Verdict  # the per-pixel tolerances over the same pixels
    tolerances: Tolerances
    masks: dict[str, BOOL] = field(default_factory=dict)
    per_effect: dict[str, EffectResult] = field(default_factory=dict)
    score: Score | None = None  # with effect masks: the rubric's scored verdict

    def effect_metrics(self) -> dict[str, Metrics]:
        return {k: v.metrics for k, v in self.per_effect.items()}


def evaluate_pair(
    ref: F32,
    test: F32,
    *,
    hdr: bool = False,
    tolerances: Tolerances = Tolerances(),
    region: BOOL | None = None,
    masks: dict[str, BOOL] | None = None,
    rules: dict[str, EffectRule] | None = None,
    flip_at_zero: float = FLIP_AT_ZERO_SCORE,
    pass_score: float | None = None,
) -> Evaluation:
    """Every metric of `test` against `ref`, globally (over `region`) and per effect (over each
    non-empty mask, intersected with `region`), the tolerance verdicts and, with masks, the
    score under `rules`. Raises metrics.SizeMismatch for images of different sizes."""
    maps = compute_maps(ref, test, hdr=hdr)
    metrics = compute_metrics(ref, test, maps, mask=region, threshold=tolerances.fail)
    result = Evaluation(
        ref,
        test,
        maps,
        metrics,
        judge(metrics, maps, tolerances, region),
        tolerances,
        dict(masks or {}),
    )
    for name in EFFECTS:
        if name not in result.masks:
            continue
        pixels = result.masks[name] if region is None else result.masks[name] & region
        if not np.any(pixels):
            continue
        m = compute_metrics(ref, test, maps, mask=pixels, threshold=tolerances.fail)
        result.per_effect[name] = EffectResult(m, judge(m, maps, tolerances, pixels))
    if result.masks:
        result.score = score_effects(
            result.effect_metrics(), rules, flip_at_zero=flip_at_zero, pass_score=pass_score
        )
    return result
