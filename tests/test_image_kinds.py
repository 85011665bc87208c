"""A file that is not the image its name promises: the error says what the file holds, in
words, never a Python exception's name or an object's repr."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import run

from compare.judge.image_kinds import describe, identify
from compare.judge.images import ImageError, ImageKindError, read_image, write_exr

RTVAL = str(Path(sys.executable).with_name("rtval"))
P6 = b"P6\n2 1\n255\n" + bytes(6)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("name", "content", "needle"),
    [
        ("x.png", bytes(range(7, 250)), "not a PNG: the file holds binary data that begins like no image format"),
        ("x.ppm", b"hello\n", 'not a PPM: the file holds text ("hello")'),
        ("x.png", b"", "not a PNG: the file holds nothing (it is empty)"),
        ("x.exr", P6, "not an OpenEXR image: the file holds a PPM (P6); name it .ppm"),
        ("x.png", P6, "not a PNG: the file holds a PPM (P6); name it .ppm"),
        ("x.ppm", PNG_SIGNATURE + bytes(30), "not a PPM: the file holds a PNG; name it .png"),
        ("x.png", PNG_SIGNATURE + b"IHDR", "cannot read a PNG: it begins as a PNG but is damaged or cut short"),
        ("x.exr", b"\xff\xd8\xff\xe0" + bytes(20), "not an OpenEXR image: the file holds a JPEG"),
    ],
)  # fmt: skip
def test_a_file_that_is_not_its_image_says_what_it_holds(
    tmp_path: Path, name: str, content: bytes, needle: str
) -> None:
    p = tmp_path / name
    p.write_bytes(content)
    with pytest.raises(ImageError) as err:
        read_image(p)
    message = str(err.value)
    assert message == f"{p}: {needle}"
    assert "Error" not in message and "<" not in message


def test_the_kind_found_travels_with_the_error(tmp_path: Path) -> None:
    p = tmp_path / "out.exr"
    p.write_bytes(P6)
    with pytest.raises(ImageKindError) as err:
        read_image(p)
    assert err.value.found is not None and err.value.found.key == "ppm"


def test_every_netpbm_kind_is_read_under_ppm_and_named() -> None:
    assert identify(b"P3\n2 1\n255\n").key == "ppm"  # type: ignore[union-attr]
    assert describe(b"P3\n") == "a text PPM (P3)"
    assert describe(b"PF\n") == "a PFM (PF)"
    assert identify(b"P7 x") is None  # not a Netpbm kind rtval names
    assert describe(b"ab\x00\xff") == "binary data that begins like no image format"
    assert describe("très long texte ici".encode()[:16]).startswith('text ("très long te')


def test_images_whose_bytes_match_their_names_still_read(tmp_path: Path) -> None:
    ppm, exr = tmp_path / "a.ppm", tmp_path / "a.exr"
    ppm.write_bytes(P6)
    write_exr(exr, np.zeros((1, 2, 3), np.float32))
    assert read_image(ppm).shape == read_image(exr).shape == (1, 2)


def test_compare_names_a_garbage_file_in_words(tmp_path: Path) -> None:
    garbage = tmp_path / "garbage.png"
    garbage.write_bytes(bytes(range(7, 250)) * 4)
    proc = run([RTVAL, "compare", str(garbage), str(garbage)])
    assert proc.returncode == 4
    assert proc.stderr == (
        f"rtval: error: {garbage}: not a PNG: the file holds binary data that begins like no "
        "image format\n"
    )
