"""`rtval diagnose`, rtdemo's --quirk and --mistake, and the named-mistakes catalogue.

The foreign images are student-style variants of the numpy classic program
(tests/student_variants.py), written as truncating PPMs at 160x120.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo, run
from student_variants import VARIANTS, render_variant

from compare.judge.candidate import Candidate
from compare.judge.diagnose import Diagnosis, diagnose
from compare.judge.images import Image, read_image
from compare.judge.mistakes import catalogue, parse_mistakes
from compare.judge.target_model import TargetModel, parse_model
from compare.render.candidates import CandidateRenderer
from scene_model.scene import load_scene

RTVAL = str(Path(sys.executable).with_name("rtval"))
CLASSIC = SCENES / "classic.json"
W, H = 160, 120


def _render(rtdemo: str, out: Path, *args: str, size: tuple[int, int] = (W, H)) -> Image:
    return render_demo(rtdemo, CLASSIC, out, "-q", *args, size=size)


# --- the catalogue, in one place -----------------------------------------------------------


def test_rtdemo_help_lists_the_catalogue_it_embeds(rtdemo: str) -> None:
    words = " ".join(run([rtdemo, "render", "--help"]).stdout.split())  # undo the wrapping
    for m in catalogue().values():
        assert f" {m.name} {m.explanation}" in words, m.name


def test_unknown_mistake_is_a_usage_error_in_both_languages(rtdemo: str, tmp_path: Path) -> None:
    proc = run([rtdemo, "render", str(CLASSIC), "-o", str(tmp_path / "x.exr"), "--mistake", "nope"])
    assert proc.returncode == 2 and "unknown mistake 'nope'" in proc.stderr
    with pytest.raises(ValueError, match="unknown mistake 'nope'"):
        parse_mistakes("no_offset,nope")
    gl = run([rtdemo, "render", str(CLASSIC), "-o", str(tmp_path / "x.exr"), "--backend", "gl",
              "--mistake", "no_offset"])  # fmt: skip
    assert gl.returncode == 2 and "CPU tracer" in gl.stderr


# --- rtdemo --quirk and --mistake ----------------------------------------------------------


def test_quirk_adds_on_top_of_a_mode(rtdemo: str, tmp_path: Path) -> None:
    # classic + Q2 + Q4 + Q9 is the paper's program: both spellings render the same pixels.
    a = _render(rtdemo, tmp_path / "a.exr", "--mode", "classic", "--quirk", "Q2,Q4,Q9")
    b = _render(rtdemo, tmp_path / "b.exr", "--mode", "paper")
    assert np.array_equal(a.rgb, b.rgb, equal_nan=True)
    assert a.header["rtval.quirks"] == "Q1,Q2,Q3,Q4,Q5,Q6,Q7,Q8,Q9,Q10"
    c = _render(rtdemo, tmp_path / "c.exr", "--mode", "classic", "--quirk", "Q2")
    assert not np.array_equal(c.rgb, b.rgb, equal_nan=True)  # Q4 and Q9 change the shadows
    # The target model's own options (compare/judge/target_model.py) reach the same image.
    args = Candidate.from_model(parse_model("classic+Q2+Q4+Q9")).rtdemo_args()
    d = _render(rtdemo, tmp_path / "d.exr", *args)
    assert np.array_equal(d.rgb, b.rgb, equal_nan=True)


def test_every_mistake_changes_the_classic_render_and_same_as_holds(
    rtdemo: str, tmp_path: Path
) -> None:
    base = _render(rtdemo, tmp_path / "base.exr", "--mode", "classic")
    for name, m in catalogue().items():
        im = _render(rtdemo, tmp_path / f"{name}.exr", "--mode", "classic", "--mistake", name)
        assert im.header["rtval.mistakes"] == name
        if m.same_as is None:
            assert not np.array_equal(im.rgb, base.rgb, equal_nan=True), name
    # The catalogue's same_as claims, rendered: each pair gives identical pixels.
    pairs = {
        "no_shadows": ["--mode", "classic", "--no-shadows"],
        "depth_cut": ["--mode", "classic", "--max-depth", "4"],
    }
    for name, args in pairs.items():
        a = read_image(tmp_path / f"{name}.exr")
        b = _render(rtdemo, tmp_path / f"{name}-same.exr", *args)
        assert np.array_equal(a.rgb, b.rgb, equal_nan=True), name
    # shadow_past_light is Q5: compare where Q5 is absent (physical mode).
    a = _render(
        rtdemo, tmp_path / "spl.exr", "--mode", "physical", "--mistake", "shadow_past_light"
    )
    b = _render(rtdemo, tmp_path / "q5.exr", "--mode", "physical", "--quirk", "Q5")
    assert np.array_equal(a.rgb, b.rgb, equal_nan=True)


# --- the search, with an injected renderer (no process) ------------------------------------


def _toy() -> tuple[np.ndarray, np.ndarray]:
    """32x32 AOVs of the classic scene's glass sphere (id 1) on the background."""
    ids = np.full((32, 32), -1.0, np.float32)
    ids[8:24, 8:24] = 1.0
    return ids, np.where(ids >= 0, 20.0, 0.0).astype(np.float32)


