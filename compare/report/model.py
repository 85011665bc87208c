"""A given image under test against its assigned model (is the implementation right?), what
each of the model's quirks costs against Mitsuba, and the diagnosis "What this image
implements" (compare/diagnose/evidence.py)."""

from __future__ import annotations

import itertools
from typing import Any

from compare.diagnose.evidence import EvidenceOptions, diagnose_image
from compare.diagnose.search import DiagnoseError
from compare.errors import ToolError
from compare.judge.target_model import MODE_QUIRKS, parse_model
from compare.report.context import ReportContext
from compare.verdict.against import GRADE_DEFAULT, judge_against_model, load, prepare


def model_verdict(ctx: ReportContext, ladder: list[dict[str, Any]]) -> dict[str, Any]:
    """The test image against its model, and the quirks' costs read from the ablation ladder."""

    opts = ctx.opts
    model = opts.against or parse_model(GRADE_DEFAULT)
    ctx.progress.line(f"model {model.name} ...")
    prepared = prepare(model, opts.scene_file, opts.size, ctx.cache, progress=ctx.progress)
    ev = judge_against_model(ctx.imgs[ctx.subject.key], load(prepared))
    assert ev.score is not None
    # Each ladder step fixes one quirk on top of the earlier ones: its FLIP drop is what that
    # quirk costs there (cumulative, so conditional on the earlier fixes).
    present = model.quirks if model.is_demo else frozenset()
    costs = [
        {
            "quirk": step["quirk"],
            "present": int(step["quirk"][1:]) in present,
            "flip_with": before["flip"],
            "flip_fixed": step["flip"],
            "cost": before["flip"] - step["flip"],
            "note": step["note"],
        }
        for before, step in itertools.pairwise(ladder)
        if int(step["quirk"][1:]) in MODE_QUIRKS["paper"]
    ]
    return {
        "model": model.name,
        "basis": ev.score.basis,
        "score": ev.score.as_dict(),
        "reasons": ev.score.reasons(),
        "exact": ev.exact.as_dict() if ev.exact else None,
        "quirk_costs": costs,
    }


def diagnosis(ctx: ReportContext, assigned: str) -> dict[str, Any]:
    """The test image explained as the nearest demo model, with its evidence PNGs in images/.
    A diagnosis that cannot run (e.g. a renderer without AOVs) leaves the section saying
    why, not a failed report."""

    try:
        return diagnose_image(
            ctx.imgs[ctx.subject.key],
            ctx.opts.scene_file,
            ctx.cache,
            ctx.images_dir,
            EvidenceOptions(
                prefix="diagnosis",
                href="images/",
                assigned=assigned,
                parallel=max(1, ctx.opts.jobs),
            ),
        )
    except (DiagnoseError, ToolError) as e:
        return {"error": str(e)}
