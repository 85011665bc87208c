"""Every command's input checks: bad or hostile scenes, images, numbers and outputs are each
refused fast with one clear error naming the file or field and the documented exit code
(rtval 3 invalid scene, 4 unreadable input or unwritable output, 64 bad arguments; compare 3
size mismatch), never a hang, a traceback, gigabytes of memory or a partial file."""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from helpers import SCENES, run

from compare.judge.images import ImageError, ImageSizeError, read_image, write_exr
from scene_model.scene import SceneError, load_scene, parse_scene

RTVAL = str(Path(sys.executable).with_name("rtval"))
SCENE_TEXT = (SCENES / "classic.json").read_text()


def _rtval(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return run([RTVAL, *args], timeout=timeout)


def _no_traceback(proc: subprocess.CompletedProcess[str]) -> None:
    assert "Traceback" not in proc.stderr, proc.stderr


# ---------------------------------------------------------------- scenes


@pytest.mark.parametrize("kind", ["fifo", "dev_zero", "folder"])
def test_scene_that_is_not_a_regular_file_is_refused_at_once(tmp_path: Path, kind: str) -> None:
    path = tmp_path / "scene.json"
    if kind == "fifo":
        os.mkfifo(path)  # no writer: reading it would block forever
        what = "a FIFO"
    elif kind == "dev_zero":
        os.symlink("/dev/zero", path)  # reading it would grow memory without end
        what = "a character device"
    else:
        path.mkdir()
        what = "a folder"
    with pytest.raises(SceneError, match=f"{path}: is {what}, not a regular file"):
        load_scene(path)
    proc = _rtval("export", str(path), "-o", str(tmp_path / "x.xml"), timeout=60)
    assert proc.returncode == 3 and str(path) in proc.stderr
    _no_traceback(proc)
    assert not (tmp_path / "x.xml").exists()


def test_scene_larger_than_the_bound_is_refused(tmp_path: Path) -> None:
    from scene_model.scene import MAX_SCENE_BYTES

    path = tmp_path / "big.json"
    with path.open("wb") as f:
        f.truncate(MAX_SCENE_BYTES + 1)  # sparse: costs no disk
    with pytest.raises(SceneError, match="16777217 bytes, more than the 16777216 allowed"):
        load_scene(path)


def test_bom_is_accepted_by_both_loaders(tmp_path: Path, rtdemo: str) -> None:
    """RFC 8259 lets parsers ignore a BOM; nlohmann json (C++) does, so Python does too."""
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + SCENE_TEXT.encode())
    plain = load_scene(SCENES / "classic.json")
    with_bom = load_scene(path)
    assert with_bom.spheres == plain.spheres and with_bom.camera == plain.camera
    proc = run([rtdemo, "render", str(path), "-o", str(tmp_path / "x.exr"), "-q",
                "--width", "8", "--height", "6"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr


def test_deep_nesting_is_a_scene_error_not_a_recursion_error(tmp_path: Path) -> None:
    path = tmp_path / "nested.json"
    path.write_text("[" * 100_000)
    with pytest.raises(SceneError, match="nested 100000 levels deep, at most 64"):
        load_scene(path)
    proc = _rtval("export", str(path), "-o", str(tmp_path / "x.xml"))
    assert proc.returncode == 3 and "nested 100000 levels deep" in proc.stderr
    _no_traceback(proc)
    # brackets inside strings do not count
    j = json.loads(SCENE_TEXT)
    j["description"] = "[{" * 100 + '\\"[' * 100
    assert parse_scene(json.dumps(j)).description == j["description"]


@pytest.mark.parametrize(
    ("field", "literal"),
    [("bias", "1" + "0" * 400), ("bias", "1" + "0" * 5000), ("max_depth", "9" * 30)],
)
def test_huge_integers_are_scene_errors_naming_the_field(field: str, literal: str) -> None:
    j = json.loads(SCENE_TEXT)
    j[field] = 0
    text = json.dumps(j).replace(f'"{field}": 0', f'"{field}": {literal}')
    with pytest.raises(SceneError, match=rf"<string>: {field}: expected"):
        parse_scene(text)


# ---------------------------------------------------------------- images


def _png_declaring(path: Path, w: int, h: int) -> None:
    """A valid RGB PNG of w x h black pixels: tiny on disk, w*h*3 bytes once decoded."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    z = zlib.compressobj(9)
    rows = bytes(w * 3 + 1) * 200
    idat = (
        b"".join(z.compress(rows) for _ in range(h // 200))
        + z.compress(bytes(w * 3 + 1) * (h % 200))
        + z.flush()
    )
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", idat)
        + chunk(b"IEND", b"")
    )


@pytest.fixture(scope="module")
def huge_png(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("img") / "huge.png"
    _png_declaring(path, 9400, 9400)
    assert path.stat().st_size < 1_000_000  # the file: ~280 KB
    return path


_PEAK = """
import resource, sys, time
from compare.judge.images import ImageError, read_image
import PIL.PngImagePlugin  # imports are not what we measure
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter()
try:
    read_image(sys.argv[1], expected_size=(480, 640))
    print("read")
except ImageError as e:
    print("refused:", e)
print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) // 1024, time.perf_counter() - t)
"""


def test_huge_declared_png_is_refused_from_its_header(huge_png: Path) -> None:
    proc = run([sys.executable, "-c", _PEAK, str(huge_png)], timeout=120)
    assert proc.returncode == 0, proc.stderr
    verdict, numbers = proc.stdout.strip().splitlines()
    assert verdict == f"refused: {huge_png}: wrong size 9400x9400, expected 640x480"
    grown_mb, seconds = numbers.split()
    assert int(grown_mb) < 50, f"peak RSS grew {grown_mb} MB (decoding would take ~1 GB)"
    assert float(seconds) < 2.0


def test_compare_refuses_size_mismatch_before_decoding(huge_png: Path, tmp_path: Path) -> None:
    ref = tmp_path / "ref.exr"
    write_exr(ref, np.zeros((48, 64, 3), np.float32))
    wrapper = "import resource,subprocess,sys; p=subprocess.run(sys.argv[1:]); print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss // 1024)"
    proc = run(
        [sys.executable, "-c", wrapper, RTVAL, "compare", str(ref), str(huge_png)], timeout=120
    )
    code, peak_mb = proc.stdout.split()
    assert int(code) == 3 and "size mismatch" in proc.stderr and str(huge_png) in proc.stderr
    assert int(peak_mb) < 600, f"rtval compare peaked at {peak_mb} MB"


@pytest.mark.parametrize("kind", ["fifo", "dev_zero", "folder"])
def test_image_that_is_not_a_regular_file_is_refused(tmp_path: Path, kind: str) -> None:
    path = tmp_path / "img.ppm"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dev_zero":
        os.symlink("/dev/zero", path)
    else:
        path.mkdir()
    with pytest.raises(ImageError, match=f"{path}: is a .*not a regular file"):
        read_image(path)
    proc = _rtval("compare", str(path), str(path), timeout=60)
    assert proc.returncode == 4 and str(path) in proc.stderr
    _no_traceback(proc)


def test_wrong_size_is_found_in_every_format_header(tmp_path: Path) -> None:
    exr = tmp_path / "a.exr"
    write_exr(exr, np.zeros((6, 8, 3), np.float32))
    pfm = tmp_path / "a.pfm"
    pfm.write_bytes(b"PF\n8 6\n-1.0\n" + np.zeros((6, 8, 3), "<f4").tobytes())
    for p in (exr, pfm):
        with pytest.raises(ImageSizeError) as e:
            read_image(p, expected_size=(48, 64))
        assert e.value.size == (6, 8) and e.value.expected == (48, 64)
        assert read_image(p, expected_size=(6, 8)).shape == (6, 8)


# ---------------------------------------------------------------- numbers


@pytest.mark.parametrize("scale", [b"nan", b"inf", b"-inf", b"0"])
def test_pfm_scale_must_be_finite_and_non_zero(tmp_path: Path, scale: bytes) -> None:
    p = tmp_path / "a.pfm"
    p.write_bytes(b"PF\n2 2\n" + scale + b"\n" + bytes(48))
    with pytest.raises(ImageError, match="PFM scale: expected a finite number != 0"):
        read_image(p)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--fail", "nan"),
        ("--warn", "inf"),
        ("--failpercent", "150"),
        ("--min-ssim", "nan"),
        ("--max-flip", "-1"),
        ("--hardfail", "nan"),
    ],
)
def test_compare_tolerances_are_finite_and_in_range(
    tmp_path: Path, option: str, value: str
) -> None:
    ref = tmp_path / "ref.exr"
    write_exr(ref, np.zeros((4, 4, 3), np.float32))
    proc = _rtval("compare", str(ref), str(ref), option, value)
    assert proc.returncode == 64 and f"tolerance {option}: expected a finite number" in proc.stderr
    _no_traceback(proc)


@pytest.mark.parametrize(
    ("toml", "needle"),
    [
        (
            "[effects.refraction]\nweight = nan\n",
            "weight must be a number from 0 to 1000 \\(finite\\), got nan",
        ),
        (
            "[effects.refraction]\nmax_flip = inf\n",
            "max_flip must be a number >= 0 \\(finite\\), got inf",
        ),
        (
            "[effects.refraction]\nmin_ssim = 2.0\n",
            "min_ssim must be a number from -1 to 1 \\(finite\\), got 2.0",
        ),
        ("[rubric]\npass_score = nan\n", "pass_score must be a number \\(finite\\), got nan"),
    ],
)
def test_rubric_numbers_are_finite_and_in_range(toml: str, needle: str) -> None:
    from compare.judge.rubric import RubricError, parse_rubric

    with pytest.raises(RubricError, match=f"r.toml: line 2: {needle}"):
        parse_rubric(toml, "r.toml")


# ---------------------------------------------------------------- outputs


@pytest.fixture
def pair(tmp_path: Path) -> tuple[Path, Path]:
    ref, test = tmp_path / "ref.exr", tmp_path / "test.exr"
    write_exr(ref, np.zeros((4, 4, 3), np.float32))
    write_exr(test, np.zeros((4, 4, 3), np.float32))
    return ref, test


@pytest.mark.parametrize("kind", ["fifo", "symlink"])
def test_outputs_replace_only_regular_files(
    tmp_path: Path, pair: tuple[Path, Path], kind: str
) -> None:
    """Renaming over a FIFO (or /dev/null as root) would turn it into a plain file."""
    target = tmp_path / "out.json"
    if kind == "fifo":
        os.mkfifo(target)
    else:
        os.symlink(tmp_path / "elsewhere.json", target)
    proc = _rtval("compare", str(pair[0]), str(pair[1]), "--json", str(target))
    assert proc.returncode == 4 and f"{target}: is a" in proc.stderr
    assert "outputs only ever replace regular files" in proc.stderr
    assert target.is_symlink() if kind == "symlink" else target.is_fifo()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_output_equal_to_an_input_or_another_output_is_refused(
    tmp_path: Path, pair: tuple[Path, Path]
) -> None:
    ref, test = pair
    before = test.read_bytes()
    proc = _rtval("compare", str(ref), str(test), "--json", str(test))
    assert proc.returncode == 64 and "--json names the same file as TEST" in proc.stderr
    assert test.read_bytes() == before
    out = tmp_path / "x.png"
    proc = _rtval(
        "compare",
        str(ref),
        str(test),
        "--json",
        str(out),
        "--diff-image",
        str(tmp_path / "." / "x.png"),
    )
    assert proc.returncode == 64 and "--diff-image names the same file as --json" in proc.stderr
    assert not out.exists()


_FULL_DISK = """
import resource, signal, sys
from safe_files.paths import write_atomic
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, (1 << 20, 1 << 20))
try:
    write_atomic(sys.argv[1], b"x" * (4 << 20))
