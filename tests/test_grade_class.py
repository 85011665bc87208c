"""What a teacher gets beside the gradebook: the class page OUT/index.html (its table sorted
by mouse and keyboard in Chromium, its links, escaped names, the histogram and the common
causes), the summary on stdout, the LMS exports (OUT/scores.csv, Gradescope's results.json
per student and `grade --gradescope` in the autograder's layout), and 8-bit files judged in
the encoding they were written in (`--test-encoding`). A class of six at 160x120 against
classic, made by rtdemo."""

from __future__ import annotations

import csv
import json
import shutil
import sys
from pathlib import Path

import pytest
from helpers import ROOT, SCENES, render_demo, run
from PIL import Image as PILImage

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
ARGS = ["--scene", "classic", "--size", "160x120", "--against", "classic"]
HOSTILE = "<img src=x onerror=alert(1)>"  # a file name a student may choose
FORMULA = "=HYPERLINK(1)"
ARTIFACTS = ROOT / "build" / "test-artifacts"


@pytest.fixture(scope="module")
def subs(tmp_path_factory: pytest.TempPathFactory, rtdemo: str) -> Path:
    folder = tmp_path_factory.mktemp("class") / "subs"
    folder.mkdir()
    scene, size = SCENES / "classic.json", (160, 120)
    render_demo(rtdemo, scene, folder / "alice.ppm", "--mode", "classic", "-q", size=size)
    render_demo(rtdemo, scene, folder / "bob.png", "--mode", "classic", "-q", size=size)
    render_demo(rtdemo, scene, folder / "eve.ppm", "--mode", "paper", "-q", size=size)
    # The PPM saved as a PNG with the same bytes: linear codes in a PNG.
    PILImage.open(folder / "alice.ppm").save(folder / "carol.png")
    shutil.copyfile(folder / "alice.ppm", folder / f"{HOSTILE}.ppm")
    shutil.copyfile(folder / "eve.ppm", folder / f"{FORMULA}.ppm")
    (folder / "dave.png").write_bytes(b"not a picture")
    return folder


def _grade(subs: Path, out: Path, *options: str) -> str:
    proc = run([RTVAL, "grade", str(subs), *ARGS, "--out", str(out), *options])
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.fixture(scope="module")
def graded(subs: Path) -> tuple[Path, str]:
    out = subs.parent / "grades"
    return out, _grade(subs, out, "--jobs", "2")


def _book(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        return {row["student"]: row for row in csv.DictReader(f)}


def test_a_png_of_linear_codes_passes_and_says_so(graded: tuple[Path, str]) -> None:
    out, _ = graded
    carol, bob = _book(out)["carol"], _book(out)["bob"]
    assert carol["status"] == "pass" and carol["score"] == "100.00"
    note = "read as linear: the PNG holds the values a PPM writer stores"
    assert carol["reasons"] == f"classic: {note}"
    assert bob["status"] == "pass" and bob["reasons"] == ""  # an sRGB PNG: nothing to say
    verdict = json.loads((out / "results" / "carol.json").read_text())["scenes"][0]["verdict"]
    assert verdict["encoding"] == "linear" and verdict["encoding_note"] == note


def test_test_encoding_fixes_the_encoding(subs: Path, tmp_path: Path) -> None:
    _grade(subs, tmp_path / "srgb", "--test-encoding", "srgb", "--no-diagnose")
    book = _book(tmp_path / "srgb")
    assert book["carol"]["status"] == "fail" and book["bob"]["status"] == "pass"
    assert "read as" not in book["carol"]["reasons"]
    _grade(subs, tmp_path / "linear", "--test-encoding", "linear", "--no-diagnose")
    book = _book(tmp_path / "linear")
    assert book["carol"]["status"] == "pass" and book["bob"]["status"] == "fail"
    assert book["alice"]["status"] == "pass"  # a PPM is linear anyway
