"""Reading the images the judge compares: EXR, PNG, PPM and PFM, as linear float32 RGB.

8-bit inputs carry an encoding: PNG defaults to sRGB, PPM to linear (the paper writes
linear values straight to 8 bits). EXR AOV channels (id, depth, N.*) are kept when present.
"""

from __future__ import annotations

import math
import os
import re
import stat
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from compare.judge import exr_scanlines, image_kinds
from compare.judge.arrays import F32
from safe_files.paths import UnsafePathError, atomic_output, check_regular_input


class ImageError(ValueError):
    """An unreadable or malformed image; the message names the file.

    Parameters
    ----------
    message : str
        What is wrong, naming the file.
    """


@dataclass
class Image:
    """An image as the judge reads it: linear float32 RGB, with an EXR's other channels.

    Attributes
    ----------
    rgb : F32
        Linear RGB, float32 H x W x 3.
    path : str
        The file it was read from; default "".
    aovs : dict[str, F32]
        The EXR's other channels (id, depth, N.X/Y/Z, ...) by name, float32 H x W each;
        default empty.
    header : dict[str, str]
        The EXR header's string attributes; default empty.
    encoding : str
        How 8-bit (PNG, PPM) data was decoded to linear: "linear" (default) or "srgb";
        "float" for EXR and PFM.
    shape : tuple[int, int]
        (height, width), read-only.
    """

    rgb: F32
    path: str = ""
    aovs: dict[str, F32] = field(default_factory=dict)
    header: dict[str, str] = field(default_factory=dict)
    encoding: str = "linear"

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.rgb.shape[0]), int(self.rgb.shape[1])


def srgb_to_linear(v: F32) -> F32:
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(v: F32) -> F32:
    """Display encoding: clamp to [0, 1] (NaN -> 0), then the sRGB curve."""
    c = np.clip(np.nan_to_num(v, nan=0.0), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055).astype(np.float32)


# The judge keeps a few float maps per pixel: refuse sizes beyond the scene format's
# largest image (16384 x 16384) before decoding anything.
MAX_PIXELS = 16384 * 16384
_PFM_HEADER_MAX = 256  # "PF\n<w> <h>\n<scale>\n" is far shorter


class ImageKindError(ImageError):
    """A file whose first bytes are not the image its suffix promises: another format
    (`found`, a Kind) or none (`found` None); the message says what it holds (`holds`, in
    words)."""

    def __init__(self, message: str, found: image_kinds.Kind | None, holds: str) -> None:
        super().__init__(message)
        self.found = found
        self.holds = holds


class ImageSizeError(ImageError):
    """An image whose declared size is not the one required (found in the header)."""

    def __init__(self, message: str, size: tuple[int, int], expected: tuple[int, int]) -> None:
        super().__init__(message)
        self.size = size  # (height, width) declared by the file
        self.expected = expected


def _open_regular(path: Path) -> BinaryIO:
    """Opens a regular file for reading, never blocking on a FIFO and never reading a
    device (a symlink to /dev/zero included)."""
    try:
        check_regular_input(path)
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise ImageError(str(e) if isinstance(e, UnsafePathError) else f"{path}: {e}") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):  # swapped after the check
        os.close(fd)
        raise ImageError(f"{path}: not a regular file")
    return os.fdopen(fd, "rb")


def _check_kind(path: Path) -> None:
    """Refuses a file whose first bytes announce another format than its suffix (a PNG named
    out.ppm would be decoded with the PPM's encoding), or, for an EXR, no format at all; the
    message says what the file holds."""
    key = path.suffix.lower().lstrip(".")
    with _open_regular(path) as f:
        head = f.read(image_kinds.HEAD_BYTES)
    found = image_kinds.identify(head)
    if found is not None and image_kinds.same_family(key, found):
        return
    if found is None and key != "exr":  # the decoder names what it could not read
        return
    hint = f"; name it .{found.key}" if found is not None and found.key else ""
    holds = image_kinds.describe(head)
    raise ImageKindError(
        f"{path}: not {image_kinds.EXPECTED[key]}: the file holds {holds}{hint}", found, holds
    )


