"""`rtval grade` diagnoses failing submissions against a demo model: the gradebook's diagnosis
column, the fail reasons, the student page's evidence, the shared candidate render cache,
--no-diagnose, and the process-pool and Dask executors. The submissions are student-style
variants of the numpy classic program (tests/student_variants.py), truncating PPMs at 160x120.
"""

from __future__ import annotations

import csv
import json
import re
import shutil
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run
from student_variants import render_variant

from scene_model.scene import load_scene

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE = SCENES / "classic.json"
ARGS = ["--scene", str(SCENE), "--size", "160x120", "--against", "classic"]


def _book(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        return {row["student"]: row for row in csv.DictReader(f)}


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("diagnosed")
    subs = root / "subs"
    subs.mkdir()
    scene = load_scene(SCENE)
    render_variant(scene, "wrong_eta_leaving", 160, 120, subs / "eta.ppm")
    render_variant(scene, "exact", 160, 120, subs / "exact.ppm")
    render_variant(scene, "depth_10", 160, 120, subs / "deep.ppm")
    render_variant(scene, "glass_colour_missing", 160, 120, subs / "pale.ppm")
    out = root / "grades"
    proc = run([RTVAL, "grade", str(subs), *ARGS, "--out", str(out), "--jobs", "2"])
    assert proc.returncode == 0, proc.stderr
    return root, out


def test_failing_submission_is_diagnosed_as_q2(graded: tuple[Path, Path]) -> None:
    _, out = graded
    book = _book(out)
    eta, exact = book["eta"], book["exact"]
    assert eta["status"] == "fail" and exact["status"] == "pass"
    assert eta["diagnosis"].startswith("looks like Q2 (") and "leaving glass" in eta["diagnosis"]
    # The fail reasons say what differs, then what it looks like.
    assert eta["reasons"].startswith("classic: refraction: ")
    assert eta["reasons"].endswith("; looks like Q2 (eta = 1/ior also when leaving glass)")
    # Passing submissions are not diagnosed.
    assert exact["diagnosis"] == ""
    result = json.loads((out / "results" / "exact.json").read_text())
    assert result["scenes"][0]["diagnosis_detail"] is None
    summary = json.loads((out / "gradebook.json").read_text())["students"]
    assert {s["student"]: s["diagnosis"] for s in summary}["eta"] == eta["diagnosis"]


def test_the_diagnosis_never_contradicts_the_verdict(graded: tuple[Path, Path]) -> None:
    # MAX_RAY_DEPTH 10 fails classic on ~30 refraction and edge pixels: the cell names the
    # deeper limit, never "looks like classic". Glass never multiplied by its colour: nothing
    # reproduces it, so no mistake is named and the cell says what is left.
    _, out = graded
    book = _book(out)
    deep, pale = book["deep"], book["pale"]
    assert deep["status"] == "fail" and pale["status"] == "fail"
    assert deep["diagnosis"] == "looks like max depth 7 or more"
    assert deep["reasons"].endswith("; looks like max depth 7 or more")
    assert pale["diagnosis"].startswith("not explained: reflection (")
    assert (
        "refraction (6,078 px, 100%)" in pale["diagnosis"] and "looks like" not in pale["diagnosis"]
    )
    detail = json.loads((out / "results" / "pale.json").read_text())["scenes"][0]
    assert (
        detail["diagnosis_detail"]["mistakes"] == [] and not detail["diagnosis_detail"]["matches"]
    )


def test_student_page_shows_the_diagnosis_and_its_evidence(graded: tuple[Path, Path]) -> None:
    _, out = graded
    page_dir = out / "students" / "eta"
    page = (page_dir / "index.html").read_text()
    assert "What this image implements: looks like Q2" in page
    assert "refraction: explained by +Q2" in page  # a diagnosis sentence
    shown = re.findall(r'<img src="([^"]+)"', page)
    evidence = [s for s in shown if "diagnosis" in s]
    assert len(evidence) >= 3, shown
    assert all((page_dir / s).is_file() for s in shown), shown
    result = json.loads((out / "results" / "eta.json").read_text())
    detail = result["scenes"][0]["diagnosis_detail"]
    assert [c["name"] for c in detail["causes"]] == ["+Q2"] and detail["result"] == "classic+Q2"
    step = detail["evidence"][0]
    assert step["cause"] == "+Q2" and "refraction" in step["flip"]
    before, after = step["flip"]["refraction"]
    assert after < before / 2  # Q2 explains the refraction


def test_identical_submissions_render_nothing_again(graded: tuple[Path, Path]) -> None:
    root, out = graded
    subs = root / "subs"
    shutil.copy(subs / "eta.ppm", subs / "eta_twin.ppm")
    try:
        proc = run([RTVAL, "grade", str(subs), *ARGS, "--out", str(out), "--jobs", "1"])
    finally:
        (subs / "eta_twin.ppm").unlink()
    assert proc.returncode == 0, proc.stderr
    assert "(4 resumed)" in proc.stderr
    twin = json.loads((out / "results" / "eta_twin.json").read_text())
    cache = twin["scenes"][0]["diagnosis_detail"]["cache"]
    # The same pixels: the diagnosis kept for them, only its evidence pictures read.
    assert cache["rendered"] == 0 and cache["hits"] > 0, cache
    assert _book(out)["eta_twin"]["diagnosis"] == _book(out)["eta"]["diagnosis"]


def test_no_diagnose_skips_it(graded: tuple[Path, Path], tmp_path: Path) -> None:
    root, _ = graded
    out = tmp_path / "plain"
    proc = run([RTVAL, "grade", str(root / "subs"), *ARGS, "--out", str(out), "--no-diagnose"])
    assert proc.returncode == 0, proc.stderr
    book = _book(out)
    assert book["eta"]["status"] == "fail" and book["eta"]["diagnosis"] == ""
    assert "looks like" not in book["eta"]["reasons"] and "refraction" in book["eta"]["reasons"]
    assert not (out / "cache" / "diagnose").exists()


def test_dask_workers_diagnose_too(graded: tuple[Path, Path], tmp_path: Path) -> None:
    from dask.distributed import LocalCluster

    root, out = graded
    dask_out = tmp_path / "dask"
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        proc = run(
            [RTVAL, "grade", str(root / "subs"), *ARGS, "--out", str(dask_out), "--executor",
             "dask", "--scheduler", cluster.scheduler_address]
        )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert _book(dask_out)["eta"]["diagnosis"] == _book(out)["eta"]["diagnosis"]


def test_a_png_of_linear_values_is_diagnosed_with_its_encoding(tmp_path: Path) -> None:
    # A student's PPM writer's bytes (Q2's refraction) saved as a PNG keeping every value:
    # graded in both encodings, read as linear; the diagnosis names the encoding first,
    # then what the pixels show.
    from PIL import Image as PILImage

    subs = tmp_path / "subs"
    subs.mkdir()
    render_variant(load_scene(SCENE), "wrong_eta_leaving", 160, 120, tmp_path / "eta.ppm")
    PILImage.open(tmp_path / "eta.ppm").save(subs / "eta.png")
    out = tmp_path / "grades"
    proc = run([RTVAL, "grade", str(subs), *ARGS, "--out", str(out), "--jobs", "1"])
    assert proc.returncode == 0, proc.stderr
    scene = json.loads((out / "results" / "eta.json").read_text())["scenes"][0]
    assert scene["verdict"]["encoding"] == "linear"
    causes = scene["diagnosis_detail"]["causes"]
    assert causes[0]["kind"] == "image" and causes[0]["name"] == (
        "encoding: the PNG holds linear values (a PPM writer's bytes saved as PNG)"
    )
    assert any(c["name"] == "+Q2" for c in causes[1:]), [c["name"] for c in causes]
    # The class page's common causes name them in words (never a record's repr).
    page = (out / "index.html").read_text()
    assert "encoding: the PNG holds linear values" in page and "Q2 (eta = 1/ior" in page
    assert "'kind'" not in page and "&#39;kind&#39;" not in page
