"""Judging against a target model, end to end at 320x240: a foreign float32 numpy
implementation of the classic program that writes a truncating PPM, and rtdemo's own classic
PPM (rounding and truncating), PNG and EXR, all pass against `classic` with score >= 99 and
every effect passing; against `mitsuba` they fail; the gradebook names the model and says why
every fail fails."""

from __future__ import annotations

import csv
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import ROOT, SCENES, render_demo, run

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE = SCENES / "classic.json"
SIZE = (320, 240)
STUDENT = ROOT / "tests" / "student_programs" / "classic_numpy.py"


def _write_ppm(path: Path, codes: np.ndarray) -> None:
    h, w = codes.shape[:2]
    path.write_bytes(f"P6\n{w} {h}\n255\n".encode() + codes.astype(np.uint8).tobytes())


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory, rtdemo: str) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("against")
    subs = root / "subs"
    subs.mkdir()
    outputs = ["--png", str(subs / "rtdemo_png.png"), "--ppm", str(subs / "rtdemo_ppm.ppm")]
    exr = subs / "rtdemo_exr.exr"
    rgb = render_demo(rtdemo, SCENE, exr, "--mode", "classic", "-q", *outputs, size=SIZE).rgb
    # rtdemo's PPM truncates by default; its rounding twin, and both again from its EXR:
    round_ppm = subs / "rtdemo_ppm_round.ppm"
    render_demo(
        rtdemo, SCENE, round_ppm, "--mode", "classic", "-q", "--ppm-rounding", "round", size=SIZE
    )
    _write_ppm(subs / "rtdemo_trunc.ppm", np.floor(255 * np.clip(rgb, 0, 1)))
    _write_ppm(subs / "rtdemo_round.ppm", np.floor(255 * np.clip(rgb, 0, 1) + 0.5))
    proc = run(
        [sys.executable, str(STUDENT), str(SCENE), str(subs / "numpy.ppm"), "--size", "320x240"],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert proc.returncode == 0, proc.stderr
    render_demo(rtdemo, SCENE, subs / "paper_mode.ppm", "--mode", "paper", "-q", size=SIZE)
    return {"root": root, "subs": subs}


def _compare(work: dict[str, Path], image: str, model: str) -> dict:  # type: ignore[type-arg]
    out = work["root"] / f"{Path(image).stem}-{model}.json"
    proc = run(
        [
            RTVAL,
            "compare",
            str(work["subs"] / image),
            "--scene",
            str(SCENE),
            "--against",
            model,
            "--json",
            str(out),
            "-q",
        ],
    )
    assert proc.returncode in (0, 2), proc.stderr
    data: dict = json.loads(out.read_text())  # type: ignore[type-arg]
    assert data["exit_code"] == proc.returncode and data["against"] == model
    return data


EXACT = ["numpy.ppm", "rtdemo_ppm.ppm", "rtdemo_ppm_round.ppm", "rtdemo_trunc.ppm"]
EXACT += ["rtdemo_round.ppm"]
EXACT += ["rtdemo_png.png", "rtdemo_exr.exr"]


@pytest.mark.parametrize("image", EXACT)
def test_exact_implementations_pass_against_classic(work: dict[str, Path], image: str) -> None:
    data = _compare(work, image, "classic")
    assert data["status"] == "pass" and data["score"]["basis"] == "exact"
    assert data["score"]["status"] == "pass" and data["score"]["score"] >= 99
    effects = data["score"]["effects"]
    assert {"background", "direct", "shadow", "reflection", "refraction", "edges"} <= set(effects)
    assert all(e["status"] == "pass" for e in effects.values()), effects
    assert data["exact"]["renders"] == 11


def test_the_foreign_program_needs_the_offsets_and_nothing_more(work: dict[str, Path]) -> None:
    """Float32 numpy against float32 C++: a handful of pixels whose centre ray grazes an edge
    match only within the spread of the model's turned renders; none differ beyond that."""
    data = _compare(work, "numpy.ppm", "classic")
    assert data["exact"]["differing"] == 0
    # Measured: 2 at 320x240 and 2 at 640x480, all on the mirror spheres.
    assert 1 <= data["exact"]["unstable"] <= 10


def test_another_mode_fails_against_classic_naming_the_effects(work: dict[str, Path]) -> None:
    data = _compare(work, "paper_mode.ppm", "classic")
    assert data["status"] == "fail" and data["exit_code"] == 2
    failing = [k for k, e in data["score"]["effects"].items() if e["status"] == "fail"]
    assert "refraction" in failing and "shadow" in failing  # Q2 (eta) and Q4 (shared shadow)
    assert any(
        "differ from classic beyond 8-bit linear quantisation; FLIP" in r for r in data["reasons"]
    )


def test_exact_classic_fails_against_mitsuba(work: dict[str, Path]) -> None:
    data = _compare(work, "numpy.ppm", "mitsuba")
    assert data["status"] == "fail" and data["score"]["basis"] == "flip"
    # Measured 38.42 at 320x240 (`rtval compare numpy.ppm --against mitsuba --scene
    # scenes/classic.json`, the 32 spp Whitted reference, Mitsuba 3 llvm_ad_rgb); the issue
    # measured 40.1 for scratchapixel's own program at 640x480. The reference's noise moves it
    # by well under 1.
    assert data["score"]["score"] == pytest.approx(38.4, abs=2.0)
    failing = {k for k, e in data["score"]["effects"].items() if e["status"] == "fail"}
    assert {"direct", "reflection", "refraction"} <= failing
    assert data["score"]["status"] == "fail"


def test_gradebook_names_the_model_and_every_fail_says_why(work: dict[str, Path]) -> None:
    out = work["root"] / "grades"

    def grade(*extra: str) -> tuple[str, dict[str, dict[str, str]]]:
        """Grades the submissions into out; rtval's stderr and the gradebook by student."""
        proc = run(
            [RTVAL, "grade", str(work["subs"]), "--scene", str(SCENE), "--out", str(out),
             "--size", "320x240", *extra]
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        with (out / "gradebook.csv").open() as f:
            return proc.stderr, {row["student"]: row for row in csv.DictReader(f)}

    stderr, book = grade()
    assert "against classic" in stderr
    assert set(book) == {Path(p).stem for p in EXACT} | {"paper_mode"}
    for sid, row in book.items():
        assert row["model"] == "classic"
        if sid == "paper_mode":  # failing: diagnosed (test_grade_diagnosis.py has more)
            assert row["status"] == "fail" and row["diagnosis"].startswith("looks like paper")
            assert row["reasons"].startswith("classic: ") and "refraction:" in row["reasons"]
        else:
            assert row["status"] == "pass" and float(row["score"]) >= 99, row
            assert row["diagnosis"] == ""
    page = (out / "students" / "numpy" / "index.html").read_text()
    assert "Judged against <strong>classic</strong>" in page
    # Grading against a demo model renders no Mitsuba reference.
    assert "mitsuba" not in stderr.lower()
    explain = run([RTVAL, "grade", "--explain", "paper_mode", "--out", str(out)])
    assert explain.returncode == 0 and "judged against classic" in explain.stdout
    # The rubric's `against` chooses the model; --against wins over it.
    rubric = work["root"] / "rubric.toml"
    rubric.write_text('[rubric]\nagainst = "paper"\n')
    _, book = grade("--rubric", str(rubric))
    assert book["paper_mode"]["status"] == "pass" and book["numpy"]["status"] == "fail"
    assert all(r["model"] == "paper" for r in book.values())


def test_against_needs_a_scene_and_a_known_model(work: dict[str, Path]) -> None:
    img = str(work["subs"] / "numpy.ppm")
    assert run([RTVAL, "compare", img, "--against", "classic"]).returncode == 64
    bad = run([RTVAL, "compare", img, "--against", "phong", "--scene", str(SCENE)])
    assert bad.returncode == 64 and "unknown model 'phong'" in bad.stderr


@pytest.mark.parametrize("mode", ["paper", "physical"])
def test_every_mode_passes_against_itself(tmp_path: Path, rtdemo: str, mode: str) -> None:
    outs = [tmp_path / f"{mode}.{ext}" for ext in ("exr", "png", "ppm")]
    outputs = ["--png", str(outs[1]), "--ppm", str(outs[2])]
    render_demo(rtdemo, SCENE, outs[0], "--mode", mode, "-q", *outputs, size=(160, 120))
    for image in outs:
        js = tmp_path / f"{image.name}.json"
        proc = run(
            [
                RTVAL,
                "compare",
                str(image),
                "--scene",
                str(SCENE),
                "--against",
                mode,
                "-q",
                "--json",
                str(js),
                "--cache",
                str(tmp_path / "cache"),
            ]
        )
        data = json.loads(js.read_text())
        assert proc.returncode == 0 and data["against"] == mode, (image, data["reasons"])
        assert data["score"]["score"] >= 99
