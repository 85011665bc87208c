"""The class summary's arithmetic and its text (compare/grading/class_page.py), without a
render: the histogram's bins and edges, the common causes counted once per student, an empty
class, and a student's text that reaches a terminal without its control characters."""

from __future__ import annotations

from pathlib import Path

import pytest

from compare.grading.class_page import summarise, summary_lines, write_class_page
from compare.grading.results import SceneResult, StudentResult


def _student(sid: str, score: float, *scenes: SceneResult) -> StudentResult:
    status = "pass" if all(s.status == "pass" for s in scenes) else "fail"
    return StudentResult(sid, "k", status, score, "classic", "", "", scenes, "r", 0.0, "p")


def _unjudged(reason: str) -> SceneResult:
    return SceneResult("classic", "classic", "error", 0.0, reason)


def _diagnosed(*causes: str) -> SceneResult:
    detail = {"causes": list(causes), "unexplained": [], "start": "classic", "assigned": "classic"}
    return SceneResult(
        "classic", "classic", "fail", 50.0, "", verdict={"effects": {}}, diagnosis_detail=detail
    )


def test_histogram_bins_hold_their_lower_edge_and_100_is_in_the_last() -> None:
    ok = SceneResult("classic", "classic", "pass", 100.0, "")
    scores = [0.0, 9.99, 10.0, 55.0, 100.0]
    s = summarise([_student(f"s{i}", x, ok) for i, x in enumerate(scores)])
    assert s.histogram == (2, 1, 0, 0, 0, 1, 0, 0, 0, 1)
    assert s.mean == pytest.approx(sum(scores) / 5) and s.median == 10.0


def test_causes_count_students_not_scenes() -> None:
    two_scenes = _student("a", 50.0, _diagnosed("+Q2"), _diagnosed("+Q2", "+Q4"))
    other = _student("b", 50.0, _diagnosed("+Q2"))
    lost = _student("c", 0.0, _unjudged("wrong size 80x60, expected 160x120"))
    s = summarise([two_scenes, other, lost])
    causes = {c: n for n, c in s.causes}
    assert causes == {
        "Q2 (eta = 1/ior also when leaving glass)": 2,
        "Q4 (one shadow factor shared by all lights)": 1,
        "image of the wrong size": 1,
    }
    assert s.causes[0] == (2, "Q2 (eta = 1/ior also when leaving glass)")  # commonest first
    assert "  2 students: Q2 (eta = 1/ior also when leaving glass)" in summary_lines(s)


def test_an_empty_class_has_a_page_and_a_summary(tmp_path: Path) -> None:
    s = write_class_page([], tmp_path, "default rubric")
    assert summary_lines(s) == ["0 students: 0 passed, 0 failed; mean score 0.0, median 0.0"]
    assert "No student failed" in (tmp_path / "index.html").read_text()


def test_a_cause_reaches_the_terminal_without_control_characters() -> None:
    evil = _student("e", 0.0, _unjudged("build failed\x1b[2J\x1b]0;owned\x07: exit 1"))
    lines = summary_lines(summarise([evil]))
    assert not any(ch in "".join(lines) for ch in "\x1b\x07")
    assert lines[1] == "  1 student: not judged: build failed\\x1b[2J\\x1b]0;owned\\x07"
