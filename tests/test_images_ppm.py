"""PPMs whose maxval is not 255 are read as their codes / maxval: Pillow rounds 16-bit
samples to 8 bits, and a 16-bit PPM from a correct program must be judged on what it holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from compare.judge.images import ImageError, read_image


def _ppm(path: Path, codes: np.ndarray, maxval: int, magic: bytes = b"P6") -> Path:
    h, w = codes.shape[:2]
    dtype = ">u2" if maxval > 255 else "u1"
    path.write_bytes(magic + f"\n{w} {h}\n{maxval}\n".encode() + codes.astype(dtype).tobytes())
    return path


@pytest.mark.parametrize("maxval", [65535, 1023, 15])
def test_samples_are_codes_over_maxval(tmp_path: Path, maxval: int) -> None:
    rng = np.random.default_rng(maxval)
    codes = rng.integers(0, maxval + 1, size=(5, 7, 3))
    img = read_image(_ppm(tmp_path / "a.ppm", codes, maxval))
    np.testing.assert_array_equal(img.rgb, (codes / np.float32(maxval)).astype(np.float32))
    assert img.encoding == "linear"  # as for every PPM: the paper's program writes linear codes


def test_16_bit_grey_is_spread_over_rgb(tmp_path: Path) -> None:
    codes = np.array([[[0], [32768], [65535]]])
    img = read_image(_ppm(tmp_path / "g.ppm", codes, 65535, b"P5"))
    assert img.rgb.shape == (1, 3, 3)
    np.testing.assert_array_equal(img.rgb[0, 1], np.float32(32768 / 65535))


def test_a_truncated_16_bit_ppm_is_an_image_error(tmp_path: Path) -> None:
    p = _ppm(tmp_path / "t.ppm", np.zeros((4, 4, 3)), 65535)
    p.write_bytes(p.read_bytes()[:-10])
    with pytest.raises(ImageError, match=r"t\.ppm"):
        read_image(p)
