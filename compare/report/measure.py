"""The report's measuring steps: metrics of every render against the reference (per effect
for the featured ones) and the difference, FLIP and SSIM maps of the mapped ones."""

from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from compare.render.cache import RenderCache
from compare.report.context import ReportContext
from compare.report.derived import LazyImages, derived_map, memo_json

MAP_KINDS = ("diff", "flip", "ssim")


@dataclass(frozen=True)
class Measured:
    metrics: dict[tuple[str, bool], dict[str, Any]]  # (key, per effect) -> metrics
    changed: list[int | None]  # per ladder step: pixels changed from the step before

    def overall(self, key: str) -> dict[str, Any]:
        """A render's global metrics."""
        return dict(self.metrics[key, False]["global"])

    def full(self, key: str) -> dict[str, Any]:
        """A featured render's metrics, global and per effect."""
        return self.metrics[key, True]


def measure(ctx: ReportContext) -> Measured:
    """Per effect (with HDR FLIP) for the featured renders, global for the charts' and the
    ladder's. A ladder step whose render equals the step before (its quirk has nothing to
    act on in this scene) has that step's metrics: its FLIP is not computed again."""
    ladder = ctx.plan.ladder
    changed: list[int | None] = [None] + [
        changed_pixels(ctx.imgs, ctx.cache, a.job.key, b.job.key)
        for a, b in itertools.pairwise(ladder)
    ]
    same_as: dict[str, str] = {}
    for i, planned in enumerate(ladder):
        if changed[i] == 0 and planned.fixes_one_quirk:
            before = ladder[i - 1].job.key
            same_as[planned.job.key] = same_as.get(before, before)
    pairs = [(k, True) for k, _ in ctx.featured()]
    charted = [j.key for j in ctx.plan.charted()] + [s.job.key for s in ladder]
    pairs += [(k, False) for k in dict.fromkeys(charted) if k not in same_as]
    start = time.perf_counter()
    found = ctx.ev.evaluate_all(
        [(ctx.imgs.loader(k), ctx.hashes[k], per_effect) for k, per_effect in pairs],
        workers=len(os.sched_getaffinity(0)),  # the cores this process may use
        keep_maps=frozenset(ctx.hashes[k] for k in ctx.mapped()),
        done=lambda n: ctx.progress.update(
            "metrics", n, len(pairs), time.perf_counter() - start, unit="pairs"
        ),
    )
    metrics = dict(zip(pairs, found, strict=True))
    for k, twin in same_as.items():
        metrics[k, False] = metrics[twin, False]
    return Measured(metrics, changed)


def changed_pixels(imgs: LazyImages, cache: RenderCache, before: str, after: str) -> int:
    """Pixels in which two renders differ (NaN equals NaN), kept in the cache by their hashes
    so that a warm run reads neither render."""

    def count() -> dict[str, Any]:
        a, b = imgs[before].rgb, imgs[after].rgb
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        return {"pixels": int((~same.all(axis=-1)).sum())}

    key = imgs.hashes[before] + imgs.hashes[after]
    return int(memo_json(cache, "changed-pixels", key, count)["pixels"])


def difference_maps(ctx: ReportContext) -> list[dict[str, str]]:
    """The maps' figures in images/, one row per mapped render: its key, title and files."""
    titles = dict(ctx.featured())
    rows = []
    for k in ctx.mapped():
        title = titles.get(k, k)
        files = {}
        for kind in MAP_KINDS:
            files[kind] = f"images/map-{k}-{kind}.png"
            target = ctx.out / files[kind]
            test = ctx.imgs.loader(k)
            derived_map(ctx.ev, kind, title, test, ctx.hashes[k], target)
        rows.append({"key": k, "label": title, **files})
    return rows
