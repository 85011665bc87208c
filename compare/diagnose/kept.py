"""What a diagnosis computes from candidate renders alone, never from the image, kept in the
diagnosis's store between runs: a candidate's exact-match bounds (exact_match.model_bounds of
its pixel-centre render and its perturbed ones), its 8-bit codes as the score sees them
(diagnose_score.Codes) and the effect masks of the first render.

The next image diagnosed against the same candidates (a class's students, the same program run
again) reads them instead of computing them again: the bounds cost ten perturbed renders read
and about 0.2 s a candidate at 640x480, a candidate's codes its render read and converted
(about 15 ms), the masks 0.12 s before anything else can start. For the 8-bit encodings every
bound and code is a whole number in [0, 255], so they are kept as bytes; a float image's are
not kept. Each file carries its payload's CRC-32 and what it holds; the
candidate, the renderer and the code that computes them are in its name: anything else read
back is computed again.
"""

from __future__ import annotations

import hashlib
import json
import zlib
from typing import Any

import numpy as np

from compare.code_identity import code_identity
from compare.diagnose.candidate import Candidate
from compare.diagnose.score import Codes, Store
from compare.judge import effects
from compare.judge.effects import BOOL
from compare.judge.exact_match import Bounds

KEPT_FORMAT = "rtval-diagnose-kept/2"
HEAD_MAX = 4096
CHECK = 8  # hex digits of the check line
Pair = tuple[Bounds, Bounds]


def _code() -> bytes:
    return code_identity(__name__).encode()


def kept_name(kind: str, identity: str, c: Candidate, *more: object) -> str:
    """The store name of `kind` ("bounds", "codes", "masks") computed from c's renders (c by
    its name: its every field, in one order)."""
    h = hashlib.sha256(_code())
    h.update(json.dumps([kind, identity, c.name, repr(more)]).encode())
    return f"diagnose-{kind}-{h.hexdigest()[:32]}.bin"


def _check(body: bytes | memoryview) -> bytes:
    """The check line of a body: its CRC-32 (8 hex digits). It finds a torn or damaged file;
    it is no defence against a planted one, which no checksum kept beside it could be."""
    return b"%08x" % zlib.crc32(body)


def _framed(head: dict[str, Any], payload: bytes) -> bytes:
    """The check of what follows, a line of JSON (the head) and the payload."""
    body = json.dumps({"format": KEPT_FORMAT, **head}).encode() + b"\n" + payload
    return _check(body) + b"\n" + body


def _unframed(data: bytes | None, kind: str) -> tuple[dict[str, Any], memoryview] | None:
    """The head and payload (a view of `data`) of a file _framed wrote for `kind`, or None
    (damaged, another kind or format: anything but what _framed writes)."""
    if data is None or len(data) < CHECK + 1 or data[CHECK : CHECK + 1] != b"\n":
        return None
    body = memoryview(data)[CHECK + 1 :]
    if _check(body) != data[:CHECK]:
        return None
    head_bytes, sep, _ = bytes(body[:HEAD_MAX]).partition(b"\n")
    try:
        head = json.loads(head_bytes) if sep else None
    except (ValueError, RecursionError):
        return None
    if not isinstance(head, dict) or head.get("format") != KEPT_FORMAT or head.get("kind") != kind:
        return None
    return head, body[len(head_bytes) + 1 :]


def _shape(head: dict[str, Any], want: tuple[int, ...]) -> bool:
    """Whether the head's shape is `want`."""
    got = head.get("shape")
    return isinstance(got, list) and all(type(v) is int for v in got) and tuple(got) == want


def _bits(n: int) -> int:
    return (n + 7) // 8


def _unpacked(buf: np.ndarray, at: int, n: int, shape: tuple[int, ...]) -> BOOL:
    out: BOOL = np.unpackbits(buf[at : at + _bits(n)], count=n).reshape(shape).astype(bool)
    return out


# --- exact-match bounds ----------------------------------------------------------------------


def pack_bounds(pair: Pair) -> bytes | None:
    """The bounds as bytes, or None where some bound is not a whole code (a float image)."""
    codes = []
    for plane in (p for b in pair for p in (b.lo, b.hi)):
        u8 = np.clip(plane, 0, 255).astype(np.uint8)
        if not np.array_equal(u8, plane):
            return None
        codes.append(u8.tobytes())
    nans = [np.packbits(b.nan).tobytes() for b in pair]
    return _framed({"kind": "bounds", "shape": list(pair[0].lo.shape)}, b"".join(codes + nans))


