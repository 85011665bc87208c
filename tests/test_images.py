"""Image reading: formats, encodings and clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PILImage

from compare.judge.images import ImageError, linear_to_srgb, read_image, srgb_to_linear


def test_srgb_round_trip_and_known_value() -> None:
    v = np.linspace(0, 1, 101, dtype=np.float32)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(v)), v, atol=1e-6)
    # sRGB(0.5) = 1.055 * 0.5^(1/2.4) - 0.055 = 0.735357
    assert float(linear_to_srgb(np.float32(0.5))) == pytest.approx(0.735357, abs=1e-6)


def test_ppm_defaults_to_linear_png_to_srgb(tmp_path: Path) -> None:
    data = np.full((2, 3, 3), 128, dtype=np.uint8)
    PILImage.fromarray(data).save(tmp_path / "a.ppm")
    PILImage.fromarray(data).save(tmp_path / "a.png")
    assert read_image(tmp_path / "a.ppm").rgb[0, 0, 0] == pytest.approx(128 / 255)
    assert read_image(tmp_path / "a.png").rgb[0, 0, 0] == pytest.approx(0.2158605, abs=1e-6)
    assert read_image(tmp_path / "a.ppm", encoding="srgb").rgb[0, 0, 0] == pytest.approx(
        0.2158605, abs=1e-6
    )


def test_pfm_both_endiannesses_and_bottom_up_rows(tmp_path: Path) -> None:
    img = np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3)
    for scale, dtype in ((-1.0, "<f4"), (1.0, ">f4")):
        p = tmp_path / f"x{scale}.pfm"
        p.write_bytes(f"PF\n3 2\n{scale}\n".encode() + img[::-1].astype(dtype).tobytes())
        np.testing.assert_array_equal(read_image(p).rgb, img)


@pytest.mark.parametrize(
    "name,content,needle",
    [
        ("t.pfm", b"PF\n3 2\n-1.0\n" + b"\0" * 10, "truncated"),
        ("t.exr", b"not an exr", "not an OpenEXR image"),
        ("t.png", b"\x89PNG\r\n\x1a\n garbage", "cannot read a PNG"),
        ("t.ppm", b"P6\n4 4\n255\n\x01\x02", "cannot read a PPM"),
        ("t.tga", b"x", "unsupported image type"),
    ],
)
def test_corrupt_files_raise_image_error_naming_the_file(
    tmp_path: Path, name: str, content: bytes, needle: str
) -> None:
    p = tmp_path / name
    p.write_bytes(content)
    with pytest.raises(ImageError, match=needle) as err:
        read_image(p)
    assert str(p) in str(err.value)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ImageError, match="no such file"):
        read_image(tmp_path / "none.exr")