def _toy_render(c: TargetModel | Candidate) -> Image:
    """Background 1 (0 with black_background); glass 0.3, plus 0.2 with Q2 present and 0.1
    with Q4. Every other switch changes nothing, so the search must find Q2 and call the rest
    (but Q4) invisible."""
    c = c if isinstance(c, Candidate) else Candidate.from_model(c)
    ids, depth = _toy()
    rgb = np.full((32, 32, 3), 0.0 if "black_background" in c.mistakes else 1.0, np.float32)
    rgb[ids >= 0] = 0.3 + (0.2 if 2 in c.quirks else 0.0) + (0.1 if 4 in c.quirks else 0.0)
    return Image(rgb=rgb, aovs={"id": ids, "depth": depth})


def _toy_image(glass: np.ndarray | float) -> Image:
    rgb = np.ones((32, 32, 3), np.float32)
    rgb[8:24, 8:24] = glass
    q = np.floor(rgb * 255) / 255  # as a truncating 8-bit writer stores it
    return Image(rgb=q.astype(np.float32), path="toy.ppm", encoding="linear")


def test_search_finds_the_one_change_and_names_the_invisible_quirks() -> None:
    scene = load_scene(CLASSIC)
    d = diagnose(_toy_image(0.5), scene, _toy_render, start=Candidate.of_mode("classic"))
    assert d.result == "classic+Q2" and d.quirks_present == [2]
    assert d.causes == ["+Q2"] and d.reason() == "looks like classic+Q2 (+Q2)"
    assert d.effects["refraction"].state == "explained" and d.exact
    assert d.effects["refraction"].final_distance == 0.0
    assert d.effects["refraction"].start_distance > 40  # 0.2 * 255 levels, less the one allowed
    # Q10 too: every candidate is rendered at one ray per pixel.
    assert d.quirks_invisible == [1, 3, 5, 6, 7, 8, 9, 10] and d.quirks_absent == [4]
    assert "explained by +Q2" in d.summary and "refraction FLIP" in d.summary


def test_search_says_when_nothing_explains_a_region() -> None:
    scene = load_scene(CLASSIC)
    noise = np.random.default_rng(3).uniform(
        0, 0.6, (16, 16, 3)
    )  # mean 0.3: Q2 cannot help.astype(np.float32)
    d = diagnose(_toy_image(noise), scene, _toy_render, start=Candidate.of_mode("classic"))
    # The glass and the silhouette pixels around it hold the noise.
    assert d.unexplained == ["refraction", "edges"] and not d.exact
    assert d.effects["background"].state == "as start"
    assert "a new bug, not a quirk" in d.effects["refraction"].sentence
    assert "nothing explains refraction" in d.summary
    assert d.reason() == "looks like classic; unexplained: refraction, edges"


# --- student programs ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def variants(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    scene = load_scene(CLASSIC)
    folder = tmp_path_factory.mktemp("students")
    return {v: render_variant(scene, v, W, H, folder / f"{v}.ppm") for v in ["exact", *VARIANTS]}


def _diagnose(path: Path) -> Diagnosis:
    scene = load_scene(CLASSIC)
    image = read_image(path)
    with CandidateRenderer(CLASSIC, W, H, threads=1) as render:
        return diagnose(image, scene, render, parallel=2)


