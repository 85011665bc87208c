"""The exact-match bounds of a diagnosis candidate (exact_match.model_bounds of its pixel-centre
render and its perturbed ones), kept in the diagnosis's store between runs.

They depend on the candidate and the image's encoding only, never on the image: the next image
diagnosed against the same candidate (a class's students, the same program run again) reads
them instead of reading ten perturbed renders and computing them again (about 0.35 s a
candidate at 640x480). For the 8-bit encodings every bound is a whole code in [0, 255], so they
are kept as bytes; a float image's bounds are not kept. The bytes carry their own sha1, the
candidate's description and the exact-match code's hash are in the name: anything else read
back is computed again.
"""

from __future__ import annotations

import hashlib
import json
from functools import cache
from pathlib import Path

import numpy as np

from compare.judge import exact_match
from compare.judge.candidate import Candidate
from compare.judge.diagnose_score import Store
from compare.judge.exact_match import Bounds

BOUNDS_FORMAT = "rtval-diagnose-bounds/1"
Pair = tuple[Bounds, Bounds]


@cache
def _code() -> bytes:
    h = hashlib.sha256()
    for module in (exact_match,):
        h.update(Path(module.__file__ or "").read_bytes())
    h.update(Path(__file__).read_bytes())
    return h.digest()


def bounds_name(identity: str, c: Candidate, perturbations: object, encoding: str) -> str:
    """The store name of c's bounds: what renders it, the candidate, how it is perturbed."""
    h = hashlib.sha256(_code())
    h.update(json.dumps([identity, repr(c), repr(perturbations), encoding]).encode())
    return f"diagnose-bounds-{h.hexdigest()[:32]}.bin"


def _planes(pair: Pair) -> list[np.ndarray]:
    return [p for b in pair for p in (b.lo, b.hi)]


def pack(pair: Pair) -> bytes | None:
    """The bounds as bytes, or None where some bound is not a whole code (a float image)."""
    codes = []
    for plane in _planes(pair):
        u8 = np.clip(plane, 0, 255).astype(np.uint8)
        if not np.array_equal(u8, plane):
            return None
        codes.append(u8.tobytes())
    nans = [np.packbits(b.nan).tobytes() for b in pair]
    payload = b"".join(codes + nans)
    head = {"format": BOUNDS_FORMAT, "shape": list(pair[0].lo.shape)}
    head["sha1"] = hashlib.sha1(payload, usedforsecurity=False).hexdigest()
    return json.dumps(head).encode() + b"\n" + payload


def packed_size(shape: tuple[int, ...]) -> int:
    """At most how many bytes pack writes for bounds of this shape."""
    n = int(np.prod(shape))
    return 4 * n + 2 * ((n + 7) // 8) + 256


def unpack(data: bytes | None, shape: tuple[int, ...]) -> Pair | None:
    """The bounds pack wrote for this shape, or None (absent, another shape, damaged)."""
    if data is None or b"\n" not in data:
        return None
    head_bytes, payload = data.split(b"\n", 1)
    try:
        head = json.loads(head_bytes)
        ok = head["format"] == BOUNDS_FORMAT and tuple(head["shape"]) == tuple(shape)
    except (ValueError, KeyError, TypeError):
        return None
    n = int(np.prod(shape))
    bits = (n + 7) // 8
    if not ok or len(payload) != 4 * n + 2 * bits:
        return None
    if hashlib.sha1(payload, usedforsecurity=False).hexdigest() != head.get("sha1"):
        return None
    buf = np.frombuffer(payload, np.uint8)
    lo0, hi0, lo1, hi1 = (
        buf[i * n : (i + 1) * n].reshape(shape).astype(np.float32) for i in range(4)
    )
    nan0, nan1 = (
        np.unpackbits(buf[4 * n + i * bits : 4 * n + (i + 1) * bits], count=n)
        .reshape(shape)
        .astype(bool)
        for i in range(2)
    )
    return Bounds(lo0, hi0, nan0), Bounds(lo1, hi1, nan1)


def load(store: Store | None, name: str, shape: tuple[int, ...]) -> Pair | None:
    if store is None:
        return None
    return unpack(store.get_bytes(name, packed_size(shape)), shape)


def keep(store: Store | None, name: str, pair: Pair) -> None:
    data = pack(pair) if store is not None else None
    if store is not None and data is not None:
        store.put_bytes(name, data)
