"""The report's analysis step: the verdict against Mitsuba, the sentences that say where the
image under test differs, what each effect contributes, penumbrae and time to converge; kept
in the cache by every input's hash (a warm run reads no render)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from compare.judge.convergence import mitsuba_to_converged, time_to_converged
from compare.judge.effects import EFFECTS
from compare.judge.metrics import Metrics, metrics_from_dict
from compare.judge.penumbra import penumbra_numbers
from compare.judge.scoring import score_effects
from compare.judge.sentences import contribution_sentence, difference_sentences
from compare.report.context import ReportContext
from compare.report.derived import judge_identity, memo_json
from compare.report.measure import Measured


@dataclass(frozen=True)
class Analysis:
    verdict: dict[str, Any]  # the image under test against Mitsuba, per effect
    absent: tuple[str, ...]  # effects that do not occur in the scene
    contributions: list[dict[str, Any]]
    sentences: list[Any]
    penumbra: dict[str, Any] | None
    converged: dict[str, Any]  # time to converge, the demo's and each Mitsuba's
    effect_pixels: dict[str, int]


def analyse(ctx: ReportContext, measured: Measured) -> Analysis:
    per_effect = measured.full(ctx.subject.key)["per_effect"]
    test_effects = {k: metrics_from_dict(v) for k, v in per_effect.items()}
    # The per-effect metrics leave out masks with no pixel: those effects do not occur.
    absent = tuple(k for k in EFFECTS if k not in test_effects)
    verdict = score_effects(test_effects, absent=absent).as_dict() | {"against": "mitsuba"}
    # Every input's hash, the labels and the judge's code: the same inputs, the same result.
    mitsuba = [(j.key, j.label) for j in ctx.plan.mitsuba()]
    inputs = json.dumps([ctx.hashes, ctx.subject.label, ctx.given, mitsuba], sort_keys=True)
    found = memo_json(
        ctx.cache, "analysis", inputs + judge_identity(), lambda: _compute(ctx, test_effects)
    )
    return Analysis(
        verdict,
        absent,
        found["contributions"],
        found["sentences"],
        found["penumbra"],
        _with_speedup(ctx, found["converged"]),
        found["effect_pixels"],
    )


def _compute(ctx: ReportContext, test_effects: dict[str, Metrics]) -> dict[str, Any]:
    imgs, rp = ctx.imgs, ctx.plan
    ref = imgs[rp.reference.key]
    penumbra = None
    if rp.area is not None:
        penumbra = penumbra_numbers(ref.rgb, imgs[rp.area.key].rgb, imgs[rp.penumbra_demo.key].rgb)
    sentences = difference_sentences(
        ref.rgb, imgs[ctx.subject.key].rgb, ctx.masks(), test_effects, ctx.subject.label
    )
    return {
        "contributions": [] if ctx.given else _contributions(ctx),
        "sentences": sentences,
        "penumbra": penumbra,
        "converged": _converged(ctx),
        "effect_pixels": {k: int(v.sum()) for k, v in ctx.masks().items()},
    }


def _contributions(ctx: ReportContext) -> list[dict[str, Any]]:
    """Effect contributions at pixel centres: what shadows / reflection / refraction add."""
    imgs, rp = ctx.imgs, ctx.plan
    if rp.centre_reference is None:
        return []
    centre = imgs[rp.centre_reference.key].rgb
    rows = []
    for ab in rp.ablations:
        for mode, without in ab.demo.items():
            said = contribution_sentence(
                ab.effect,
                imgs[ab.base[mode].key].rgb,
                imgs[without.key].rgb,
                centre,
                imgs[ab.reference.key].rgb,
                f"the demo ({mode} mode)",
            )
            rows.append({"mode": mode, **said})
    return rows


def _converged(ctx: ReportContext) -> dict[str, Any]:
    imgs, rp = ctx.imgs, ctx.plan
    ref = imgs[rp.reference.key]
    converged = time_to_converged(ref, {spp: imgs[j.key] for spp, j in rp.demo_convergence.items()})
    configurations = [
        {"key": j.key, "label": j.label, "spp": j.spp, "image": imgs[j.key]} for j in rp.mitsuba()
    ]
    same = {j.key for j in rp.same_estimator_as_reference}
    converged["mitsuba"] = mitsuba_to_converged(ref, configurations, same)
    return converged


def _with_speedup(ctx: ReportContext, converged: dict[str, Any]) -> dict[str, Any]:
    """The demo's converged render named, and its speed-up over the fastest Mitsuba."""
    if converged["demo_spp"]:
        demo_job = ctx.plan.demo_convergence[converged["demo_spp"]]
        converged["demo"] = {"key": demo_job.key, "label": demo_job.label}
    fastest = converged["mitsuba"]["fastest"]
    demo_seconds = converged["demo_seconds"]
    converged["speedup_vs_fastest_mitsuba"] = (
        fastest["seconds"] / demo_seconds
        if fastest and converged["demo_spp"] and demo_seconds and demo_seconds > 0
        else float("nan")
    )
    return converged
