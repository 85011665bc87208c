"""Reading the images the judge compares: EXR, PNG, PPM and PFM, as linear float32 RGB.

8-bit inputs carry an encoding: PNG defaults to sRGB, PPM to linear (the paper writes
linear values straight to 8 bits). EXR AOV channels (id, depth, N.*) are kept when present.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

F32 = NDArray[np.float32]


class ImageError(ValueError):
    """An unreadable or malformed image; the message names the file."""


@dataclass
class Image:
    rgb: F32  # H x W x 3, linear
    path: str = ""
    aovs: dict[str, F32] = field(default_factory=dict)  # H x W each
    header: dict[str, str] = field(default_factory=dict)
    encoding: str = "linear"  # how 8-bit data was decoded; "float" for EXR/PFM

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.rgb.shape[0]), int(self.rgb.shape[1])


def srgb_to_linear(v: F32) -> F32:
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(v: F32) -> F32:
    """Display encoding: clamp to [0, 1] (NaN -> 0), then the sRGB curve."""
    c = np.clip(np.nan_to_num(v, nan=0.0), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055).astype(np.float32)


def _read_exr(path: Path) -> Image:
    import OpenEXR

    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            header = {k: v for k, v in f.header().items() if isinstance(v, str)}
            channels = {name: np.asarray(c.pixels) for name, c in f.channels().items()}
    except Exception as e:  # the binding raises bare RuntimeError / OSError
        raise ImageError(f"{path}: cannot read EXR: {e}") from None
    missing = [c for c in "RGB" if c not in channels]
    if missing:
        raise ImageError(
            f"{path}: EXR has no {', '.join(missing)} channel "
            f"(channels: {', '.join(sorted(channels)) or 'none'})"
        )
    rgb = np.stack([channels[c].astype(np.float32) for c in "RGB"], axis=-1)
    aovs = {k: v.astype(np.float32) for k, v in channels.items() if k not in ("R", "G", "B")}
    return Image(rgb=rgb, path=str(path), aovs=aovs, header=header, encoding="float")


def _read_8bit(path: Path, encoding: str) -> Image:
    import warnings

    from PIL import Image as PILImage

    try:
        with warnings.catch_warnings():
            warnings.simplefilter(
                "error", PILImage.DecompressionBombWarning
            )  # refuse, never allocate
            im = PILImage.open(path)
        with im:
            im.load()
            if im.mode not in ("RGB", "RGBA", "L"):
                raise ImageError(f"{path}: unsupported pixel mode {im.mode} (expected 8-bit RGB)")
            data = np.asarray(im.convert("RGB"), dtype=np.float32) / 255.0
    except ImageError:
        raise
    except (
        Exception
    ) as e:  # Pillow raises OSError, ValueError, SyntaxError, DecompressionBombError ...
        raise ImageError(f"{path}: cannot read image: {type(e).__name__}: {e}") from None
    rgb = srgb_to_linear(data) if encoding == "srgb" else data
    return Image(rgb=rgb.astype(np.float32), path=str(path), encoding=encoding)


def _read_pfm(path: Path) -> Image:
    """Portable float map: 'PF' (RGB) or 'Pf' (grey), size, scale (< 0: little-endian),
    then float32 rows bottom to top."""
    raw = path.read_bytes()
    tokens: list[bytes] = []
    pos = 0
    while len(tokens) < 4:
        while pos < len(raw) and raw[pos : pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(raw) and not raw[pos : pos + 1].isspace():
            pos += 1
        if start == pos:
            raise ImageError(f"{path}: truncated PFM header")
        tokens.append(raw[start:pos])
    pos += 1  # the single whitespace byte that ends the header
    try:
        kind, w, h, scale = tokens[0], int(tokens[1]), int(tokens[2]), float(tokens[3])
    except ValueError:
        raise ImageError(f"{path}: malformed PFM header {b' '.join(tokens)!r}") from None
    if kind not in (b"PF", b"Pf") or w <= 0 or h <= 0 or scale == 0:
        raise ImageError(f"{path}: not a PFM file (expected PF or Pf, a positive size, scale != 0)")
    c = 3 if kind == b"PF" else 1
    need = w * h * c * 4
    if len(raw) - pos < need:
        raise ImageError(
            f"{path}: truncated PFM: {len(raw) - pos} bytes of pixels, expected {need}"
        )
    px = np.frombuffer(raw[pos : pos + need], dtype="<f4" if scale < 0 else ">f4")
    px = px.reshape(h, w, c)[::-1]
    rgb = np.repeat(px, 3, axis=2) if c == 1 else px
    return Image(rgb=rgb.astype(np.float32), path=str(path), encoding="float")


def read_image(path: str | Path, *, encoding: str | None = None) -> Image:
    """Reads an image as linear float32 RGB.

    ``encoding`` ("srgb" or "linear") applies to 8-bit files only; by default PNG is sRGB
    and PPM linear. Raises ImageError naming the file on anything unreadable.
    """
    p = Path(path)
    if encoding not in (None, "srgb", "linear"):
        raise ValueError(f"encoding must be 'srgb' or 'linear', got {encoding!r}")
    if not p.is_file():
        raise ImageError(f"{p}: no such file")
    suffix = p.suffix.lower()
    if suffix == ".exr":
        return _read_exr(p)
    if suffix == ".pfm":
        return _read_pfm(p)
    if suffix == ".png":
        return _read_8bit(p, encoding or "srgb")
    if suffix in (".ppm", ".pnm"):
        return _read_8bit(p, encoding or "linear")
    raise ImageError(f"{p}: unsupported image type '{suffix}' (expected .exr, .png, .ppm, .pfm)")


def write_png(path: str | Path, rgb_linear: F32) -> None:
    """Clamped, sRGB-encoded 8-bit PNG, written atomically."""
    from PIL import Image as PILImage

    p = Path(path)
    data = np.round(linear_to_srgb(rgb_linear) * 255.0).astype(np.uint8)
    tmp = p.with_name(p.name + ".tmp")
    PILImage.fromarray(data, "RGB").save(tmp, format="PNG")
    tmp.replace(p)


def write_exr(
    path: str | Path,
    rgb: F32,
    *,
    aovs: dict[str, F32] | None = None,
    header: dict[str, str] | None = None,
) -> None:
    """Float32 EXR with R, G, B and optional AOV channels, written atomically."""
    import OpenEXR

    p = Path(path)
    channels: dict[str, np.ndarray] = {
        c: np.ascontiguousarray(rgb[..., i], dtype=np.float32) for i, c in enumerate("RGB")
    }
    for name, data in (aovs or {}).items():
        channels[name] = np.ascontiguousarray(data, dtype=np.float32)
    hdr: dict[str, object] = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    hdr.update(header or {})
    tmp = p.with_name(p.name + ".tmp")
    try:
        with OpenEXR.File(hdr, channels) as f:
            f.write(str(tmp))
        tmp.replace(p)
    finally:
        if tmp.exists():
            tmp.unlink()
