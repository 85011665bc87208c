"""Bad input everywhere: one clear message, the documented exit code, no partial files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from helpers import SCENES, run

from compare.judge.images import ImageError, read_image, write_exr

RTVAL = str(Path(sys.executable).with_name("rtval"))


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