except OSError as e:
    print("error", e.errno)
"""


def test_a_full_disk_leaves_no_partial_file(tmp_path: Path) -> None:
    target = tmp_path / "gradebook.csv"
    target.write_text("old\n")
    proc = run([sys.executable, "-c", _FULL_DISK, str(target)], timeout=60)
    assert proc.stdout.startswith("error"), (proc.stdout, proc.stderr)
    assert target.read_text() == "old\n"  # untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gradebook.csv"]  # no temporary left


# ---------------------------------------------------------------- temporary files


@pytest.mark.slow
def test_a_mitsuba_reference_leaves_nothing_in_the_temporary_folder(tmp_path: Path) -> None:
    """The paper scene's meshes (~13 MB of PLY) go to a temporary folder for Mitsuba's
    loader; it must be gone when the command ends. TMPDIR makes the check private."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {**os.environ, "TMPDIR": str(tmp)}
    out = tmp_path / "ref.exr"
    proc = run(
        [
            RTVAL,
            "reference",
            str(SCENES / "paper.json"),
            "-o",
            str(out),
            "--spp",
            "1",
            "--size",
            "32x24",
        ],
        env=env,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert out.is_file() and list(tmp.iterdir()) == []


def test_ztest_refuses_nan_alpha_and_an_output_over_an_input(pair: tuple[Path, Path]) -> None:
    ref, test = pair
    proc = _rtval("ztest", str(ref), str(test), "--alpha", "nan")
    assert proc.returncode == 64 and "--alpha: expected a number between 0 and 1" in proc.stderr
    proc = _rtval("ztest", str(ref), str(test), "--json", str(ref))
    assert proc.returncode == 64 and "--json names the same file as REF" in proc.stderr


def test_rubric_that_is_a_fifo_is_refused(tmp_path: Path) -> None:
    from compare.judge.rubric import RubricError, load_rubric

    fifo = tmp_path / "r.toml"
    os.mkfifo(fifo)
    with pytest.raises(RubricError, match=f"{fifo}: is a FIFO, not a regular file"):
        load_rubric(fifo)


def _exr(path: Path, channels: dict[str, np.ndarray]) -> Path:
    with OpenEXR.File(
        {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
        {k: v.astype(np.float32) for k, v in channels.items()},
    ) as f:
        f.write(str(path))
    return path


def test_exr_with_extra_channels_is_read_and_extras_kept_apart(tmp_path: Path) -> None:
    plane = np.full((8, 8), 0.5, np.float32)
    p = _exr(
        tmp_path / "x.exr", {"R": plane, "G": plane, "B": plane, "A": plane, "diffuse.R": plane * 0}
    )
    img = read_image(p)
    assert img.rgb.shape == (8, 8, 3) and set(img.aovs) == {"A", "diffuse.R"}


def test_exr_without_rgb_names_the_missing_channels(tmp_path: Path) -> None:
    p = _exr(tmp_path / "y.exr", {"Y": np.zeros((8, 8), np.float32)})
    with pytest.raises(ImageError, match=r"y.exr: EXR has no R, G, B channel \(channels: Y\)"):
        read_image(p)
    ok = _exr(tmp_path / "ok.exr", {c: np.zeros((8, 8), np.float32) for c in "RGB"})
    proc = run([RTVAL, "compare", str(ok), str(p)])
    assert proc.returncode == 4 and "y.exr" in proc.stderr


def test_truncated_exr_is_unreadable(tmp_path: Path) -> None:
    p = tmp_path / "t.exr"
    write_exr(p, np.zeros((32, 32, 3), np.float32))
    p.write_bytes(p.read_bytes()[:200])
    proc = run([RTVAL, "compare", str(p), str(p)])
    assert proc.returncode == 4 and "t.exr" in proc.stderr


def test_unwritable_json_output_is_exit_4(tmp_path: Path) -> None:
    p = _exr(tmp_path / "ok.exr", {c: np.zeros((16, 16), np.float32) for c in "RGB"})
    proc = run(
        [RTVAL, "compare", str(p), str(p), "--json", str(tmp_path / "no" / "dir" / "r.json")]
    )
    assert proc.returncode == 4 and "r.json" in proc.stderr


def test_absurd_reference_size_is_refused_before_allocating(tmp_path: Path) -> None:
    proc = run(
        [
            RTVAL,
            "reference",
            str(SCENES / "classic.json"),
            "-o",
            str(tmp_path / "x.exr"),
            "--size",
            "16384x16384",
        ]
    )
    assert proc.returncode == 64 and "too large" in proc.stderr


def test_missing_scene_file_everywhere(tmp_path: Path, rtdemo: str) -> None:
    missing = str(tmp_path / "nope.json")
    assert run([rtdemo, "render", missing, "-o", str(tmp_path / "x.exr")]).returncode == 3
    for cmd in (
        ["export", missing, "-o", str(tmp_path / "x.xml")],
        ["reference", missing, "-o", str(tmp_path / "x.exr")],
        ["report", missing, "--reports-dir", str(tmp_path)],
    ):
        proc = run([RTVAL, *cmd])
        assert proc.returncode == 3 and "nope.json" in proc.stderr, cmd


def test_interrupted_report_leaves_no_complete_looking_files(tmp_path: Path) -> None:
    # A cache of its own, cold: after the first render line the Mitsuba renders are still
    # to come (seconds of work), so the interrupt lands inside the report, never after it
    # (with the shared warm cache the rest took milliseconds). A lost interrupt, the other
    # cause of this test's failure, is test_report_safety's.
    cache = tmp_path / "cache"
    proc = subprocess.Popen(
        [
            RTVAL,
            "report",
            str(SCENES / "classic.json"),
            "--reports-dir",
            str(tmp_path),
            "--size",
            "64x48",
            "--no-pdf",
            "--cache",
            str(cache),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    # Interrupt once the first render is done (an event, not a guess at the clock: on a loaded
    # machine a sleep could outlast the whole report).
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if line.startswith("[1/"):
            break
    else:
        pytest.fail("the report printed no render line:\n" + "".join(seen))
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    folder = tmp_path / "classic"
    assert not (folder / "index.html").exists() and not (folder / "report.json").exists()
    leftovers = [p.name for p in folder.rglob("*") if ".tmp" in p.name or ".partial" in p.name]
    assert not leftovers, leftovers
    half_made = list((cache / "tmp").glob("*"))  # renders in progress are removed
    assert not half_made, half_made


@pytest.mark.parametrize("size", ["1x1", "3x2", "31x240"])
def test_report_refuses_a_size_too_small_for_its_metrics(size: str) -> None:
    """A traceback (SSIM undefined) in the hostile-input pass; now a usage error up front."""
    proc = run([RTVAL, "report", str(SCENES / "classic.json"), "--size", size, "--no-pdf"])
    assert proc.returncode == 64 and "each side must be 32-16384" in proc.stderr, proc.stderr


def test_report_refuses_a_scene_whose_camera_is_too_small(tmp_path: Path) -> None:
    scene = json.loads((SCENES / "classic.json").read_text())
    scene["camera"].update(width=8, height=6)
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(scene))
    proc = run([RTVAL, "report", str(path), "--reports-dir", str(tmp_path), "--no-pdf"])
    assert proc.returncode == 64 and "its camera is 8x6" in proc.stderr, proc.stderr
    assert not (tmp_path / "classic").exists()