def bounds_size(shape: tuple[int, ...]) -> int:
    """At most how many bytes pack_bounds writes for bounds of this shape."""
    n = int(np.prod(shape))
    return 4 * n + 2 * _bits(n) + HEAD_MAX


def unpack_bounds(data: bytes | None, shape: tuple[int, ...]) -> Pair | None:
    """The bounds pack_bounds wrote for this shape, or None (absent, another shape, damaged)."""
    framed = _unframed(data, "bounds")
    n = int(np.prod(shape))
    if framed is None or not _shape(framed[0], tuple(shape)):
        return None
    payload = framed[1]
    if len(payload) != 4 * n + 2 * _bits(n):
        return None
    buf = np.frombuffer(payload, np.uint8)
    lo0, hi0, lo1, hi1 = (
        buf[i * n : (i + 1) * n].reshape(shape).astype(np.float32) for i in range(4)
    )
    nan0, nan1 = (_unpacked(buf, 4 * n + i * _bits(n), n, shape) for i in range(2))
    return Bounds(lo0, hi0, nan0), Bounds(lo1, hi1, nan1)


# --- effect masks ----------------------------------------------------------------------------


def pack_masks(masks: dict[str, BOOL]) -> bytes:
    shape = next(iter(masks.values())).shape
    payload = b"".join(np.packbits(m).tobytes() for m in masks.values())
    return _framed({"kind": "masks", "shape": list(shape), "names": list(masks)}, payload)


def masks_size(shape: tuple[int, ...]) -> int:
    return len(effects.EFFECTS) * _bits(int(np.prod(shape))) + HEAD_MAX


def unpack_masks(data: bytes | None, shape: tuple[int, ...]) -> dict[str, BOOL] | None:
    """The masks pack_masks wrote for renders of this shape, or None."""
    framed = _unframed(data, "masks")
    n = int(np.prod(shape))
    if framed is None or not _shape(framed[0], tuple(shape)):
        return None
    head, payload = framed
    names = head.get("names")
    if not isinstance(names, list) or not names or len(payload) != len(names) * _bits(n):
        return None
    if not all(isinstance(k, str) and k in effects.EFFECTS for k in names):
        return None
    buf = np.frombuffer(payload, np.uint8)
    masks = {k: _unpacked(buf, i * _bits(n), n, shape) for i, k in enumerate(names)}
    # Every region has pixels (Regions relies on it), no name twice.
    return masks if len(masks) == len(names) and all(m.any() for m in masks.values()) else None


# --- a render's codes ----------------------------------------------------------------------


def pack_codes(codes: Codes) -> bytes | None:
    """The codes (0..255) and each half-level as its offset from twice the code (-1, 0, 1);
    None for codes outside those ranges (none that diagnose_score makes)."""
    offset = codes.halves - np.int16(2) * codes.enc
    if not len(offset) or codes.enc.min() < 0 or codes.enc.max() > 255:
        return None
    if np.abs(offset).max() > 1:
        return None
    enc, offset = codes.enc.astype(np.uint8), offset.astype(np.int8)
    head = {"kind": "codes", "pixels": len(codes.enc), "digest": codes.digest.hex()}
    return _framed(head, enc.tobytes() + offset.tobytes())


def codes_size(pixels: int) -> int:
    return 6 * pixels + HEAD_MAX


def unpack_codes(data: bytes | None, pixels: int) -> Codes | None:
    """The codes pack_codes wrote for a render of this many pixels, or None."""
    framed = _unframed(data, "codes")
    if framed is None or framed[0].get("pixels") != pixels or len(framed[1]) != 6 * pixels:
        return None
    digest = framed[0].get("digest")
    if not isinstance(digest, str) or len(digest) != 40:
        return None
    try:
        digest_bytes = bytes.fromhex(digest)
    except ValueError:
        return None
    buf = np.frombuffer(framed[1], np.uint8)
    offset = buf[3 * pixels :].view(np.int8).reshape(pixels, 3)
    # -1, 0, 1 as unsigned bytes are 255, 0, 1: one bound checks both ends.
    if (buf[3 * pixels :] + np.uint8(1)).max(initial=0) > 2:
        return None
    enc = buf[: 3 * pixels].reshape(pixels, 3).astype(np.int16)
    halves = np.left_shift(enc, 1)
    halves += offset
    return Codes(None, enc, halves, digest_bytes)


def read(store: Store | None, name: str, max_bytes: int) -> bytes | None:
    return None if store is None else store.get_bytes(name, max_bytes)


def write(store: Store | None, name: str, data: bytes | None) -> None:
    if store is not None and data is not None:
        store.put_bytes(name, data)
