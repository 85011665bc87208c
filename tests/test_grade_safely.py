"""compare/grading/grade.py: a failure inside one submission's grading (an exception, a
grading process killed) is that student's row, never the class's end, and is never stored."""

from __future__ import annotations

from concurrent.futures.process import BrokenProcessPool
from types import SimpleNamespace
from typing import Any

import pytest

from compare.grading import grade
from compare.grading.executors import Executor


def _task(student: str) -> grade.GradeTask:
    models: Any = {"classic": SimpleNamespace(model="classic")}
    return grade.GradeTask(
        student=student,
        files={"classic": None},
        problem=None,
        models=models,
        models_key="",
        rubric_text="",
        rubric_source="built-in",
        out_dir="/nonexistent",
    )


def test_an_exception_in_one_grading_is_its_row(monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(task: grade.GradeTask) -> None:
        raise RecursionError("maximum recursion depth exceeded \x1b[2J")

    monkeypatch.setattr(grade, "grade_one", boom)
    row = grade.grade_safely(_task("alice"))
    assert row.status == "fail" and row.key == ""  # a key no stored result can match
    assert row.reasons.startswith("not graded: maximum recursion depth exceeded \\x1b[2J")
    assert row.scenes[0].status == "error"


def test_a_dead_grading_process_leaves_rows_for_the_rest(monkeypatch: pytest.MonkeyPatch) -> None:
    tasks = [_task(s) for s in ("alice", "bob", "carol")]

    def pool_breaks(work: Any, todo: Any, arrived: Any, where: Any) -> None:
        arrived(grade.not_graded(todo[0], "first"))
        raise BrokenProcessPool("a process in the pool was terminated abruptly")

    monkeypatch.setattr(grade, "run_tasks", pool_breaks)
    rows: list[grade.StudentResult] = []
    grade._run_all(tasks, rows.append, Executor(jobs=2))
    assert [r.student for r in rows] == ["alice", "bob", "carol"]
    assert "a grading process died" in rows[1].reasons and "first" in rows[0].reasons
