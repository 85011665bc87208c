"""The one PNG encoder for the pictures rtval shows people (report, grade, check --html,
stress, diagnosis evidence).

Display values (already sRGB-encoded, nominally [0, 1]) become 8-bit codes: clamped, then
rounded. A pixel with a non-finite value in any channel (NaN, +Inf or -Inf) is painted the
fixed MARKER colour, never a plausible black or white, so a page shows where an image is
broken. Linear renders go through display_values(), which keeps that mark (linear_to_srgb,
used for metrics, turns NaN into 0).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from compare.judge.arrays import F32
from compare.judge.images import linear_to_srgb
from safe_files.paths import write_atomic

MARKER = (255, 0, 255)  # magenta: no render produces it by accident on a broken pixel
FAST = 1  # zlib level for pages written per student (bench/bench_grade.py); PIL's default is 6
DEFAULT = 6


def display_values(rgb_linear: F32) -> F32:
    """The sRGB display values of a linear image, NaN where the input is not finite."""
    out = linear_to_srgb(rgb_linear)
    return np.where(np.isfinite(rgb_linear), out, np.float32(np.nan)).astype(np.float32)


def encode_png(display: np.ndarray, *, compress_level: int = DEFAULT) -> bytes:
    """The PNG bytes of an H x W x 3 image of display values (see the module's rules)."""
    values = np.asarray(display)  # float32 stays float32: the codes of every earlier page
    if not np.issubdtype(values.dtype, np.floating):
        values = values.astype(np.float32)
    if values.ndim != 3 or values.shape[2] != 3:
        raise ValueError(f"expected an H x W x 3 image, got shape {values.shape}")
    bad = ~np.isfinite(values).all(axis=-1)
    codes = np.round(np.clip(np.nan_to_num(values), 0.0, 1.0) * 255.0).astype(np.uint8)
    codes[bad] = MARKER
    from PIL import Image as PILImage

    buf = io.BytesIO()
    PILImage.fromarray(codes, "RGB").save(buf, format="PNG", compress_level=compress_level)
    return buf.getvalue()


def write_display_png(
    path: str | Path, display: np.ndarray, *, compress_level: int = DEFAULT
) -> None:
    """encode_png(...) written atomically (only a regular file is ever replaced)."""
    write_atomic(path, encode_png(display, compress_level=compress_level))


def write_linear_png(path: str | Path, rgb_linear: F32, *, compress_level: int = DEFAULT) -> None:
    """A linear render as its sRGB display PNG, written atomically."""
    write_display_png(path, display_values(rgb_linear), compress_level=compress_level)


def write_png(path: str | Path, rgb_linear: F32) -> None:
    """Write a linear render as an 8-bit sRGB PNG for people to look at.

    Each channel is clamped to [0, 1], sRGB-encoded and rounded to 8 bits; a pixel with a
    NaN or infinity in any channel is painted MARKER (magenta), never a plausible black or
    white. Written atomically: no partial file ever remains.

    Parameters
    ----------
    path : str or Path
        The file to write; only a regular file (or nothing) is replaced.
    rgb_linear : F32
        Linear RGB, H x W x 3.

    Returns
    -------
    None

    Raises
    ------
    ValueError
        `rgb_linear` is not H x W x 3.
    OSError
        The file cannot be written; UnsafePathError (an OSError) when `path` is a link, a
        folder or anything but a regular file.
    """
    write_linear_png(path, rgb_linear)