def _unreadable(path: Path, e: Exception) -> ImageError:
    """Pillow's failure in words: what the file holds when Pillow could not tell what it is,
    else Pillow's own reason without the Python objects it quotes."""
    kind = image_kinds.EXPECTED.get(path.suffix.lower().lstrip("."), "an image")
    text = re.sub(r"\s*<[^<>]*>", "", str(e)).strip().rstrip(".")
    if text.startswith("cannot identify image file") or not text:
        with _open_regular(path) as f:
            head = f.read(image_kinds.HEAD_BYTES)
        found = image_kinds.identify(head)
        if found is None or not image_kinds.same_family(path.suffix.lower()[1:], found):
            holds = image_kinds.describe(head)
            return ImageKindError(f"{path}: not {kind}: the file holds {holds}", found, holds)
        text = f"it begins as {found.words} but is damaged or cut short"
    return ImageError(f"{path}: cannot read {kind}: {text}")


def _exr_size(path: Path) -> tuple[int, int]:
    import OpenEXR

    try:
        with OpenEXR.File(str(path), header_only=True) as f:
            lo, hi = f.header()["dataWindow"]
    except Exception as e:  # the binding raises bare RuntimeError / OSError
        raise ImageError(f"{path}: cannot read EXR: {e}") from None
    return int(hi[1]) - int(lo[1]) + 1, int(hi[0]) - int(lo[0]) + 1


def _pil_formats(path: Path) -> list[str]:
    """The one decoder a file's name allows: never one chosen by its bytes (a TIFF named
    .ppm is not read; an EPS would run Ghostscript)."""
    return {".png": ["PNG"], ".ppm": ["PPM"]}.get(path.suffix.lower(), ["PNG", "PPM"])


def _pil_size(path: Path) -> tuple[int, int]:
    from PIL import Image as PILImage

    with _open_regular(path) as f:
        try:
            with PILImage.open(f, formats=_pil_formats(path)) as im:  # the header only
                w, h = im.size
        except Exception as e:
            raise _unreadable(path, e) from None
    return int(h), int(w)


