"""Reads the one EXR layout rtdemo and the render cache write most, quickly: a single-part,
uncompressed scanline file whose channels are all 32-bit floats, one line per block in
increasing order. Such a file is a header, a table of line offsets, then fixed-size blocks,
so numpy views it whole (a 640x480 candidate in 8.2 ms instead of the OpenEXR binding's
18.7 ms, bench/NOTES.md; the diagnosis reads dozens per search).

`parse` returns None for anything else (compressed, tiled, half floats, a reordered table...),
and images.py then reads the file with OpenEXR as before: this is a shortcut, never the only
reader. Values, channel names, sizes and string attributes are those OpenEXR gives
(tests/test_exr_scanlines.py compares both on every layout rtdemo writes).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np
from numpy.typing import NDArray

from compare.judge.arrays import F32

MAGIC = 20000630
HEAD_BYTES = 1 << 16  # rtdemo's header is ~1 KB; one longer is read by OpenEXR
FLOAT = 2  # the channel pixel type UINT 0, HALF 1, FLOAT 2
# Version-field flags of a layout this reader does not take: tiled, deep, multi-part.
OTHER_LAYOUTS = 0x200 | 0x800 | 0x1000
# String attributes of the format itself, not the renderer's: OpenEXR hands them back as enums.
FORMAT_STRINGS = ("type", "name", "view")


@dataclass
class Layout:
    """What the header says, and where the pixels start."""

    width: int
    height: int
    channels: list[str]  # in file order (alphabetical)
    strings: dict[str, str]
    table_at: int  # the line-offset table's byte offset
    y0: int  # the first line's number (the data window's top)


@dataclass
class Scanlines:
    """A whole file's pixels as one view, H x channels x W (no copy made yet)."""

    planes: NDArray[np.float32]
    names: list[str]
    strings: dict[str, str]

    def channel(self, name: str) -> F32:
        """One channel, H x W, contiguous (a copy)."""
        return np.ascontiguousarray(self.planes[:, self.names.index(name), :])

    def rgb(self) -> F32:
        """R, G, B interleaved, H x W x 3 (one copy)."""
        return np.stack([self.planes[:, self.names.index(c), :] for c in "RGB"], axis=-1)


def _cstr(buf: bytes, at: int) -> tuple[str, int]:
    end = buf.index(b"\0", at, at + 256)
    return buf[at:end].decode("latin-1"), end + 1


def _channels(value: bytes) -> list[str] | None:
    """Channel names of a chlist, or None unless every one is FLOAT, sampled 1 x 1."""
    out, at = [], 0
    while at < len(value) and value[at] != 0:
        name, at = _cstr(value, at)
        ptype, _linear, xs, ys = struct.unpack_from("<iB3xii", value, at)
        at += 16
        if ptype != FLOAT or xs != 1 or ys != 1:
            return None
        out.append(name)
    return out


def _attributes(head: bytes) -> tuple[dict[str, tuple[str, bytes]], int] | None:
    """name -> (type, value) and where the header ends, or None when it does not end in head."""
    attrs, at = {}, 8
    try:
        while head[at] != 0:
            name, at = _cstr(head, at)
            kind, at = _cstr(head, at)
            (size,) = struct.unpack_from("<i", head, at)
            at += 4
            if size < 0 or at + size > len(head):
                return None
            attrs[name] = (kind, head[at : at + size])
            at += size
    except (ValueError, IndexError, struct.error):
        return None
    return attrs, at + 1


def _layout(head: bytes) -> Layout | None:
    if len(head) < 8:
        return None
    magic, version = struct.unpack_from("<ii", head, 0)
    if magic != MAGIC or version & 0xFF != 2 or version & OTHER_LAYOUTS:
        return None
    found = _attributes(head)
    if found is None:
        return None
    attrs, end = found
    try:
        chans = _channels(attrs["channels"][1])
        compression, line_order = attrs["compression"][1], attrs["lineOrder"][1]
        x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"][1])
    except (KeyError, struct.error):
        return None
    if not chans or compression != b"\0" or line_order != b"\0" or x1 < x0 or y1 < y0:
        return None
    strings = {
        k: v.decode("utf-8", "replace")
        for k, (kind, v) in attrs.items()
        if kind == "string" and k not in FORMAT_STRINGS
    }
    return Layout(x1 - x0 + 1, y1 - y0 + 1, chans, strings, end, y0)


def read_layout(f: BinaryIO) -> Layout | None:
    """The header of a file open at its start, or None: not this layout."""
    return _layout(f.read(HEAD_BYTES))


def file_size(layout: Layout) -> int:
    """The size a file of this layout has: header, table, then every line's block."""
    block = 8 + 4 * len(layout.channels) * layout.width
    return layout.table_at + 8 * layout.height + layout.height * block


def parse(layout: Layout, data: bytes) -> Scanlines | None:
    """The pixels of a whole file of this layout, or None when its table or blocks are not
    the plain sequence (OpenEXR reads those)."""
    h, w, n = layout.height, layout.width, len(layout.channels)
    if len(data) != file_size(layout):
        return None
    first = layout.table_at + 8 * h
    block = 8 + 4 * n * w
    table = np.frombuffer(data, "<u8", h, layout.table_at)
    if not np.array_equal(table, first + block * np.arange(h, dtype=np.uint64)):
        return None
    lines = np.frombuffer(
        data, np.dtype([("y", "<i4"), ("size", "<i4"), ("px", "<f4", (n, w))]), h, first
    )
    if not (
        np.all(lines["size"] == 4 * n * w) and np.array_equal(lines["y"], layout.y0 + np.arange(h))
    ):
        return None
    return Scanlines(lines["px"], layout.channels, layout.strings)
