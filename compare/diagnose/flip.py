"""The FLIP numbers a diagnosis reports (diagnose.py): the mean LDR-FLIP (metrics.flip_ldr_map,
the judge's map) of the image against a candidate's render in each effect region.

They are computed on a thread of their own while the search goes on (flip-evaluator releases
the GIL), the start's as soon as the start is chosen. A later candidate's map is the first
map's, evaluated again only around the pixels where the two renders differ
(flip_crops.updated_ldr_flip: the same values). With a store, the means are kept under a name
hashing both images' bytes, the regions and the FLIP code, so that diagnosing the image again
computes none.
"""

from __future__ import annotations

import hashlib
import json
from concurrent.futures import Executor, Future
from functools import cache

import numpy as np

from compare.code_identity import code_identity
from compare.diagnose.candidate import Candidate
from compare.diagnose.score import Store
from compare.judge import flip_crops, metrics
from compare.judge.arrays import F32
from compare.judge.effects import BOOL

FLIP_FORMAT = "rtval-diagnose-flip/1"
Means = dict[str, float]


@cache
def _flip_code() -> bytes:
    """What the FLIP numbers are computed by: the judge's FLIP code and flip-evaluator."""
    return code_identity("compare.judge.metrics", distributions=("flip-evaluator",)).encode()


def _name(test: F32, rgb: F32, masks: dict[str, BOOL]) -> str:
    h = hashlib.sha256(_flip_code())
    for a in (test, rgb):
        h.update(str((a.dtype, a.shape)).encode() + np.ascontiguousarray(a).data.cast("B"))
    for k, m in masks.items():
        h.update(k.encode() + np.packbits(m).data.cast("B"))
    return f"diagnose-flip-{h.hexdigest()[:32]}.json"


def _stored_means(text: str | None, masks: dict[str, BOOL]) -> Means | None:
    """The means a store kept, or None when there are none of this format for these
    regions (anything else there is computed again)."""
    if text is None:
        return None
    try:
        raw = json.loads(text)
        means = {k: float(raw["means"][k]) for k in masks}
    except (ValueError, KeyError, TypeError, RecursionError):
        return None
    return means if raw.get("format") == FLIP_FORMAT else None


class Flips:
    """The FLIP means of candidates against one image, each computed once, on `background`
    (one thread: the maps are computed in turn)."""

    def __init__(self, store: Store | None, background: Executor) -> None:
        self.store, self.pool = store, background
        self.jobs: dict[Candidate, Future[Means]] = {}
        # The first map computed here, with the display values of its render and of the
        # image: later maps of that image are evaluated again only where renders differ.
        self.known: tuple[F32, F32, F32] | None = None
        self.stale: BOOL | None = None  # where a seeded map holds no values (seed)
        self.guessed: Candidate | None = None  # the search's likely result (guess)
        self.maps: dict[Candidate, F32] = {}  # every map computed here, by candidate

    def start(self, c: Candidate, rgb: F32, test: F32, masks: dict[str, BOOL]) -> None:
        """Begin c's means (its render `rgb` against the image `test`), unless begun."""
        if c not in self.jobs:
            self.jobs[c] = self.pool.submit(self._means, c, rgb, test, dict(masks))

    def guess(self, c: Candidate, rgb: F32, test: F32, masks: dict[str, BOOL]) -> None:
        """Begin c's means as the likely result's: the last guess goes unless begun."""
        last, self.guessed = self.guessed, c
        if last is not None and last != c and self.jobs[last].cancel():
            del self.jobs[last]
        self.start(c, rgb, test, masks)

    def means(self, c: Candidate, rgb: F32, test: F32, masks: dict[str, BOOL]) -> Means:
        self.start(c, rgb, test, masks)
        return self.jobs[c].result()

    def map_of(self, c: Candidate, rgb: F32, test: F32) -> F32:
        """c's map (its render `rgb` against the image `test`): the one its means were
        computed from, else computed now on the background thread."""
        if c not in self.maps:
            self.pool.submit(self._map_of, c, rgb, test).result()
        return self.maps[c]

    def _map_of(self, c: Candidate, rgb: F32, test: F32) -> F32:
        if c not in self.maps:
            self.maps[c] = self._map(metrics.display(rgb), metrics.display(test))
        return self.maps[c]

    def _means(self, c: Candidate, rgb: F32, test: F32, masks: dict[str, BOOL]) -> Means:
        name = _name(test, rgb, masks)
        known = _stored_means(self.store.get(name), masks) if self.store is not None else None
        if known is not None:
            return known
        flip = self._map_of(c, rgb, test)
        out = {k: float(flip[m].mean()) for k, m in masks.items()}
        if self.store is not None:
            self.store.put(name, json.dumps({"format": FLIP_FORMAT, "means": out}))
        return out

    def seed(self, ref: F32, test: F32, flip: F32, valid: BOOL) -> None:
        """A map computed elsewhere (the verdict's, metrics.flip_ldr_map of the linear `ref`
        and `test`), whose values hold where `valid`: the first map here is made from it.
        Call before any map is begun."""
        self.known = (metrics.display(ref), flip, metrics.display(test))
        self.stale = ~valid

    def _map(self, ref: F32, test: F32) -> F32:
        """metrics.flip_ldr_map of the display values, from the first map where one is
        known (runs on the one background thread: `known` is never written at once)."""
        if self.known is not None and np.array_equal(self.known[2], test):
            flip = flip_crops.updated_ldr_flip(
                ref, test, self.known[0], self.known[1], stale=self.stale
            )
            if self.stale is not None:  # a seed: this whole map is the one to start from
                self.known, self.stale = (ref, flip, test), None
            return flip
        flip = flip_crops.cropped_ldr_flip(ref, test)
        self.known, self.stale = (ref, flip, test), None
        return flip
