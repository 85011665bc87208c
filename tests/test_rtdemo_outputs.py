"""rtdemo against hostile paths: outputs only ever replace regular files (exit 4), an output
equal to the scene or to another output is refused (exit 2), a full disk leaves no partial
file (exit 4), a FIFO or /dev/zero as the scene is refused at once (exit 3), a frame that does
not fit in memory is one line and exit 1."""

from __future__ import annotations

import os
import resource
import shutil
import signal
import stat
from pathlib import Path

import pytest
from helpers import SCENES, run

SMALL = ["--width", "8", "--height", "6", "-q"]


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    p = tmp_path / "scene.json"
    shutil.copyfile(SCENES / "classic.json", p)
    return p


@pytest.mark.parametrize("kind", ["fifo", "link_to_dev_full"])
def test_output_that_is_not_a_regular_file_is_refused(
    rtdemo: str, scene: Path, tmp_path: Path, kind: str
) -> None:
    """A FIFO stands for a device (renaming over /dev/full as root made it a file)."""
    out = tmp_path / "out.exr"
    if kind == "fifo":
        os.mkfifo(out)
    else:
        os.symlink("/dev/full", out)
    proc = run([rtdemo, "render", str(scene), "-o", str(out), *SMALL], timeout=60)
    assert proc.returncode == 4, proc.stderr
    assert (
        f"{out}: is a" in proc.stderr and "outputs only ever replace regular files" in proc.stderr
    )
    mode = os.lstat(out).st_mode
    assert stat.S_ISFIFO(mode) if kind == "fifo" else stat.S_ISLNK(mode)
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.exr", "scene.json"]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["-o", "{scene}"], "-o names the scene file"),
        (["--ppm", "{scene}"], "--ppm names the scene file"),
        (["-o", "{dir}/x.exr", "--ppm", "{dir}/./x.exr"], "--ppm and -o name the same file"),
        (["-o", "{dir}/x.exr", "--png", "{dir}/x.exr"], "--png and -o name the same file"),
    ],
)
def test_output_equal_to_an_input_or_another_output_is_refused(
    rtdemo: str, scene: Path, tmp_path: Path, args: list[str], needle: str
) -> None:
    before = scene.read_bytes()
    argv = [a.format(scene=scene, dir=tmp_path) for a in args]
    proc = run([rtdemo, "render", str(scene), *argv, *SMALL], timeout=60)
    assert proc.returncode == 2 and needle in proc.stderr, proc.stderr
    assert scene.read_bytes() == before
    assert not (tmp_path / "x.exr").exists()


def _limit_file_size() -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes past the limit fail (EFBIG)
    resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))


@pytest.mark.parametrize("option", ["-o", "--ppm"])
def test_full_disk_leaves_no_partial_file(
    rtdemo: str, scene: Path, tmp_path: Path, option: str
) -> None:
    out = tmp_path / "out" / "img"
    out.parent.mkdir()
    extra = ["--exr-compression", "none"] if option == "-o" else []
    proc = run(
        [
            rtdemo,
            "render",
            str(scene),
            option,
            str(out),
            "--width",
            "320",
            "--height",
            "240",
            "-q",
            *extra,
        ],
        preexec_fn=_limit_file_size,
        timeout=120,
    )
    assert proc.returncode == 4 and str(out) in proc.stderr, proc.stderr
    assert list(out.parent.iterdir()) == []


def _limit_address_space() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (256 << 20, 256 << 20))


@pytest.mark.parametrize(
    "outputs",
    [
        ["-o", "{dir}/x.exr", "--keep-frame"],
        ["-o", "{dir}/x.exr", "--exr-compression", "zip"],
        ["--png", "{dir}/x.png"],
        ["--ppm", "{dir}/x.ppm", "--frames", "2"],
    ],
)
def test_out_of_memory_is_one_line_and_exit_1(
    rtdemo: str, scene: Path, tmp_path: Path, outputs: list[str]
) -> None:
    """A kept 8192x8192 frame needs ~2 GiB; under a 256 MiB address space its allocation
    fails before any tracing: a message naming the size and the ways out, no output file."""
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    argv = [a.format(dir=out_dir) for a in outputs]
    size = ["--width", "8192", "--height", "8192", "--threads", "2"]
    proc = run(
        [rtdemo, "render", str(scene), *argv, *size],
        preexec_fn=_limit_address_space,
        timeout=120,
    )
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.startswith(
        "rtdemo: error: out of memory for an image of 8192x8192 pixels: "
    ), proc.stderr
    assert "smaller --width/--height or one streamed output" in proc.stderr
    assert proc.stderr.count("\n") == 1
    assert list(out_dir.iterdir()) == []


@pytest.mark.parametrize("kind", ["fifo", "dev_zero"])
def test_scene_that_is_not_a_regular_file_is_refused(
    rtdemo: str, tmp_path: Path, kind: str
) -> None:
    path = tmp_path / "scene.json"
    if kind == "fifo":
        os.mkfifo(path)
        what = "a FIFO"
    else:
        os.symlink("/dev/zero", path)
        what = "a character device"
    proc = run([rtdemo, "render", str(path), "-o", str(tmp_path / "x.exr"), *SMALL], timeout=30)
    assert proc.returncode == 3
    assert f"cannot read the scene file: {path}: is {what}, not a regular file" in proc.stderr