def _pfm_header(path: Path, head: bytes) -> tuple[int, int, int, float, int]:
    """(width, height, channels, scale, offset of the pixels) from the first bytes."""
    tokens: list[bytes] = []
    pos = 0
    while len(tokens) < 4:
        while pos < len(head) and head[pos : pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(head) and not head[pos : pos + 1].isspace():
            pos += 1
        if start == pos or pos >= len(head):
            raise ImageError(f"{path}: truncated or malformed PFM header")
        tokens.append(head[start:pos])
    pos += 1  # the single whitespace byte that ends the header
    try:
        kind, w, h, scale = tokens[0], int(tokens[1]), int(tokens[2]), float(tokens[3])
    except ValueError:
        raise ImageError(f"{path}: malformed PFM header {b' '.join(tokens)!r}") from None
    if kind not in (b"PF", b"Pf") or w <= 0 or h <= 0:
        raise ImageError(f"{path}: not a PFM file (expected PF or Pf and a positive size)")
    if not math.isfinite(scale) or scale == 0:
        raise ImageError(f"{path}: PFM scale: expected a finite number != 0, got {tokens[3]!r}")
    return w, h, 3 if kind == b"PF" else 1, scale, pos


def image_size(path: str | Path) -> tuple[int, int]:
    """(height, width) from the file's header, without decoding its pixels."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".exr", ".pfm", ".png", ".ppm", ".pnm"):
        _check_kind(p)  # also the type check: the EXR binding opens by name
    if suffix == ".exr":
        return _exr_size(p)
    if suffix == ".pfm":
        with _open_regular(p) as f:
            w, h, *_ = _pfm_header(p, f.read(_PFM_HEADER_MAX))
        return h, w
    if suffix in (".png", ".ppm", ".pnm"):
        return _pil_size(p)
    raise ImageError(f"{p}: unsupported image type '{suffix}' (expected .exr, .png, .ppm, .pfm)")


def _check_size(path: Path, size: tuple[int, int], expected: tuple[int, int] | None) -> None:
    h, w = size
    if expected is not None and size != expected:
        raise ImageSizeError(
            f"{path}: wrong size {w}x{h}, expected {expected[1]}x{expected[0]}", size, expected
        )
    if h <= 0 or w <= 0 or h * w > MAX_PIXELS:
        raise ImageError(f"{path}: declares {w}x{h} pixels; at most {MAX_PIXELS} are read")


def _read_exr(path: Path) -> Image:
    import OpenEXR

    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            # rtval.padding: the spaces rtdemo's streamed EXR keeps its header's size with,
            # no information, so not carried into EXRs written from this image.
            header = {
                k: v for k, v in f.header().items() if isinstance(v, str) and k != "rtval.padding"
            }
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


def _read_exr_scanlines(
    path: Path, expected_size: tuple[int, int] | None, keep: Collection[str] | None
) -> Image | None:
    """The image with the AOVs in `keep` (None: every one), when the file is the plain
    layout exr_scanlines reads (its size checked before its pixels are read); None: OpenEXR
    reads it."""
    _check_kind(path)
    with _open_regular(path) as f:
        layout = exr_scanlines.read_layout(f)
        if layout is None or not {"R", "G", "B"} <= set(layout.channels):
            return None
        _check_size(path, (layout.height, layout.width), expected_size)
        if os.fstat(f.fileno()).st_size != exr_scanlines.file_size(layout):
            return None
        f.seek(0)
        found = exr_scanlines.parse(layout, f.read())
    if found is None:
        return None
    aovs = {
        k: found.channel(k)
        for k in found.names
        if k not in ("R", "G", "B") and (keep is None or k in keep)
    }
    # In OpenEXR's order (by name), as _read_exr gives them.
    header = {k: v for k, v in sorted(found.strings.items()) if k != "rtval.padding"}
    return Image(found.rgb(), str(path), aovs, header, "float")


def _read_8bit(path: Path, encoding: str) -> Image:
    import warnings

    from PIL import Image as PILImage

    try:
        with warnings.catch_warnings(), _open_regular(path) as f:
            warnings.simplefilter(
                "error", PILImage.DecompressionBombWarning
            )  # refuse, never allocate
            with PILImage.open(f, formats=_pil_formats(path)) as im:
                data = _ppm_exact(path, f, im)  # before load(), which forgets the layout
                if data is None:
                    im.load()
                    if im.mode not in ("RGB", "RGBA", "L"):
                        raise ImageError(
                            f"{path}: unsupported pixel mode {im.mode} (expected 8-bit RGB)"
                        )
                    data = np.asarray(im.convert("RGB"), dtype=np.float32) / 255.0
    except ImageError:
        raise
    except (
        Exception
    ) as e:  # Pillow raises OSError, ValueError, SyntaxError, DecompressionBombError ...
        raise _unreadable(path, e) from None
    rgb = srgb_to_linear(data) if encoding == "srgb" else data
    return Image(rgb=rgb.astype(np.float32), path=str(path), encoding=encoding)


def _ppm_exact(path: Path, f: BinaryIO, im: Any) -> F32 | None:
    """A binary PPM/PGM whose maxval is not 255, read as its codes / maxval (Pillow rounds
    16-bit colour samples to 8 bits); None for every other image."""
    if im.format != "PPM" or len(im.tile) != 1:
        return None
    f.seek(0)
    head = f.read(im.tile[0].offset)
    words = b" ".join(line.split(b"#")[0] for line in head.splitlines()).split()
    if len(words) != 4 or words[0] not in (b"P5", b"P6") or int(words[3]) == 255:
        return None
    maxval, channels = int(words[3]), 3 if words[0] == b"P6" else 1
    w, h = im.size
    dtype = np.dtype(">u2" if maxval > 255 else "u1")
    need = w * h * channels * dtype.itemsize
    raw = f.read(need)
    if len(raw) < need:
        raise ImageError(f"{path}: truncated PPM: {len(raw)} bytes of pixels, expected {need}")
    codes = np.frombuffer(raw, dtype=dtype).reshape(h, w, channels).astype(np.float32)
    data = np.minimum(codes / np.float32(maxval), np.float32(1.0))  # codes above maxval: 1
    return np.repeat(data, 3, axis=2) if channels == 1 else data


def _read_pfm(path: Path) -> Image:
    """Portable float map: 'PF' (RGB) or 'Pf' (grey), size, scale (< 0: little-endian),
    then float32 rows bottom to top. Reads the header first and only the pixels it declares."""
    with _open_regular(path) as f:
        head = f.read(_PFM_HEADER_MAX)
        w, h, c, scale, pos = _pfm_header(path, head)
        _check_size(path, (h, w), None)
        need = w * h * c * 4
        f.seek(pos)
        raw = f.read(need)
    if len(raw) < need:
        raise ImageError(f"{path}: truncated PFM: {len(raw)} bytes of pixels, expected {need}")
    px = np.frombuffer(raw, dtype="<f4" if scale < 0 else ">f4")
    px = px.reshape(h, w, c)[::-1]
    rgb = np.repeat(px, 3, axis=2) if c == 1 else px
    return Image(rgb=rgb.astype(np.float32), path=str(path), encoding="float")


def read_image(
    path: str | Path,
    *,
    encoding: str | None = None,
    expected_size: tuple[int, int] | None = None,
    aovs: Collection[str] | None = None,
) -> Image:
    """Read an EXR, PFM, PNG or PPM/PNM image as linear float32 RGB.

    Only a regular file is read (never a FIFO or a device). A wrong or huge declared size is
    refused from the header, before any pixel is decoded: a small file costs no memory.

    Parameters
    ----------
    path : str or Path
        The image; its suffix (.exr, .pfm, .png, .ppm, .pnm, any case) picks the reader.
    encoding : {"srgb", "linear"} or None, optional
        How PNG/PPM codes decode to linear (EXR, PFM ignore it); None: PNG sRGB, PPM linear.
    expected_size : tuple[int, int] or None, optional
        The (height, width) the file must declare; default None: any size.
    aovs : Collection[str] or None, optional
        EXR channels besides R, G, B to keep (a search copies only what it uses); None: all.

    Returns
    -------
    Image

    Raises
    ------
    ValueError
        `encoding` is not None, "srgb" or "linear".
    ImageSizeError
        The declared size differs from `expected_size` (an ImageError).
    ImageError
        An unsupported suffix, a non-regular file, more than MAX_PIXELS, anything unreadable
        or malformed (no R, G or B channel, truncated pixels); the message names the file.
    """
    p = Path(path)
    if encoding not in (None, "srgb", "linear"):
        raise ValueError(f"encoding must be 'srgb' or 'linear', got {encoding!r}")
    suffix = p.suffix.lower()
    if suffix not in (".exr", ".pfm", ".png", ".ppm", ".pnm"):
        raise ImageError(
            f"{p}: unsupported image type '{suffix}' (expected .exr, .png, .ppm, .pfm)"
        )
    if suffix == ".exr":
        fast = _read_exr_scanlines(p, expected_size, aovs)
        if fast is not None:
            return fast
    _check_size(p, image_size(p), expected_size)
    if suffix == ".exr":
        image = _read_exr(p)
        if aovs is not None:
            image.aovs = {k: v for k, v in image.aovs.items() if k in aovs}
        return image
    if suffix == ".pfm":
        return _read_pfm(p)
    if suffix == ".png":
        return _read_8bit(p, encoding or "srgb")
    return _read_8bit(p, encoding or "linear")


def write_exr(
    path: str | Path,
    rgb: F32,
    *,
    aovs: dict[str, F32] | None = None,
    header: dict[str, str] | None = None,
) -> None:
    """Write a float32 EXR (ZIP-compressed scanlines) with R, G, B and optional AOVs.

    Written atomically: to a temporary sibling, then renamed over `path`, so no partial
    file ever remains.

    Parameters
    ----------
    path : str or Path
        The file to write; only a regular file (or nothing) is replaced.
    rgb : F32
        The R, G, B channels, H x W x 3, written as float32 (linear, as read_image reads).
    aovs : dict[str, F32] or None, optional
        Further channels by name, H x W each, written as float32; default None: none.
    header : dict[str, str] or None, optional
        Header attributes to add, overriding compression and type; default None.

    Returns
    -------
    None

    Raises
    ------
    OSError
        The file cannot be written (a full disk included); UnsafePathError (an OSError)
        when `path` is a link, a folder or anything but a regular file.
    """
    import OpenEXR

    p = Path(path)
    channels: dict[str, np.ndarray] = {
        c: np.ascontiguousarray(rgb[..., i], dtype=np.float32) for i, c in enumerate("RGB")
    }
    for name, data in (aovs or {}).items():
        channels[name] = np.ascontiguousarray(data, dtype=np.float32)
    hdr: dict[str, object] = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    hdr.update(header or {})
    with atomic_output(p) as tmp, OpenEXR.File(hdr, channels) as f:
        try:
            f.write(str(tmp))
        except RuntimeError as e:  # OpenEXR's write error (a full disk): name the file
            raise OSError(f"{p}: cannot write: {e}") from None
