"""rtdemo as a user runs it: outputs, header, exit codes, no partial files."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo, run
from PIL import Image as PILImage

from compare.judge.images import read_image
from compare.judge.target_model import DEMO_MODES, MODE_QUIRKS

CLASSIC = str(SCENES / "classic.json")


def test_help_lists_modes_and_says_physical_has_point_lights(rtdemo: str) -> None:
    proc = run([rtdemo, "render", "--help"])
    assert proc.returncode == 0
    for word in (
        "--mode",
        "paper",
        "classic",
        "physical",
        "--fix",
        "--spp",
        "--ppm",
        "--png",
        "--ppm-rounding",
        "truncate",
        "round",
        "--threads",
        "no soft shadows",
    ):
        assert word in proc.stdout
    assert run([rtdemo, "--help"]).returncode == 0


def test_help_states_the_size_limit_and_the_out_of_memory_exit(rtdemo: str) -> None:
    top = run([rtdemo, "--help"]).stdout
    assert "1 out of memory" in top and "16384 a side or 64 Mpixels" in top
    render = " ".join(run([rtdemo, "render", "--help"]).stdout.split())
    assert "1-16384 each (at most 64 Mpixels, e.g. 8192x8192: exit 2 past that)" in render
    assert "out of memory is exit 1" in render


def test_exr_has_colour_aovs_and_header(rtdemo: str, tmp_path: Path) -> None:
    img = render_demo(
        rtdemo, CLASSIC, tmp_path / "c.exr", "--mode", "classic", "--threads", "2", size=(64, 48)
    )
    assert img.shape == (48, 64)
    assert set(img.aovs) == {"id", "depth", "N.X", "N.Y", "N.Z"}
    ids = img.aovs["id"]
    assert set(np.unique(ids)) <= {-1, 0, 1, 2, 3, 4, 5}
    assert (ids == -1).any() and (ids == 1).any()  # background and the glass sphere
    hit = ids >= 0
    assert (img.aovs["depth"][hit] > 0).all() and (img.aovs["depth"][~hit] == 0).all()
    normals = np.stack([img.aovs[c] for c in ("N.X", "N.Y", "N.Z")], axis=-1)
    np.testing.assert_allclose(np.linalg.norm(normals[hit], axis=-1), 1, atol=1e-5)
    assert img.header["rtval.scene"] == "classic"
    assert img.header["rtval.mode"] == "classic"
    assert img.header["rtval.quirks"] == "Q1,Q3,Q5,Q6,Q7,Q8,Q10"
    assert float(img.header["rtval.render_seconds"]) > 0
    # Ray counts: one camera ray per pixel at 1 spp; glass and mirrors spawn secondary rays.
    assert int(img.header["rtval.rays_camera"]) == 64 * 48
    assert int(img.header["rtval.rays_secondary"]) > 0 and int(img.header["rtval.rays_shadow"]) > 0


def test_header_lists_the_quirks_present(rtdemo: str, tmp_path: Path) -> None:
    def quirks(*args: str) -> str:
        out = tmp_path / "q.exr"
        return render_demo(rtdemo, CLASSIC, out, *args, size=(16, 12)).header["rtval.quirks"]

    paper = ",".join(f"Q{i}" for i in range(1, 14))
    assert quirks() == paper
    assert quirks("--fix", "Q11,Q12,Q13") == paper.removesuffix(",Q11,Q12,Q13")
    assert quirks("--mode", "classic", "--quirk", "Q12") == "Q1,Q3,Q5,Q6,Q7,Q8,Q10,Q12"
    assert quirks("--mode", "physical", "--quirk", "Q13,Q11") == "Q11,Q13"


@pytest.mark.parametrize("mode", DEMO_MODES)
def test_the_mode_presets_of_python_and_rtdemo_are_one(
    rtdemo: str, tmp_path: Path, mode: str
) -> None:
    """MODE_QUIRKS (what the judge believes a mode holds) and rtdemo's quirks_for (what it
    renders): a mode changed on one side only would judge against the wrong algorithm."""
    header = render_demo(rtdemo, CLASSIC, tmp_path / "m.exr", "--mode", mode, size=(8, 6)).header
    listed = header["rtval.quirks"]
    rendered = set() if listed == "none" else {int(q[1:]) for q in listed.split(",")}
    assert rendered == set(MODE_QUIRKS[mode])


def test_ray_counts_follow_the_options(rtdemo: str, tmp_path: Path) -> None:
    def rays(*args: str) -> dict[str, int]:
        h = render_demo(rtdemo, CLASSIC, tmp_path / "r.exr", *args, size=(40, 30)).header
        return {k: int(h[f"rtval.rays_{k}"]) for k in ("camera", "secondary", "shadow")}

    base = rays()
    assert rays("--threads", "1") == base == rays("--threads", "2")  # counting is exact per thread
    assert rays("--no-shadows")["shadow"] == 0
    assert rays("--max-depth", "0")["secondary"] == 0
    # 4 spp: four camera rays per pixel plus the centre ray for the AOVs.
    assert rays("--spp", "4", "--fix", "Q10")["camera"] == 5 * 40 * 30


def test_exr_compression_is_lossless_and_checked(rtdemo: str, tmp_path: Path) -> None:
    images = {}
    for c in ("none", "rle", "zip"):
        out = tmp_path / f"{c}.exr"
        images[c] = render_demo(rtdemo, CLASSIC, out, "--exr-compression", c, size=(80, 60))
    for c in ("rle", "zip"):
        np.testing.assert_array_equal(images[c].rgb, images["none"].rgb)
        np.testing.assert_array_equal(images[c].aovs["depth"], images["none"].aovs["depth"])
    assert (tmp_path / "zip.exr").stat().st_size < (tmp_path / "none.exr").stat().st_size
    proc = run(
        [rtdemo, "render", CLASSIC, "-o", str(tmp_path / "bad.exr"), "--exr-compression", "lz4"]
    )
    assert proc.returncode == 2 and "--exr-compression" in proc.stderr
    assert not (tmp_path / "bad.exr").exists()


def test_ppm_is_linear_and_png_is_srgb_of_the_same_render(rtdemo: str, tmp_path: Path) -> None:
    exr, png, ppm = tmp_path / "a.exr", tmp_path / "a.png", tmp_path / "a.ppm"
    linear = render_demo(
        rtdemo, CLASSIC, exr, "--png", str(png), "--ppm", str(ppm), size=(80, 60)
    ).rgb.astype(np.float32)
    ref = np.clip(linear, 0, 1)
    # PPM is linear and truncated by default, byte = (unsigned char)(min(1, x) * 255) as the
    # paper's program family writes it: exactly that in float32, not just within a level.
    truncated = (np.clip(np.nan_to_num(linear, nan=0.0), 0, 1) * np.float32(255)).astype(np.uint8)
    ppm_bytes = np.asarray(PILImage.open(ppm))
    assert np.array_equal(ppm_bytes, truncated)
    assert not np.array_equal(ppm_bytes, np.rint(ref * 255).astype(np.uint8))  # not rounding
    # PNG is sRGB: decoding it back gives linear values within one sRGB step.
    assert np.abs(read_image(png).rgb - ref).max() < 0.02


def test_ppm_rounding_option(rtdemo: str, tmp_path: Path) -> None:
    exr, rounded = tmp_path / "a.exr", tmp_path / "round.ppm"
    linear = render_demo(
        rtdemo, CLASSIC, exr, "--ppm", str(rounded), "--ppm-rounding", "round", size=(80, 60)
    ).rgb
    ref = np.clip(linear, 0, 1)
    assert np.abs(read_image(rounded).rgb - ref).max() <= 0.5 / 255 + 1e-6
    bad = run(
        [rtdemo, "render", CLASSIC, "--ppm", str(tmp_path / "bad.ppm"), "--ppm-rounding", "floor"]
    )
    assert bad.returncode == 2 and "--ppm-rounding" in bad.stderr and "floor" in bad.stderr
    assert not (tmp_path / "bad.ppm").exists()


def test_a_single_output_streamed_is_the_kept_frames_file(rtdemo: str, tmp_path: Path) -> None:
    # One PPM or one uncompressed EXR is written band by band as it renders (the summary line
    # says so); --keep-frame writes the whole frame afterwards. The same PPM bytes, the same EXR
    # pixels and header but for the time; the padding that keeps the streamed header's size
    # known is spaces and is not part of the header read_image gives. Full size, 2 threads:
    # bands from both threads at once.
    args = ("--mode", "classic", "--threads", "2")
    for name in ("streamed", "kept"):
        extra = ("--keep-frame",) if name == "kept" else ()
        for out in (f"{name}.ppm", f"{name}.exr"):
            option = "--ppm" if out.endswith(".ppm") else "-o"
            proc = run([rtdemo, "render", CLASSIC, option, str(tmp_path / out), *args, *extra])
            assert proc.returncode == 0, proc.stderr
            assert ("(streamed during the frame)" in proc.stderr) == (name == "streamed")
    assert (tmp_path / "streamed.ppm").read_bytes() == (tmp_path / "kept.ppm").read_bytes()
    streamed, kept = read_image(tmp_path / "streamed.exr"), read_image(tmp_path / "kept.exr")
    np.testing.assert_array_equal(streamed.rgb, kept.rgb)
    assert set(streamed.aovs) == set(kept.aovs) == {"id", "depth", "N.X", "N.Y", "N.Z"}
    for name in kept.aovs:
        np.testing.assert_array_equal(streamed.aovs[name], kept.aovs[name])
    raw = (tmp_path / "streamed.exr").read_bytes()
    at = raw.index(b"rtval.padding\0string\0") + len(b"rtval.padding\0string\0")
    size = int.from_bytes(raw[at : at + 4], "little")
    assert size > 0 and raw[at + 4 : at + 4 + size] == b" " * size
    assert "rtval.padding" not in streamed.header
    for h in (streamed.header, kept.header):
        assert float(h.pop("rtval.render_seconds")) > 0
    assert streamed.header == kept.header
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "kept.exr",
        "kept.ppm",
        "streamed.exr",
        "streamed.ppm",
    ]


def test_threads_do_not_change_the_image(rtdemo: str, tmp_path: Path) -> None:
    a, b = (
        render_demo(rtdemo, CLASSIC, tmp_path / f"{t}.exr", "--threads", t, size=(96, 72))
        for t in ("1", "2")
    )
    np.testing.assert_array_equal(a.rgb, b.rgb)


def test_spp_averages_stratum_centres_and_needs_q10_fixed(rtdemo: str, tmp_path: Path) -> None:
    out = tmp_path / "s.exr"
    refused = run([rtdemo, "render", CLASSIC, "-o", str(out), "--spp", "4"])
    assert refused.returncode == 2 and "Q10" in refused.stderr and not out.exists()
    strata = render_demo(rtdemo, CLASSIC, out, "--spp", "4", "--fix", "Q10", size=(32, 24))
    # 2x2 stratum centres of a 32x24 image are the pixel centres of the 64x48 image.
    big = render_demo(rtdemo, CLASSIC, tmp_path / "big.exr", size=(64, 48))
    fine = big.rgb.reshape(24, 2, 32, 2, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(strata.rgb, fine, atol=1e-5)


@pytest.mark.parametrize(
    "args,code,needle",
    [
        (["--mode", "physics"], 2, "unknown mode"),
        (["--fix", "Q14"], 2, "Q1 ... Q13"),
        (["--quirk", "Q0"], 2, "Q0"),
        (["--width", "0"], 2, "--width"),
        (["--width", "16385"], 2, "--width"),
        (["--width", "abc"], 2, "--width"),
        (["--width", "16384", "--height", "16384"], 2, "too large"),
        (["--spp", "3", "--mode", "physical"], 2, "perfect square"),
        (["--max-depth", "65"], 2, "--max-depth"),
        (["--backend", "vulkan"], 2, "--backend"),
        (["--bogus"], 2, "unknown option"),
    ],
)
def test_bad_arguments_give_one_clear_line_and_exit_2(
    rtdemo: str, tmp_path: Path, args: list[str], code: int, needle: str
) -> None:
    out = tmp_path / "x.exr"
    proc = run([rtdemo, "render", CLASSIC, "-o", str(out), *args])
    assert proc.returncode == code
    assert needle in proc.stderr and proc.stderr.startswith("rtdemo: error:")
    assert not out.exists()


def test_missing_scene_is_exit_3(rtdemo: str, tmp_path: Path) -> None:
    proc = run([rtdemo, "render", str(tmp_path / "none.json"), "-o", str(tmp_path / "x.exr")])
    assert proc.returncode == 3 and "none.json" in proc.stderr


def test_unwritable_output_is_exit_4_before_rendering(rtdemo: str, tmp_path: Path) -> None:
    proc = run([rtdemo, "render", CLASSIC, "-o", str(tmp_path / "no" / "dir" / "x.exr")])
    assert proc.returncode == 4 and "does not exist" in proc.stderr
    if os.geteuid() != 0:  # root can write anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        assert run([rtdemo, "render", CLASSIC, "-o", str(ro / "x.exr")]).returncode == 4


@pytest.mark.parametrize("engine", ["packet", "scalar"])
@pytest.mark.parametrize("output", ["x.exr", "x.ppm"])  # streamed by the packet engine
def test_a_spent_ray_budget_stops_with_exit_6_and_no_file(
    rtdemo: str, tmp_path: Path, engine: str, output: str
) -> None:
    # The 40x30 classic frame traces 7714 rays (its header's count, the next test): a budget
    # of exactly that finishes, one ray fewer stops.
    out = tmp_path / output
    common = [rtdemo, "render", CLASSIC, "-o", str(out), "--mode", "classic", "--engine", engine]
    common += ["--width", "40", "--height", "30"]
    done = run([*common, "--ray-budget", "7714"])
    assert done.returncode == 0, done.stderr
    out.unlink()
    proc = run([*common, "--ray-budget", "7713"])
    assert proc.returncode == 6
    assert proc.stderr.startswith("rtdemo: ray budget of 7713 rays exhausted after ")
    assert list(tmp_path.iterdir()) == []  # neither the output nor a temporary file


def test_the_header_counts_the_rays_a_budget_limits(rtdemo: str, tmp_path: Path) -> None:
    # 7714: this header's sum when --ray-budget came (1200 camera rays, and the secondary and
    # shadow rays of classic.json at 40x30); both engines count alike (packet_engine_test.cpp).
    h = render_demo(rtdemo, CLASSIC, tmp_path / "r.exr", "--mode", "classic", size=(40, 30)).header
    assert sum(int(h[f"rtval.rays_{k}"]) for k in ("camera", "secondary", "shadow")) == 7714


def test_no_temporary_files_are_left_behind(rtdemo: str, tmp_path: Path) -> None:
    render_demo(
        rtdemo, CLASSIC, tmp_path / "x.exr", "--png", str(tmp_path / "x.png"), size=(16, 12)
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.exr", "x.png"]
