"""The class page OUT/index.html and its summary on stdout: every student in one sortable
table (status, score, each effect's points, the diagnosis' cause, a link to the student's
page), the score histogram and the class's common causes ("7 students: Q2 (...)").

Effect points are the student's score taken apart: an effect's points are its score times its
share of the scene's score (compare/judge/scoring.weighted_score, the `--explain` arithmetic)
divided by the number of scenes, so a row's points add up to its score.
"""

from __future__ import annotations

import statistics
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare.diagnose.evidence import describe_cause
from compare.grading.results import SceneResult, StudentResult
from compare.judge.scoring import Term, weighted_score
from compare.pages.writer import write_page
from compare.student_ids import displayable

HISTOGRAM_BINS = 10  # 0-10, 10-20, ..., 90-100 (100 falls in the last)
# Why an unjudged scene was not judged, by how its reason starts (grade.py's words).
_UNJUDGED = (
    ("wrong size", "image of the wrong size"),
    ("unreadable", "unreadable image"),
    ("no image for scene", "no image for a scene"),
)


@dataclass(frozen=True)
class ClassSummary:
    """The class in numbers: counts, mean and median score, the histogram (students per
    bin of 10 points) and the common causes (students, cause), the most frequent first."""

    students: int
    passed: int
    mean: float
    median: float
    histogram: tuple[int, ...]
    causes: tuple[tuple[int, str], ...]
    notes: tuple[tuple[int, str], ...] = ()  # (students, how their files were read)


def effect_weights(scene: SceneResult, scenes: int) -> dict[str, float]:
    """Each effect's share of the student's score from one judged scene: its points are its
    score times this, its most 100 times this (an unjudged scene has none: it scores 0)."""
    if not scene.verdict or scenes <= 0:
        return {}
    effects: dict[str, Any] = scene.verdict.get("effects", {})
    _, shares = weighted_score(
        {k: Term(e["pixels"], e["rule"]["weight"], e["score"]) for k, e in effects.items()}
    )
    return {k: shares[k] / scenes for k in effects}


def effect_points(scene: SceneResult, scenes: int) -> dict[str, float]:
    """Each effect's points toward the student's score from one scene."""
    effects: dict[str, Any] = (scene.verdict or {}).get("effects", {})
    return {k: effects[k]["score"] * w for k, w in effect_weights(scene, scenes).items()}


def student_causes(r: StudentResult) -> list[str]:
    """What the student's failing scenes have in common with others', one label per cause:
    the diagnosis' causes in words, why a scene was not judged, or the failing effects."""
    labels = [c for s in r.scenes if s.status != "pass" for c in _scene_causes(s)]
    return list(dict.fromkeys(labels))  # each cause once per student, in order


def _scene_causes(s: SceneResult) -> list[str]:
    detail = s.diagnosis_detail or {}
    labels = []
    start, assigned = detail.get("start"), detail.get("assigned")
    if start and assigned and start != assigned:  # nearer another mode than the model
        labels.append(f"looks like {start}")
    # Each cause is a record (diagnose/record.py cause_list): its name is what it names.
    labels += [describe_cause(_cause_name(c)) for c in detail.get("causes") or []]
    if detail.get("unexplained"):
        labels.append("not explained by a known mistake")
    if labels:
        return labels
    if s.verdict is None:
        return [_unjudged_label(s.reason)]
    failing = [k for k, e in s.verdict.get("effects", {}).items() if e["status"] != "pass"]
    return [f"{k} differs" for k in failing] or ["score below the pass score"]


def _cause_name(cause: Any) -> str:
    return str(cause.get("name", "")) if isinstance(cause, dict) else str(cause)


def _unjudged_label(reason: str) -> str:
    for start, label in _UNJUDGED:
        if reason.startswith(start):
            return label
    return "not judged: " + reason.split(":", 1)[0][:60]


def summarise(results: list[StudentResult]) -> ClassSummary:
    scores = [r.score for r in results]
    bins = [0] * HISTOGRAM_BINS
    for x in scores:
        bins[min(HISTOGRAM_BINS - 1, max(0, int(x // (100 / HISTOGRAM_BINS))))] += 1
    counts = Counter(c for r in results for c in student_causes(r))
    notes = Counter(
        n
        for r in results
        for n in {str((s.verdict or {}).get("encoding_note", "")) for s in r.scenes}
    )
    notes.pop("", None)
    return ClassSummary(
        students=len(results),
        passed=sum(r.status == "pass" for r in results),
        mean=statistics.fmean(scores) if scores else 0.0,
        median=statistics.median(scores) if scores else 0.0,
        histogram=tuple(bins),
        causes=_commonest(counts),
        notes=_commonest(notes),
    )


def _commonest(counts: Counter[str]) -> tuple[tuple[int, str], ...]:
    return tuple((n, c) for c, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))


def summary_lines(summary: ClassSummary, most: int = 5) -> list[str]:
    """The summary for a terminal: counts, mean, median, the commonest causes."""
    s = summary
    lines = [
        f"{s.students} student{'' if s.students == 1 else 's'}: {s.passed} passed, {s.students - s.passed} failed; "
        f"mean score {s.mean:.1f}, median {s.median:.1f}"
    ]
    for n, cause in s.causes[:most]:
        lines.append(f"  {n} student{'s' if n != 1 else ''}: {displayable(cause)}")
    for n, note in s.notes:
        lines.append(f"  note, {n} student{'s' if n != 1 else ''}: {displayable(note)}")
    return lines


def class_rows(results: list[StudentResult]) -> tuple[list[str], list[dict[str, Any]]]:
    """The table's effect columns (in the order they first appear) and one row per student."""
    effects: dict[str, None] = {}
    rows = []
    for r in results:
        points: dict[str, float] = {}
        for s in r.scenes:
            for k, p in effect_points(s, len(r.scenes)).items():
                effects.setdefault(k)
                points[k] = points.get(k, 0.0) + p
        rows.append(
            {
                "student": r.student,
                "status": r.status,
                "score": r.score,
                "points": points,
                "cause": r.diagnosis or "; ".join(student_causes(r)),
                "page": r.page,
            }
        )
    return list(effects), rows


def write_class_page(results: list[StudentResult], out: Path, rubric: str) -> ClassSummary:
    """OUT/index.html; returns the summary it shows."""
    summary = summarise(results)
    effects, rows = class_rows(results)
    top = max(summary.histogram, default=0) or 1
    write_page(
        out / "index.html",
        "class.html.j2",
        summary=summary,
        effects=effects,
        rows=rows,
        rubric=rubric,
        bins=[
            {"low": i * 100 // HISTOGRAM_BINS, "count": n, "height": 100 * n / top}
            for i, n in enumerate(summary.histogram)
        ],
    )
    return summary
