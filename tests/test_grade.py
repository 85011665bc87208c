"""`rtval grade --against mitsuba` on a generated class of 33 submissions made from the
Mitsuba reference: every verdict as expected, every fail with a reason, local and Dask
executors, resume, rubric errors with line numbers, --explain. (Grading against a demo model:
test_against.py.)"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
from class_generator import make_class
from helpers import SCENES, run

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE = SCENES / "classic.json"
SIZE = ["--size", "160x120", "--against", "mitsuba"]


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory, rtdemo: str) -> tuple[Path, dict, Path]:  # type: ignore[type-arg]
    root = tmp_path_factory.mktemp("class")
    out = root / "grades"
    # First run renders the reference, which the class is made from.
    warm = _grade(root, out, *SIZE)
    assert warm.returncode == 0, warm.stderr
    reference = out / "references" / "classic-mitsuba.exr"
    expected = make_class(reference, SCENE, rtdemo, root / "subs")
    proc = _grade(root / "subs", out, *SIZE, "--jobs", "2")
    assert proc.returncode == 0, proc.stderr
    return out, expected, root


def _grade(subs: Path, out: Path, *options: str) -> subprocess.CompletedProcess[str]:
    """`rtval grade SUBS --scene classic.json --out OUT OPTIONS...`."""
    return run([RTVAL, "grade", str(subs), "--scene", str(SCENE), "--out", str(out), *options])


def _gradebook(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        return {row["student"]: row for row in csv.DictReader(f)}


def test_every_verdict_is_the_expected_one(graded: tuple[Path, dict, Path]) -> None:  # type: ignore[type-arg]
    out, expected, _ = graded
    book = _gradebook(out)
    assert len(expected) >= 30 and set(book) == set(expected)
    wrong = {
        sid: (kind, status, book[sid]["status"], book[sid]["reasons"])
        for sid, (kind, status) in expected.items()
        if book[sid]["status"] != status
    }
    assert not wrong, wrong
    assert all(row["model"] == "mitsuba" for row in book.values())
    assert all(row["reasons"] for row in book.values() if row["status"] == "fail")
    reasons = {sid: book[sid]["reasons"] for sid in book}
    assert "shadow: SSIM" in reasons["no_shadows_0"] and "> 0.1" in reasons["no_shadows_0"]
    assert all("wrong size 80x60, expected 160x120" in reasons[f"wrong_size_{i}"] for i in range(3))
    assert all("unreadable" in reasons[f"corrupt_{i}"] for i in range(3))
    assert all("no image for scene 'classic'" in reasons[f"missing_{i}"] for i in range(3))
    assert all("NaN" in reasons[f"nan_{i}"] for i in range(3))
    result = json.loads((out / "results" / "no_shadows_0.json").read_text())
    effects = result["scenes"][0]["verdict"]["effects"]
    assert effects["shadow"]["status"] == "fail" and effects["background"]["status"] == "pass"
    result = json.loads((out / "results" / "no_refraction_1.json").read_text())
    assert result["scenes"][0]["verdict"]["effects"]["refraction"]["status"] == "fail"
    page = out / "students" / "copy_0" / "index.html"
    assert (
        "copy_0" in page.read_text()
        and (out / "students" / "copy_0" / "classic-diff.png").is_file()
    )
    assert json.loads((out / "gradebook.json").read_text())["students"][0]["student"]


def test_rerun_resumes_everything(graded: tuple[Path, dict, Path]) -> None:  # type: ignore[type-arg]
    out, expected, root = graded
    proc = _grade(root / "subs", out, *SIZE)
    assert proc.returncode == 0
    assert f"({len(expected)} resumed)" in proc.stderr


def test_dask_cluster_gives_the_same_gradebook(
    graded: tuple[Path, dict, Path], tmp_path: Path
) -> None:  # type: ignore[type-arg]
    from dask.distributed import LocalCluster

    out, _expected, root = graded
    dask_out = tmp_path / "dask"  # the model's render comes from the session's render cache
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        proc = _grade(
            root / "subs",
            dask_out,
            *SIZE,
            "--executor",
            "dask",
            "--scheduler",
            cluster.scheduler_address,
        )
    assert proc.returncode == 0, proc.stderr
    a, b = _gradebook(out), _gradebook(dask_out)
    assert {k: (v["status"], v["score"]) for k, v in a.items()} == {
        k: (v["status"], v["score"]) for k, v in b.items()
    }


def test_explain_prints_the_arithmetic(graded: tuple[Path, dict, Path]) -> None:  # type: ignore[type-arg]
    out, _, _ = graded
    proc = run([RTVAL, "grade", "--explain", "biased_0", "--out", str(out)])
    assert proc.returncode == 0
    assert (
        "biased_0: FAIL" in proc.stdout
        and "x weight" in proc.stdout
        and "scene classic" in proc.stdout
    )
    assert run([RTVAL, "grade", "--explain", "nobody", "--out", str(out)]).returncode == 4


def test_rubric_changes_verdicts_and_errors_name_the_line(
    graded: tuple[Path, dict, Path], tmp_path: Path
) -> None:  # type: ignore[type-arg]
    _out, _, root = graded
    lenient = tmp_path / "lenient.toml"
    lenient.write_text(
        "[rubric]\npass_score = 0\n"
        + "".join(
            f"\n[effects.{e}]\nmin_ssim = -1\nmax_flip = 1.0\n"
            for e in ("direct", "shadow", "reflection", "edges")
        )
    )
    proc = _grade(root / "subs", tmp_path / "g", *SIZE, "--rubric", str(lenient))
    assert proc.returncode == 0, proc.stderr
    assert _gradebook(tmp_path / "g")["no_shadows_0"]["status"] == "pass"
    bad = tmp_path / "bad.toml"
    for effect, error in (
        ("[effects.shadows]\nmax_flip = 0.1", "line 4: unknown effect 'shadows'"),
        ("[effects.shadow]\nmax_flip = 'low'", "line 5: max_flip must be a number"),
    ):
        bad.write_text(f"[rubric]\npass_score = 60\n\n{effect}\n")
        proc = _grade(root / "subs", tmp_path / "h", "--rubric", str(bad))
        assert proc.returncode == 4 and f"bad.toml: {error}" in proc.stderr
