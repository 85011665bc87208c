"""The class's gradebook (OUT/gradebook.csv and gradebook.json) and `rtval grade --explain`,
both from the typed results (compare/grading/results.py); the arithmetic they show is
compare/judge/scoring.py's."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from compare.grading.csv_safe import csv_text
from compare.grading.results import BadResult, SceneResult, StudentResult, read_result
from compare.judge.scoring import Term, weighted_score
from compare.student_ids import displayable, student_slug
from safe_files.paths import write_atomic

_SUMMARY_KEYS = ("student", "status", "score", "model", "reasons", "diagnosis", "page")


def write_gradebook(results: list[StudentResult], out: Path, rubric: str, seconds: float) -> None:
    """Every text cell goes through displayable(): a reason quoting a student's link target
    or compiler line cannot carry an escape sequence, a bidi override or a line break."""
    write_atomic(out / "gradebook.csv", csv_text(_csv_rows(results)))
    summary = [
        {k: _shown(getattr(r, k)) for k in _SUMMARY_KEYS}
        | {"scenes": {s.scene: {"status": s.status, "score": s.score} for s in r.scenes}}
        for r in results
    ]
    write_atomic(
        out / "gradebook.json",
        json.dumps({"rubric": rubric, "seconds": seconds, "students": summary}, indent=2),
    )


def _csv_rows(results: list[StudentResult]) -> list[list[object]]:
    """The CSV's rows, header first (csv_text neutralises formulas)."""
    scenes = sorted({s.scene for r in results for s in r.scenes})
    rows: list[list[object]] = [
        [
            "student",
            "status",
            "score",
            "model",
            *[f"{s} score" for s in scenes],
            *[f"{s} status" for s in scenes],
            "reasons",
            "diagnosis",
            "page",
        ]
    ]
    for r in results:
        by = {s.scene: s for s in r.scenes}
        rows.append(
            [
                displayable(r.student),
                r.status,
                f"{r.score:.2f}",
                r.model,
                *[f"{by[s].score:.2f}" if s in by else "" for s in scenes],
                *[by[s].status if s in by else "" for s in scenes],
                displayable(r.reasons),
                displayable(r.diagnosis),
                r.page,
            ]
        )
    return rows


def _shown(value: object) -> object:
    return displayable(value) if isinstance(value, str) else value


def explain(out: Path, student: str) -> str:
    """How `student`'s score came about, from the stored result (OSError when there is
    none, it is not a result, or it is another id's)."""
    path = out / "results" / f"{student_slug(student)}.json"
    try:
        r = read_result(path)
    except BadResult as e:
        raise OSError(
            f"{path}: the result for {student!r} is truncated or corrupt ({e.why}); "
            "run rtval grade again: it regrades this student"
        ) from None
    if r is None:
        raise OSError(f"{path}: no result for {student!r} (run rtval grade first)")
    if r.student != student:  # never a classmate's result
        raise OSError(f"{path}: holds the result of another id, not {student!r}")
    lines = [
        f"{displayable(student)}: {r.status.upper()}, score {r.score:.1f} = mean of the scene "
        f"scores (judged against {r.model or 'mitsuba'}; rubric: {displayable(r.rubric)})"
    ]
    for s in r.scenes:
        lines.append(
            f"  scene {displayable(s.scene)}: {displayable(s.status)}, score {s.score:.1f}"
            + (f" — {displayable(s.reason)}" if s.reason else "")
        )
        if s.verdict:
            lines += _verdict_lines(s)
    # Every line is ours: whatever a result file holds, no text in it starts a line.
    return "\n".join(displayable(line) for line in lines)


def _verdict_lines(s: SceneResult) -> list[str]:
    """One line per effect: its numbers, score and share of the scene's score."""
    v: dict[str, Any] = s.verdict or {}
    effects: dict[str, Any] = v["effects"]
    _, shares = weighted_score(
        {k: Term(e["pixels"], e["rule"]["weight"], e["score"]) for k, e in effects.items()}
    )
    exact = v.get("basis") == "exact"
    lines = []
    for name, e in effects.items():
        w = shares[name]
        lines.append(
            f"    {name:<11} {e['status']:<4} {_measures(e, exact)}: score {e['score']:.1f} x "
            f"weight {w:.3f} = {e['score'] * w:.1f}"
        )
    if exact:
        lines.append(
            "    score = 100 x the share of the effect's pixels that match the model within "
            f"{v['exact']['rule']}, weighted by pixels x weight; an effect passes with at "
            f"most {v['exact']['stray_rule']} of its pixels differing; "
            f"pass needs every effect to pass and score >= {v['pass_score']}"
        )
    else:
        lines.append(
            f"    score = 100 (1 - FLIP / {v['flip_at_zero_score']}) per effect, weighted by "
            f"pixels x weight; pass needs every effect to pass and score >= {v['pass_score']}"
        )
    return lines


def _measures(e: dict[str, Any], exact: bool) -> str:
    if exact:
        return f"{e['differing']} of {e['pixels']} px differ" + (
            f", FLIP {e['flip']:.4f}" if e["flip"] is not None else ""
        )
    ssim = f"{e['ssim']:.4f}" if e["ssim"] is not None else "undefined"
    return (
        f"SSIM {ssim} (min {e['rule']['min_ssim']}), "
        f"FLIP {e['flip']:.4f} (max {e['rule']['max_flip']})"
    )
