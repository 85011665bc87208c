"""Scores and pass/fail per effect, read from an evaluation (rubric rules applied).

Defaults (a rubric may override them): an effect passes with mean LDR FLIP <= 0.10 over its
pixels and SSIM >= 0.5. FLIP decides; SSIM is only a floor against broken structure, because
display-space SSIM collapses on faint noise in near-black regions (a render with linear noise
of sigma 0.002 scores SSIM 0.65 in the classic scene's shadows at FLIP 0.04). An effect's
score is 100 (1 - FLIP / flip_at_zero), clamped to [0, 100] (flip_at_zero defaults to 0.5:
half the perceptual range scores nothing). The overall score is the mean of the effect scores
weighted by pixel count times the rule's weight; the verdict passes when every effect does
(and, with `pass_score`, when the overall score reaches it). An effect whose mask has no
pixels does not occur in the scene: it has no score, is not counted in the overall score
and is listed as absent (`absent_effects`), so that a page can say so.

Against a demo model the basis is the exact match instead (score_exact): an effect passes when
no more of its pixels differ from the model beyond the test's quantisation than the stray
allowance, ceil(sqrt(pixels) / 16), at most 1 % and at least 1 (exact_match.py). A passing
effect scores 100 (its strays are the float chaos a correct program shows), a failing one 100 x
the share of its pixels that match. FLIP is then only evidence in the reason of a failing
effect.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from compare.judge.metrics import Metrics

if TYPE_CHECKING:
    from compare.judge.exact_match import ExactMatch

FLIP_AT_ZERO_SCORE = 0.5
ABSENT = "does not occur in this scene"


@dataclass(frozen=True)
class EffectRule:
    """One effect's rule, as a rubric's [effects.NAME] table sets it.

    Attributes
    ----------
    min_ssim : float
        The effect fails with a mean SSIM below this, or undefined; default 0.5.
    max_flip : float
        The effect fails with a mean LDR FLIP above this, or NaN; default 0.10.
    weight : float
        Multiplies the effect's pixel count, its weight in the overall score; default 1.0.
        The only part that applies against a demo model (the exact match decides there).
    """

    min_ssim: float = 0.5
    max_flip: float = 0.10
    weight: float = 1.0


@dataclass(frozen=True)
class EffectScore:
    """One effect's score and pass or fail.

    Attributes
    ----------
    status : str
        "pass" or "fail".
    score : float
        From 0 to 100: 100 (1 - FLIP / flip_at_zero), clamped; against a demo model, 100 when
        it passes, else 100 times the share of the effect's pixels that match it.
    reasons : list[str]
        Why it fails ("FLIP 0.310 > 0.1"); empty when it passes.
    pixels : int
        The effect's pixels.
    ssim : float or None
        Mean SSIM; None when undefined (the image is smaller than SSIM's window) or
        against a demo model.
    flip : float or None
        Mean LDR FLIP; None when not computed (an effect that matches its demo model
        exactly).
    rule : EffectRule
        The rule it was judged by.
    differing : int or None
        Against a demo model, the pixels that differ from it; default None (FLIP basis).
    """

    status: str
    score: float
    reasons: list[str]
    pixels: int
    ssim: float | None
    flip: float | None
    rule: EffectRule
    differing: int | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "score": self.score,
            "reasons": self.reasons,
            "pixels": self.pixels,
            "ssim": self.ssim,
            "flip": self.flip,
            "differing": self.differing,
            "rule": {
                "min_ssim": self.rule.min_ssim,
                "max_flip": self.rule.max_flip,
                "weight": self.rule.weight,
            },
        }


@dataclass(frozen=True)
class Score:
    """The scored verdict of one image: the overall score and each effect's.

    Attributes
    ----------
    status : str
        "pass" when every effect passes (at least one is scored) and, with `pass_score`,
        the overall score reaches it; else "fail".
    score : float
        The overall score, 0 to 100: the effect scores weighted by pixels times their rule's
        weight (by pixels alone when no weighted effect occurs; 0 without effects).
    effects : dict[str, EffectScore]
        Each scored effect's score by name; default empty.
    flip_at_zero_score : float
        The mean FLIP that scores 0; default FLIP_AT_ZERO_SCORE (0.5).
    pass_score : float or None
        The overall score needed to pass; default None: none.
    basis : str
        "flip" (default): the rubric's FLIP and SSIM rules; "exact": the exact match
        against a demo model.
    absent : tuple[str, ...]
        Effects whose masks have no pixels: not scored, not counted; default ().
    """

    status: str
    score: float
    effects: dict[str, EffectScore] = field(default_factory=dict)
    flip_at_zero_score: float = FLIP_AT_ZERO_SCORE
    pass_score: float | None = None
    basis: str = "flip"
    absent: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "score": self.score,
            "basis": self.basis,
            "effects": {k: e.as_dict() for k, e in self.effects.items()},
            "absent_effects": dict.fromkeys(self.absent, ABSENT),
            "flip_at_zero_score": self.flip_at_zero_score,
            "pass_score": self.pass_score,
        }

    def reasons(self) -> list[str]:
        """Why it fails, one line per failing effect, the worst first ("refraction: FLIP 0.310
        > 0.1"), then the overall score when it is short of pass_score."""
        out = [f"{k}: {'; '.join(self.effects[k].reasons)}" for k in self.failing_effects]
        if self.pass_score is not None and self.score < self.pass_score:
            out.append(f"score {self.score:.1f} < {self.pass_score:g}")
        return out

    @property
    def failing_effects(self) -> list[str]:
        """Failing effects, the worst (most score lost, weighted) first."""
        bad = [(k, e) for k, e in self.effects.items() if e.status != "pass"]
        bad.sort(
            key=lambda kv: (100.0 - kv[1].score) * kv[1].pixels * kv[1].rule.weight, reverse=True
        )
        return [k for k, _ in bad]


def effect_score(flip: float, flip_at_zero: float = FLIP_AT_ZERO_SCORE) -> float:
    """100 at FLIP 0, 0 at FLIP >= flip_at_zero, linear between."""
    return min(100.0, max(0.0, 100.0 * (1.0 - flip / flip_at_zero)))


def score_effect(m: Metrics, rule: EffectRule, flip_at_zero: float) -> EffectScore:
    ssim: float | None = m.ssim if m.ssim == m.ssim else None  # NaN: window too small
    flip = m.flip_ldr
    reasons = []
    if ssim is None or not ssim >= rule.min_ssim:
        reasons.append(
            f"SSIM {ssim:.3f} < {rule.min_ssim}" if ssim is not None else "SSIM undefined"
        )
    if not flip <= rule.max_flip:
        reasons.append(f"FLIP {flip:.3f} > {rule.max_flip}")
    return EffectScore(
        "fail" if reasons else "pass",
        effect_score(flip, flip_at_zero),
        reasons,
        m.pixels,
        ssim,
        flip,
        rule,
    )


@dataclass(frozen=True)
class Term:
    """One effect's part in the overall score."""

    pixels: int
    weight: float  # the rubric's
    score: float


def weighted_score(terms: Mapping[str, Term]) -> tuple[float, dict[str, float]]:
    """The overall score and each effect's share of it (docs/metrics.md, "Grades"): the
    effect scores weighted by pixels x weight; by pixels alone when no weighted effect
    occurs in the image (the rubric weights only effects the scene lacks). The verdict and
    `rtval grade --explain` both take their numbers from here."""
    total_w = sum(t.pixels * t.weight for t in terms.values())
    if total_w:
        overall = sum(t.pixels * t.weight * t.score for t in terms.values()) / total_w
        return overall, {k: t.pixels * t.weight / total_w for k, t in terms.items()}
    total_p = sum(t.pixels for t in terms.values())
    if not total_p:
        return 0.0, dict.fromkeys(terms, 0.0)
    overall = sum(t.pixels * t.score for t in terms.values()) / total_p
    return overall, {k: t.pixels / total_p for k, t in terms.items()}


def _overall(effects: dict[str, EffectScore]) -> float:
    terms = {k: Term(e.pixels, e.rule.weight, e.score) for k, e in effects.items()}
    return weighted_score(terms)[0]


def student_score(scene_scores: Sequence[float]) -> float:
    """A student's score: the mean of the scene scores (0 with no scene)."""
    return float(np.mean(scene_scores)) if scene_scores else 0.0


def student_passes(scene_statuses: Sequence[str], score: float, pass_score: float) -> bool:
    """Every scene passes and the mean reaches the rubric's pass score."""
    return bool(scene_statuses) and all(s == "pass" for s in scene_statuses) and score >= pass_score


def score_exact(
    exact: ExactMatch,
    flip_of: Callable[[str], float],
    rules: dict[str, EffectRule] | None = None,
    *,
    pass_score: float | None = None,
    absent: tuple[str, ...] = (),
) -> Score:
    """The exact match -> the scored verdict; `flip_of(effect)` is asked for failing effects
    only (it computes the FLIP map on first use). `absent`: effects with no pixels."""
    rules = rules or {}
    effects = {}
    for name, e in exact.per_effect.items():
        flip = None if e.passed else flip_of(name)
        reasons = [] if e.passed else [f"{exact.sentence(name)}; FLIP {flip:.2f}"]
        effects[name] = EffectScore(
            "pass" if e.passed else "fail",
            100.0 if e.passed else 100.0 * (1.0 - e.share),
            reasons,
            e.pixels,
            None,
            flip,
            rules.get(name, EffectRule()),
            e.differing,
        )
    overall = _overall(effects)
    ok = bool(effects) and all(e.status == "pass" for e in effects.values())
    if pass_score is not None and overall < pass_score:
        ok = False
    return Score(
        "pass" if ok else "fail",
        overall,
        effects,
        FLIP_AT_ZERO_SCORE,
        pass_score,
        "exact",
        _absent(absent, effects),
    )


def score_effects(
    per_effect: dict[str, Metrics],
    rules: dict[str, EffectRule] | None = None,
    *,
    flip_at_zero: float = FLIP_AT_ZERO_SCORE,
    pass_score: float | None = None,
    absent: tuple[str, ...] = (),
) -> Score:
    """Score each effect's metrics under its rule, and the image overall (FLIP basis).

    An effect fails with a mean SSIM below ``min_ssim`` or undefined, or a mean LDR FLIP
    above ``max_flip`` or NaN; it scores 100 (1 - FLIP / flip_at_zero), clamped to [0, 100].

    Parameters
    ----------
    per_effect : dict[str, Metrics]
        Each effect's metrics over its (non-empty) mask, by name.
    rules : dict[str, EffectRule] or None, optional
        Each effect's rule by name; an effect without one gets ``EffectRule()``. Default None.
    flip_at_zero : float, optional
        The mean FLIP that scores 0; default FLIP_AT_ZERO_SCORE (0.5).
    pass_score : float or None, optional
        The overall score needed to pass; default None: passing every effect suffices.
    absent : tuple[str, ...], optional
        Effects whose masks have no pixels (they have no metrics either); default ().

    Returns
    -------
    Score
        With ``basis`` "flip"; fails when no effect is scored.
    """
    rules = rules or {}
    effects = {
        name: score_effect(m, rules.get(name, EffectRule()), flip_at_zero)
        for name, m in per_effect.items()
    }
    overall = _overall(effects)
    ok = bool(effects) and all(e.status == "pass" for e in effects.values())
    if pass_score is not None and overall < pass_score:
        ok = False
    return Score(
        "pass" if ok else "fail",
        overall,
        effects,
        flip_at_zero,
        pass_score,
        absent=_absent(absent, effects),
    )


def _absent(absent: tuple[str, ...], effects: dict[str, EffectScore]) -> tuple[str, ...]:
    """The absent effects, once each; one that was scored is not absent."""
    return tuple(k for k in dict.fromkeys(absent) if k not in effects)
