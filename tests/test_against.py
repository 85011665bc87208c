"""Judging against a target model, end to end at 320x240 (issue 16): a foreign float32 numpy
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
from helpers import ROOT, SCENES, run

from compare.judge.images import read_image

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
    size = ["--width", str(SIZE[0]), "--height", str(SIZE[1])]
    exr = subs / "rtdemo_exr.exr"
    proc = run(
        [
            rtdemo,
            "render",
            str(SCENE),
            "--mode",
            "classic",
            "-q",
            *size,
            "-o",
            str(exr),
            "--png",
            str(subs / "rtdemo_png.png"),
            "--ppm",
            str(subs / "rtdemo_ppm.ppm"),
        ]
    )
    assert proc.returncode == 0, proc.stderr
    # rtdemo's PPM truncates by default; its rounding twin, and both again from its EXR:
    round_ppm = ["--ppm", str(subs / "rtdemo_ppm_round.ppm"), "--ppm-rounding", "round"]
    proc = run([rtdemo, "render", str(SCENE), "--mode", "classic", "-q", *size, *round_ppm])
    assert proc.returncode == 0, proc.stderr
    rgb = read_image(exr).rgb
    _write_ppm(subs / "rtdemo_trunc.ppm", np.floor(255 * np.clip(rgb, 0, 1)))
    _write_ppm(subs / "rtdemo_round.ppm", np.floor(255 * np.clip(rgb, 0, 1) + 0.5))
    proc = run(
        [sys.executable, str(STUDENT), str(SCENE), str(subs / "numpy.ppm"), "--size", "320x240"],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert proc.returncode == 0, proc.stderr
    wrong = ["--ppm", str(subs / "paper_mode.ppm")]
    assert (
        run([rtdemo, "render", str(SCENE), "--mode", "paper", "-q", *size, *wrong]).returncode == 0
    )
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
    assert data["exact"]["renders"] == 5


def test_the_foreign_program_needs_the_offsets_and_nothing_more(work: dict[str, Path]) -> None:
    """Float32 numpy against float32 C++: a handful of pixels whose centre ray grazes an edge
    match only a model render turned by 1e-4 px; none differ beyond that."""
    data = _compare(work, "numpy.ppm", "classic")
    assert data["exact"]["differing"] == 0
    # Measured: 2 at 320x240 and 2 at 640x480, all on the mirror spheres.
    assert 1 <= data["exact"]["edge_ambiguous"] <= 10


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
    proc = run(
        [
            RTVAL,
            "grade",
            str(work["subs"]),
            "--scene",
            str(SCENE),
            "--out",
            str(out),
            "--size",
            "320x240",
        ]
    )
    assert proc.returncode == 0, proc.stderr
    assert "against classic" in proc.stderr
    with (out / "gradebook.csv").open() as f:
        book = {row["student"]: row for row in csv.DictReader(f)}
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
    assert "mitsuba" not in proc.stderr.lower()
    explain = run([RTVAL, "grade", "--explain", "paper_mode", "--out", str(out)])
    assert explain.returncode == 0 and "judged against classic" in explain.stdout
    # The rubric's `against` chooses the model; --against wins over it.
    rubric = work["root"] / "rubric.toml"
    rubric.write_text('[rubric]\nagainst = "paper"\n')
    proc = run(
        [
            RTVAL,
            "grade",
            str(work["subs"]),
            "--scene",
            str(SCENE),
            "--out",
            str(out),
            "--size",
            "320x240",
            "--rubric",
            str(rubric),
        ]
    )
    assert proc.returncode == 0, proc.stderr
    with (out / "gradebook.csv").open() as f:
        book = {row["student"]: row for row in csv.DictReader(f)}
    assert book["paper_mode"]["status"] == "pass" and book["numpy"]["status"] == "fail"
    assert all(r["model"] == "paper" for r in book.values())


def test_against_needs_a_scene_and_a_known_model(work: dict[str, Path]) -> None:
    img = str(work["subs"] / "numpy.ppm")
    assert run([RTVAL, "compare", img, "--against", "classic"]).returncode == 64
    bad = run([RTVAL, "compare", img, "--against", "phong", "--scene", str(SCENE)])
    assert bad.returncode == 64 and "unknown model 'phong'" in bad.stderr


@pytest.mark.parametrize("mode", ["paper", "physical"])
def test_every_mode_passes_against_itself(tmp_path: Path, rtdemo: str, mode: str) -> None:
    size = ["--width", "160", "--height", "120"]
    outs = [tmp_path / f"{mode}.{ext}" for ext in ("exr", "png", "ppm")]
    proc = run(
        [
            rtdemo,
            "render",
            str(SCENE),
            "--mode",
            mode,
            "-q",
            *size,
            "-o",
            str(outs[0]),
            "--png",
            str(outs[1]),
            "--ppm",
            str(outs[2]),
        ]
    )
    assert proc.returncode == 0, proc.stderr
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
