"""`rtdemo render -o NAME` writes the format NAME says, or refuses before rendering: an EXR
named x.png would be read as a broken PNG by whoever opens it next."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import SCENES, run

SMALL = ["--width", "8", "--height", "6", "-q"]
MAGIC = {"exr": b"\x76\x2f\x31\x01", "png": b"\x89PNG\r\n\x1a\n", "ppm": b"P6"}


@pytest.mark.parametrize(
    ("name", "kind"),
    [("x.png", "png"), ("x.PNG", "png"), ("x.ppm", "ppm"), ("x.pnm", "ppm"), ("x.exr", "exr"),
     ("x", "exr")],
)  # fmt: skip
def test_output_is_written_in_the_format_its_name_says(
    rtdemo: str, tmp_path: Path, name: str, kind: str
) -> None:
    out = tmp_path / name
    proc = run([rtdemo, "render", str(SCENES / "classic.json"), "-o", str(out), *SMALL])
    assert proc.returncode == 0, proc.stderr
    assert out.read_bytes().startswith(MAGIC[kind])
    assert [p.name for p in tmp_path.iterdir()] == [name]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["-o", "{dir}/x.jpg"], "-o {dir}/x.jpg: rtdemo writes EXR (.exr), PNG (.png) or PPM"),
        (["-o", "{dir}/x.txt"], "name the output with one of these suffixes"),
        (["-o", "{dir}/x.png", "--png", "{dir}/y.png"], "both ask for a PNG; give one"),
        (["--png", "{dir}/x.exr"], "--png {dir}/x.exr: writes a PNG but the name says EXR"),
    ],
)
def test_output_named_for_another_format_is_refused_before_rendering(
    rtdemo: str, tmp_path: Path, args: list[str], needle: str
) -> None:
    argv = [a.format(dir=tmp_path) for a in args]
    proc = run([rtdemo, "render", str(SCENES / "classic.json"), *argv, *SMALL])
    assert proc.returncode == 2, proc.stderr
    assert needle.format(dir=tmp_path) in proc.stderr
    assert list(tmp_path.iterdir()) == []
