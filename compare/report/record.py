"""report.json as a typed record: the fields the page's template and the tests read, built
from the report's steps, and the list of the images it links to."""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import os
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from compare.judge.scoring import ABSENT
from compare.report.analysis import Analysis
from compare.report.charts import FIGURES, Charts
from compare.report.context import SCENE_COPY, TEST_KEY, ReportContext, exr_path
from compare.report.facts import machine, versions
from compare.report.measure import MAP_KINDS, Measured
from safe_files.content import json_safe, sha256_file
from safe_files.paths import write_atomic


@dataclass(frozen=True)
class RenderRow:
    """One render as the page lists it: how it looks, how to make it again."""

    key: str
    label: str
    png: str | None  # its PNG in the folder (ablation renders are only measured)
    exr: str | None  # its EXR in the folder: the reference's and the test's only
    command: str
    family: str
    seconds: float
    cached: bool
    sha256: str


@dataclass
class ReportRecord:
    """report.json, field for field (the page shows the same record)."""

    scene: str
    scene_file: str
    scene_copy: str
    scene_sha256: str
    size: list[int]
    date: str
    machine: str
    versions: dict[str, str]
    command: str  # the command that makes this report again, from inside its folder
    reference: dict[str, Any]
    test: dict[str, str]
    verdict: dict[str, Any]
    model_verdict: dict[str, Any] | None
    diagnosis: dict[str, Any] | None
    sentences: list[Any]
    contributions: list[dict[str, Any]]
    featured: list[dict[str, Any]]
    maps: list[dict[str, str]]
    speed_accuracy: list[dict[str, Any]]
    pareto_front: dict[str, list[dict[str, Any]]]
    convergence_slopes: dict[str, float]
    ladder: list[dict[str, Any]]
    penumbra: dict[str, Any] | None
    not_applicable: dict[str, str]  # renders left out: what switching them would not change
    time_to_converged: dict[str, Any]
    renders: list[RenderRow]
    effect_pixels: dict[str, int]
    absent_effects: dict[str, str]
    timings: list[dict[str, Any]] = field(default_factory=list)  # the steps run so far
    renders_made: int = 0  # renders not found in the cache (0: all from the cache)

    def as_json(self) -> dict[str, Any]:
        """The record as JSON values (NaN and infinities as null)."""
        return dict(json_safe(dataclasses.asdict(self)))

    def linked_images(self) -> set[str]:
        """Every file of images/ the page links to."""
        linked = {p for r in self.renders for p in (r.png, r.exr) if p}
        linked |= {m[k] for m in self.maps for k in MAP_KINDS}
        linked |= {f"images/{n}.png" for n in FIGURES}
        return linked | _linked_images(self.diagnosis)


@dataclass(frozen=True)
class Judged:
    """What the steps found, for the record."""

    measured: Measured
    maps: list[dict[str, str]]
    charts: Charts
    analysis: Analysis
    model_verdict: dict[str, Any] | None
    diagnosis: dict[str, Any] | None


def make_record(ctx: ReportContext, judged: Judged) -> ReportRecord:
    rp, a = ctx.plan, judged.analysis
    ref_w, ref_h = ctx.imgs.facts(rp.reference.key)["size"]
    return ReportRecord(
        scene=ctx.scene.name,
        scene_file=_shown_path(ctx.opts.scene_file),
        scene_copy=SCENE_COPY,
        scene_sha256=sha256_file(ctx.opts.scene_file),
        size=[ref_w, ref_h],
        date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        machine=machine(),
        versions=versions(),
        command=shlex.join(_command_line(ctx)),
        reference={
            "key": rp.reference.key,
            "label": rp.reference.label,
            "spp": rp.reference.spp,
            "command": ctx.command(rp.reference),
        },
        test={"key": ctx.subject.key, "label": ctx.subject.label},
        verdict=a.verdict,
        model_verdict=judged.model_verdict,
        diagnosis=judged.diagnosis,
        sentences=a.sentences,
        contributions=a.contributions,
        featured=[{"key": k, "label": t, **judged.measured.full(k)} for k, t in ctx.featured()],
        maps=judged.maps,
        speed_accuracy=judged.charts.rows,
        pareto_front=judged.charts.pareto,
        convergence_slopes=judged.charts.slopes,
        ladder=judged.charts.ladder,
        penumbra=a.penumbra,
        not_applicable=rp.not_applicable,
        time_to_converged=a.converged,
        renders=render_rows(ctx),
        effect_pixels=a.effect_pixels,
        absent_effects=dict.fromkeys(a.absent, ABSENT),
        renders_made=sum(not j.cached for j in rp.jobs()),
    )


def render_rows(ctx: ReportContext) -> list[RenderRow]:
    """Every render, the image under test first when one is given."""
    pictured, kept = ctx.plan.shown(), {ctx.plan.reference.key, ctx.subject.key}
    rows = [
        RenderRow(
            key=j.key,
            label=j.label,
            png=f"images/{j.key}.png" if j in pictured else None,
            exr=exr_path(j.key) if j.key in kept else None,
            command=ctx.command(j),
            family=j.family,
            seconds=ctx.imgs.facts(j.key)["seconds"],
            cached=j.cached,
            sha256=ctx.hashes[j.key],
        )
        for j in ctx.plan.jobs()
    ]
    given = ctx.subject.given
    if given is not None:
        row = RenderRow(
            key=TEST_KEY,
            label=ctx.subject.label,
            png="images/test-image.png",
            exr=ctx.subject.copy,
            command=f"(given) {given.path.name}",
            family="test",
            seconds=float("nan"),
            cached=True,
            sha256=ctx.hashes[TEST_KEY],
        )
        rows.insert(0, row)
    return rows


def _command_line(ctx: ReportContext) -> list[str]:
    """`rtval report` as run from inside the folder, on its copies of the scene and image."""
    opts = ctx.opts
    line = ["rtval", "report", SCENE_COPY, "--reports-dir", ".."]
    if opts.size:
        line += ["--size", f"{opts.size[0]}x{opts.size[1]}"]
    if ctx.given:
        line += ["--test-image", ctx.subject.copy]
        line += ["--label", opts.test_label] if opts.test_label else []
        line += ["--against", opts.against.name] if opts.against else []
    return line


def _shown_path(path: Path) -> str:
    """A path as the page may show it: relative to the working folder, or the bare name."""
    rel = os.path.relpath(path.resolve(), Path.cwd())
    return path.name if rel.startswith("..") or os.path.isabs(rel) else rel


def _linked_images(data: Any) -> set[str]:
    """Every "images/..." path inside a JSON-like value (the diagnosis' evidence PNGs)."""
    if isinstance(data, str):
        return {data} if data.startswith("images/") else set()
    if isinstance(data, dict):
        return set().union(*(_linked_images(v) for v in data.values()))
    if isinstance(data, (list, tuple)):
        return set().union(*(_linked_images(v) for v in data))
    return set()


def write_json(path: Path, record: ReportRecord) -> None:
    write_atomic(path, json.dumps(record.as_json(), indent=2) + "\n")
