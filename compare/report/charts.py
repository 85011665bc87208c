"""The report's charts: speed against accuracy (with its Pareto front), convergence (with the
fitted slopes) and the ablation ladder, as rows for report.json and figures in images/."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare.judge.pareto import pareto_front
from compare.report import figures as figs
from compare.report.context import ReportContext
from compare.report.derived import derived_figure, digest, figures_identity
from compare.report.measure import Measured
from safe_files.content import json_safe
from safe_files.paths import write_atomic

NO_CHANGE = "changes nothing in this scene"  # a ladder step whose render equals the last
PARETO_ERRORS = ("flip", "one_minus_ssim")
FIGURES = ("speed-accuracy", "convergence", "ablation-ladder")  # images/<name>.png


@dataclass(frozen=True)
class Charts:
    rows: list[dict[str, Any]]  # the speed-accuracy chart's points
    pareto: dict[str, list[dict[str, Any]]]  # error -> the renders no other beats
    slopes: dict[str, float]  # fitted convergence slopes by family
    ladder: list[dict[str, Any]]  # one row per ladder step


def draw_charts(ctx: ReportContext, measured: Measured) -> Charts:
    rows = chart_rows(ctx, measured)
    pareto = {
        error: [
            {k: r[k] for k in ("key", "label", "family", "spp", "seconds", error)}
            for r in pareto_front(rows, error)
        ]
        for error in PARETO_ERRORS
    }
    chart = json.dumps(json_safe(rows), sort_keys=True)
    derived_figure(
        ctx.cache,
        "speed-accuracy",
        chart,
        ctx.images_dir / "speed-accuracy.png",
        lambda p: figs.speed_accuracy_chart(rows, p),
    )
    slopes = _convergence(ctx, rows, chart)
    ladder = ladder_rows(ctx, measured)
    derived_figure(
        ctx.cache,
        "ladder",
        json.dumps(json_safe(ladder), sort_keys=True),
        ctx.images_dir / "ablation-ladder.png",
        lambda p: figs.ladder_chart(ladder, p),
    )
    return Charts(rows, pareto, slopes, ladder)


def chart_rows(ctx: ReportContext, measured: Measured) -> list[dict[str, Any]]:
    rows = []
    for j in ctx.plan.charted():
        g = measured.overall(j.key)
        rows.append(
            {
                "key": j.key,
                "label": j.label,
                "family": j.family,
                "spp": j.spp,
                "seconds": ctx.imgs.facts(j.key)["seconds"],
                "one_minus_ssim": max(1.0 - (g["ssim"] or 0.0), 1e-7),
                "flip": g["flip_ldr"],
                "rmse": g["rmse_display"],
            }
        )
    return rows


def _convergence(ctx: ReportContext, rows: list[dict[str, Any]], chart: str) -> dict[str, float]:
    """The convergence figure, and its fitted slopes (kept in the cache beside it)."""
    slopes_path = ctx.cache.derived(f"slopes-{digest(chart + figures_identity())}.json")
    fitted: dict[str, float] = {}

    def draw(p: Path) -> None:
        fitted.update(figs.convergence_chart(rows, p))
        write_atomic(slopes_path, json.dumps(fitted))

    derived_figure(ctx.cache, "convergence", chart, ctx.images_dir / "convergence.png", draw)
    if not fitted and slopes_path.is_file():
        fitted = json.loads(slopes_path.read_text())
    elif not fitted:  # the figure is cached but its slopes were lost: draw it again
        draw(ctx.cache.derived("convergence-again.png"))
    return fitted


def ladder_rows(ctx: ReportContext, measured: Measured) -> list[dict[str, Any]]:
    """Ablation ladder: paper -> Q1 fixed -> Q1,Q2 fixed ... -> physical (Q10: 16 spp)."""
    rows = []
    for planned, changed in zip(ctx.plan.ladder, measured.changed, strict=True):
        step, g = planned.step, measured.overall(planned.job.key)
        rows.append(
            {
                "step": step.name,
                "key": step.key,
                "quirk": step.quirk,
                "flip": g["flip_ldr"],
                "one_minus_ssim": 1.0 - (g["ssim"] or 0.0),
                "seconds": ctx.imgs.facts(step.key)["seconds"],
                "command": ctx.command(planned.job),
                "changed_pixels": changed,  # against the step before; 0: no change
                "note": NO_CHANGE if changed == 0 else "",
            }
        )
    return rows
