"""Grades for learning-management systems: Gradescope's autograder results.json per
submission (its "Autograder Specifications": a `tests` list of name, score, max_score,
status, output, visibility; the top-level score wins over the tests' sum) and a plain
`id,score` CSV that Moodle's and Canvas's grade imports map onto their columns.

The tests are the effects: an effect's points are its share of the student's score
(class_page.effect_weights), its max_score the points it gives when it matches fully, so a
submission's tests add up to its score out of 100. A scene that could not be judged is one
test worth its whole share, scored 0, whose output says why.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare.grading.class_page import effect_weights
from compare.grading.csv_safe import csv_text
from compare.grading.results import SceneResult, StudentResult
from compare.sandbox.archives import TreeLimits
from compare.sandbox.trees import open_regular, remove_tree, walk
from compare.student_ids import student_slug
from safe_files.paths import own_folder, read_bounded, write_atomic

VISIBILITIES = ("visible", "hidden", "after_due_date", "after_published")


def _points(x: float, top: float) -> float:
    """A score Gradescope can store: finite, within 0..top, to 1/100 of a point."""
    if not math.isfinite(x):
        return 0.0
    return round(min(max(x, 0.0), top), 2)


def _scene_tests(s: SceneResult, scenes: int, visibility: str) -> list[dict[str, Any]]:
    share = 100.0 / scenes
    if not s.verdict:
        return [
            {
                "name": f"{s.scene}: not judged",
                "score": 0.0,
                "max_score": _points(share, 100.0),
                "status": "failed",
                "output": s.reason,
                "visibility": visibility,
            }
        ]
    effects: dict[str, Any] = s.verdict.get("effects", {})
    weights = effect_weights(s, scenes)
    tests = []
    for name, e in effects.items():
        tests.append(
            {
                "name": f"{s.scene}: {name}",
                "score": _points(e["score"] * weights[name], 100.0),
                "max_score": _points(100.0 * weights[name], 100.0),
                "status": "passed" if e["status"] == "pass" else "failed",
                "output": _effect_output(e, "; ".join(e.get("reasons") or [])),
                "visibility": visibility,
            }
        )
    return tests


def _effect_output(e: dict[str, Any], reasons: str) -> str:
    """Why the effect lost points (the verdict's own words), or what it measured."""
    if reasons:
        return reasons
    if e.get("differing") == 0:
        return f"all {e['pixels']:,} pixels match the model"
    if e.get("differing") is not None:
        return f"{e['differing']:,} of {e['pixels']:,} pixels differ, within the allowance"
    return f"{e['pixels']:,} pixels, score {e['score']:.1f} of 100"


def gradescope_results(r: StudentResult, visibility: str = "visible") -> dict[str, Any]:
    """The results.json of one submission."""
    if visibility not in VISIBILITIES:
        raise ValueError(f"visibility must be one of {', '.join(VISIBILITIES)}")
    tests = [t for s in r.scenes for t in _scene_tests(s, len(r.scenes), visibility)]
    output = f"{r.status.upper()}: score {r.score:.1f} of 100, judged against {r.model}."
    if r.reasons:  # a pass's reasons are notes (how its file was read)
        output += f"\n{'Note' if r.status == 'pass' else 'Why'}: {r.reasons}"
    if r.diagnosis:
        output += f"\nWhat the image implements: {r.diagnosis}"
    return {
        "score": _points(r.score, 100.0),
        "execution_time": max(0, round(r.seconds)) if math.isfinite(r.seconds) else 0,
        "output": output,
        "output_format": "text",
        "visibility": visibility,
        "stdout_visibility": "hidden",  # rtval's progress lines are for the teacher
        "tests": tests,
    }


def gradescope_json(r: StudentResult, visibility: str = "visible") -> str:
    return json.dumps(gradescope_results(r, visibility), indent=2, allow_nan=False)


def scores_csv(results: list[StudentResult]) -> str:
    """`id,score`, one row per student (csv_text keeps a formula-like id inert)."""
    return csv_text([["id", "score"], *[[r.student, f"{r.score:.2f}"] for r in results]])


def write_lms_exports(results: list[StudentResult], out: Path) -> None:
    """OUT/scores.csv and OUT/gradescope/<slug>/results.json for every student."""
    write_atomic(out / "scores.csv", scores_csv(results))
    for r in results:
        folder = own_folder(out, "gradescope", student_slug(r.student))
        write_atomic(folder / "results.json", gradescope_json(r))


# Gradescope's autograder layout: the harness unpacks the student's files into
# ROOT/submission and uploads ROOT/results/results.json.
GRADESCOPE_ROOT = Path("/autograder")
GRADESCOPE_ID = "submission"  # the id in OUT when Gradescope's metadata names no student
METADATA = "submission_metadata.json"  # Gradescope's: ROOT/submission_metadata.json
MAX_METADATA_BYTES = 4 << 20
# A user's fields, in the order the id is taken from (its "Submission Metadata" page:
# users[] of {email, id, name}; a group submission lists every member).
_ID_FIELDS = ("email", "id", "name")


@dataclass(frozen=True)
class Identity:
    """Who the submission is: its id in OUT, the names, and where the id came from."""

    student: str
    names: str
    source: str  # words for the progress line


def submission_identity(root: Path) -> Identity:
    """The student(s) of ROOT/submission_metadata.json: the id is each user's email (else
    Gradescope's user id, else the name), members of a group joined by '+'. Without the
    file (or with one that names no user) the id is 'submission', said as such."""
    path = root / METADATA
    if not os.path.lexists(path):
        return Identity(GRADESCOPE_ID, "", f"no {path}: the id is '{GRADESCOPE_ID}'")
    try:
        meta = json.loads(read_bounded(path, MAX_METADATA_BYTES))
    except (OSError, ValueError) as e:
        why = str(e).removeprefix(f"{path}: ")
        return Identity(GRADESCOPE_ID, "", f"{path}: unreadable ({why}): the id is 'submission'")
    users = meta.get("users") if isinstance(meta, dict) else None
    users = [u for u in users if isinstance(u, dict)] if isinstance(users, list) else []
    for key in _ID_FIELDS:
        ids = [str(u[key]).strip() for u in users if str(u.get(key) or "").strip()]
        if users and len(ids) == len(users):
            names = ", ".join(str(u.get("name") or "").strip() for u in users)
            return Identity(entry_name("+".join(ids)), names, f"{path}: users[].{key}")
    return Identity(GRADESCOPE_ID, "", f"{path}: no users[] with an email, id or name")


def entry_name(student: str) -> str:
    """The id as the staged entry's name: itself when it is one plain file name (an email
    is), else its slug."""
    plain = student not in ("", ".", "..") and not student.startswith(".")
    if plain and "/" not in student and "\0" not in student and len(student) <= 200:
        return student
    return student_slug(student)


def stage_submission(root: Path, out: Path, student: str = GRADESCOPE_ID) -> Path:
    """A submissions folder holding ROOT/submission as its only entry (named `student`), copied under
    OUT/autograder: regular files and folders are copied, a link is copied as a link (so
    grading refuses it, naming it) and nothing else (a FIFO, a device) is read."""
    source = root / "submission"
    if not source.is_dir():
        raise OSError(f"{source}: no submission folder (is this Gradescope's layout?)")
    out.mkdir(parents=True, exist_ok=True)
    staging = own_folder(out, "autograder")
    for old in staging.iterdir():  # an earlier run's student (maybe another id)
        if old.is_symlink() or old.is_file():
            old.unlink()
        else:
            remove_tree(old)  # a student's folder: any depth, no link followed
    target = staging / entry_name(student)
    _copy_tree(source, target)
    return staging


def _copy_tree(source: Path, target: Path) -> None:
    """The submission as the student made it, within the bounds of a submitted folder
    (compare/sandbox/trees.py: iterative, no link followed): links copied as links, for
    grading to refuse by name; FIFOs and devices left out."""
    target.mkdir()
    limits = TreeLimits()
    for node in walk(source, limits.max_depth, limits.max_entries):
        dst = target.joinpath(*node.parts)
        if stat.S_ISLNK(node.st.st_mode):
            os.symlink(os.readlink(node.name, dir_fd=node.dir_fd), dst)
        elif stat.S_ISDIR(node.st.st_mode):
            dst.mkdir()
        elif stat.S_ISREG(node.st.st_mode):
            with os.fdopen(open_regular(node), "rb") as f, open(dst, "wb") as out:
                shutil.copyfileobj(f, out)


def write_autograder_results(
    results: list[StudentResult],
    root: Path,
    visibility: str = "visible",
    student: str = GRADESCOPE_ID,
) -> Path:
    """ROOT/results/results.json of the one graded submission."""
    mine = [r for r in results if r.student == entry_name(student)]
    if len(mine) != 1:
        raise OSError(f"expected one graded submission, found {len(results)}")
    folder = root / "results"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "results.json"
    write_atomic(path, gradescope_json(mine[0], visibility))
    return path
