"""Images are decoded only as the format their name says: a TIFF named .ppm is not read by
compare/judge/images.py, and a program's output of another format than --output-format
names is a reason (compare/judge/image_kinds.py), never handed to a decoder chosen by its
bytes (an EPS would reach Ghostscript)."""

from __future__ import annotations

from pathlib import Path

import pytest
from PIL import Image

from compare.judge.image_kinds import output_problem
from compare.judge.images import ImageError, read_image


def test_a_tiff_named_ppm_is_not_decoded(tmp_path: Path) -> None:
    Image.new("RGB", (4, 4)).save(tmp_path / "a.ppm", format="TIFF")
    with pytest.raises(ImageError, match="not a PPM: the file holds a TIFF"):
        read_image(tmp_path / "a.ppm")
    Image.new("RGB", (4, 4)).save(tmp_path / "b.ppm", format="PPM")
    assert read_image(tmp_path / "b.ppm").rgb.shape == (4, 4, 3)


@pytest.mark.parametrize(
    ("data", "name", "problem"),
    [
        (b"P6\n1 1\n255\n\0\0\0", "classic.ppm", ""),
        (
            b"%!PS-Adobe-3.0 EPSF-3.0\n",
            "classic.ppm",
            "output is not a PPM: classic.ppm holds text",
        ),
        (b"BM6\0\0\0", "classic.png", "output is not a PNG: classic.png holds binary data"),
        (b"\x89PNG\r\n\x1a\n", "classic.png", ""),
        (b"PF\n1 1\n-1\n", "classic.pfm", ""),
        (b"v/1\x01", "classic.exr", ""),
        (b"II*\0", "classic.exr", "output is not an OpenEXR image: classic.exr holds a TIFF"),
    ],
)
def test_program_outputs_must_be_of_their_named_format(
    data: bytes, name: str, problem: str
) -> None:
    got = output_problem(data, name)
    assert got.startswith(problem) and bool(got) == bool(problem)