def _names(d: Diagnosis, cause: str) -> bool:
    if cause.startswith("+Q"):
        return int(cause[2:]) in d.quirks_present and d.mode == "classic"
    if cause in ("shadows", "reflection", "refraction"):
        return cause in d.effects_off
    return cause in d.mistakes


def test_the_exact_classic_program_is_classic(variants: dict[str, Path]) -> None:
    d = _diagnose(variants["exact"])
    assert d.result == "classic" and not d.steps and d.exact
    assert all(f.state == "as start" for f in d.effects.values())


@pytest.mark.slow
@pytest.mark.parametrize("variant", list(VARIANTS))
def test_diagnose_names_the_students_mistake(variants: dict[str, Path], variant: str) -> None:
    # All six are named (the issue asks for five of six). no_offset is named but only "partly
    # explained": its acne is decided pixel by pixel by float rounding, which a float64 numpy
    # program and float32 rtdemo do differently, so only the regions' averages agree. (A
    # float32 C++ program with bias 0, bench/baseline/seed_tracer.cpp edited so, was explained
    # exactly: refraction FLIP 0.340 -> 0.013 at 640x480, every effect matched.)
    d = _diagnose(variants[variant])
    assert _names(d, VARIANTS[variant]), d.sentences
    assert len(d.steps) == 1, d.sentences  # one cause, nothing fitted on top
    if variant != "no_offset":
        assert d.exact, d.sentences


# --- the command ---------------------------------------------------------------------------


def test_cli_writes_json_and_documents_exit_codes(
    variants: dict[str, Path], tmp_path: Path
) -> None:
    out = tmp_path / "d.json"
    proc = run([RTVAL, "diagnose", str(variants["black_background"]), "--scene", "classic",
                "--json", str(out), "--against-start", "classic"], cwd=SCENES.parent)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    data = json.loads(out.read_text())
    assert data["mistakes"] == ["black_background"] and data["start"] == "classic"
    assert data["effects"]["background"]["state"] == "explained"
    assert "diagnose: round 1" in proc.stderr and "black_background" in proc.stdout

    bad_scene = tmp_path / "bad.json"
    bad_scene.write_text("{")
    assert (
        run([RTVAL, "diagnose", str(variants["exact"]), "--scene", str(bad_scene)]).returncode == 3
    )
    broken = tmp_path / "broken.ppm"
    broken.write_bytes(b"P6\n9 9\n255\nxx")
    assert run([RTVAL, "diagnose", str(broken), "--scene", str(CLASSIC)]).returncode == 4
    assert run([RTVAL, "diagnose", str(broken)]).returncode == 64  # --scene missing
    start = run([RTVAL, "diagnose", str(variants["exact"]), "--scene", str(CLASSIC),
                 "--against-start", "mitsuba"])  # fmt: skip
    assert start.returncode == 64 and "demo model" in start.stderr
    image = variants["exact"]
    same = run([RTVAL, "diagnose", str(image), "--scene", str(CLASSIC), "--json", str(image)])
    assert same.returncode == 64 and "IMAGE" in same.stderr and image.read_bytes()[:2] == b"P6"


@pytest.mark.slow
def test_several_causes_from_a_far_start_are_retold_from_the_simplest_mode(
    rtdemo: str, tmp_path: Path
) -> None:
    # The paper's program with exact Fresnel, gamma-encoded on top, as an sRGB PNG: physical
    # mode is nearest, the search walks there from it (double_gamma, +Q2, +Q7, ...), and the
    # result is retold from paper in two steps.
    png = tmp_path / "gamma.png"
    scene_file = SCENES / "paper.json"
    image = render_demo(rtdemo, scene_file, png, "-q", "--mode", "paper", "--fix", "Q8",
                        "--mistake", "double_gamma", size=(W, H))  # fmt: skip
    with CandidateRenderer(scene_file, W, H, threads=1) as render:
        d = diagnose(image, load_scene(scene_file), render, parallel=2)
    assert d.result == "paper-Q8 --mistake double_gamma", d.sentences
    assert sorted(d.causes) == ["-Q8", "double_gamma"] and d.exact
