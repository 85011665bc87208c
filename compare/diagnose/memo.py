"""A diagnosis kept for the next time the same image is diagnosed: in a class, students with
the same bug in the same float32 program hand in the same pixels, and grading them again, or
re-running `rtval diagnose`, searches again for nothing. The record is kept in the renderer's
store (diagnose_score.Store: the render cache's derived/) under a name hashing every input the
search reads: the image's values and encoding, the scene, what the search may try, the judge's
code, and the renderer's `identity` (its binary, the scene file, the size); any change makes a
new search.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from compare.code_identity import code_identity
from compare.diagnose.candidate import Candidate
from compare.diagnose.record import Diagnosis
from compare.diagnose.score import Store
from compare.judge.images import Image
from scene_model.scene import Scene

RECORD_FORMAT = "rtval-diagnosis/1"


def record_name(
    image: Image,
    scene: Scene,
    starts: Sequence[Candidate],
    search: dict[str, Any],
    identity: str,
) -> str:
    """The store name of this diagnosis; `search`: what it may try (quirks, turns, grows,
    max_renders)."""
    h = hashlib.sha256(code_identity("compare.diagnose.search").encode() + identity.encode())
    rgb = np.ascontiguousarray(image.rgb)
    h.update(f"{rgb.dtype}{rgb.shape}{image.encoding}".encode() + rgb.data.cast("B"))
    h.update(repr(scene).encode())
    h.update(json.dumps([c.name for c in starts]).encode())
    h.update(json.dumps(search, sort_keys=True).encode())
    return f"diagnosis-{h.hexdigest()[:32]}.json"


def load(store: Store, name: str, image: Image, t0: float) -> Diagnosis | None:
    """The kept diagnosis (its image this one, its seconds this run's), or None."""
    text = store.get(name)
    if text is None:
        return None
    try:
        raw = json.loads(text)
        if raw.get("format") != RECORD_FORMAT:
            return None
        d = Diagnosis.from_record(raw["diagnosis"])
    except (ValueError, KeyError, TypeError, AttributeError, RecursionError):
        return None  # not a record of this format: searched again, and kept anew
    return dataclasses.replace(d, image=image.path, seconds=time.perf_counter() - t0)


def keep(store: Store, name: str, d: Diagnosis) -> None:
    store.put(name, json.dumps({"format": RECORD_FORMAT, "diagnosis": d.record()}))
