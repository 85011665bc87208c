"""Results the report derives from renders, kept in the render cache (derived/): metrics,
PNGs, compressed EXRs, figures and facts, each keyed by its inputs' content hashes and the
judge's code, so that a warm `rtval report` reads no render and draws nothing."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.code_identity import code_identity
from compare.judge.evaluate import evaluate_pair
from compare.judge.images import Image, read_image, write_exr
from compare.judge.png import write_png
from compare.judge.tolerances import Tolerances
from compare.render.cache import RenderCache
from compare.report import figures as figs
from safe_files.content import json_safe as _json_safe
from safe_files.paths import atomic_output, write_atomic

# The judge modules the derived results come from (with what they import): metrics and analyses
# are keyed by their code, so a change to a metric is never hidden by the cache. Other judge
# code (the diagnosis, the rubric, ...) leaves them valid.
JUDGE_ROOTS = ("evaluate", "effects", "convergence", "penumbra", "pareto", "scoring", "sentences")


def judge_identity() -> str:
    return code_identity(*(f"compare.judge.{m}" for m in JUDGE_ROOTS))[:16]


def figures_identity() -> str:
    """The judge's code and the figures': the key of every drawn figure. Redrawing a chart
    recomputes no metric."""
    return code_identity("compare.report.figures")[:16] + judge_identity()


class LazyImages:
    """The report's images by key, read from the cache on first use. Facts the page needs
    of every render (its render time, its size) are kept in the cache, so that a warm run
    reads no EXR at all."""

    def __init__(self, paths: dict[str, Path], hashes: dict[str, str], cache: RenderCache) -> None:
        self.paths, self.hashes, self.cache = paths, hashes, cache
        self.loaded: dict[str, Image] = {}

    def __getitem__(self, key: str) -> Image:
        if key not in self.loaded:
            self.loaded[key] = read_image(self.paths[key])
        return self.loaded[key]

    def add(self, key: str, image: Image, sha: str) -> None:
        self.loaded[key], self.hashes[key] = image, sha

    def loader(self, key: str) -> Callable[[], Image]:
        return lambda: self[key]

    def facts(self, key: str) -> dict[str, Any]:
        def read() -> dict[str, Any]:
            img = self[key]
            return {"seconds": render_seconds(img), "size": [img.shape[1], img.shape[0]]}

        return memo_json(self.cache, "facts", self.hashes[key], read)


def memo_json(
    cache: RenderCache, name: str, inputs: str, compute: Callable[[], dict[str, Any]]
) -> dict[str, Any]:
    path = cache.derived(f"{name}-{digest(inputs)}.json")
    if path.is_file():
        with contextlib.suppress(ValueError, OSError):
            return dict(json.loads(path.read_text()))
    value = compute()
    write_atomic(path, json.dumps(value))
    return value


class Evaluator:
    """Metrics of images against the reference, cached by the pair's content hashes (and the
    judge's code); the reference and its masks are read only when a metric is computed."""

    def __init__(
        self,
        ref: Callable[[], Image],
        ref_hash: str,
        masks: Callable[[], dict[str, np.ndarray]],
        cache: RenderCache,
    ) -> None:
        self.ref, self.ref_hash, self.masks, self.cache = ref, ref_hash, masks, cache
        self._maps: dict[str, MapPair] = {}  # by the test image's hash

    def _path(self, test_hash: str, per_effect: bool) -> Path:
        return self.cache.derived(
            f"metrics-{self.ref_hash[:16]}-{test_hash[:16]}-{judge_identity()}-{int(per_effect)}.json"
        )

    def _stored(self, test_hash: str, per_effect: bool) -> Path | None:
        path = self._path(test_hash, per_effect)
        if path.is_file():
            return path
        # The global metrics of a per-effect evaluation are the same numbers (HDR FLIP added).
        full = self._path(test_hash, True)
        return full if not per_effect and full.is_file() else None

    def evaluate(
        self, test: Callable[[], Image], test_hash: str, *, per_effect: bool
    ) -> dict[str, Any]:
        stored = self._stored(test_hash, per_effect)
        if stored is not None:
            return dict(json.loads(stored.read_text()))
        masks = self.masks() if per_effect else None
        out, _ = pair_metrics(self.ref().rgb, test().rgb, masks)
        write_atomic(self._path(test_hash, per_effect), json.dumps(out))
        return out

    def evaluate_all(
        self,
        pairs: list[tuple[Callable[[], Image], str, bool]],
        *,
        workers: int,
        done: Callable[[int], None] | None = None,
        keep_maps: frozenset[str] = frozenset(),
    ) -> list[dict[str, Any]]:
        """`evaluate` for many (image, hash, per_effect), the missing ones in `workers`
        processes (FLIP holds the GIL: threads would not overlap). The FLIP and SSIM maps of
        the images in `keep_maps` (hashes) come back from the workers for `maps`."""
        covered = {h for _, h, per_effect in pairs if per_effect}
        missing, seen = [], set()
        for load, h, pe in pairs:
            if (h, pe) not in seen and self._stored(h, pe) is None and (pe or h not in covered):
                missing.append((load, h, pe))
            seen.add((h, pe))
        if missing and workers > 1:
            from concurrent.futures import ProcessPoolExecutor

            ref = self.ref().rgb
            with ProcessPoolExecutor(max_workers=workers, initializer=_one_thread) as pool:
                futures = [
                    pool.submit(
                        pair_metrics, ref, load().rgb, self.masks() if pe else None, h in keep_maps
                    )
                    for load, h, pe in missing
                ]
                for n, ((_, h, pe), f) in enumerate(zip(missing, futures, strict=True)):
                    found, maps = f.result()
                    if maps is not None:
                        self._maps[h] = maps
                    write_atomic(self._path(h, pe), json.dumps(found))
                    if done:
                        done(n + 1)
        return [self.evaluate(load, h, per_effect=pe) for load, h, pe in pairs]

    def maps(self, test: Callable[[], Image], test_hash: str) -> MapPair:
        """The FLIP (LDR) and SSIM maps against the reference: kept from evaluate_all, or
        computed here."""
        if test_hash not in self._maps:
            m = evaluate_pair(self.ref().rgb, test().rgb).maps
            self._maps[test_hash] = MapPair(m.flip_ldr, m.ssim)
        return self._maps[test_hash]


@dataclass(frozen=True)
class MapPair:
    flip_ldr: np.ndarray
    ssim: np.ndarray


def _one_thread() -> None:
    """One OpenMP thread per pool worker: one worker per core already fills the cores, and
    FLIP's threads on top of them only contend (paper report, metrics step: 2 workers x 1
    thread 27.4 s, 4 workers x 2 threads 31.2 s; bench/NOTES.md)."""
    os.environ["OMP_NUM_THREADS"] = "1"


def pair_metrics(
    ref: np.ndarray, test: np.ndarray, masks: dict[str, np.ndarray] | None, keep_maps: bool = False
) -> tuple[dict[str, Any], MapPair | None]:
    """The report's numbers for one render against the reference: global, and per effect
    (with HDR FLIP) when masks are given. A plain function of arrays, so a process pool can
    run it. Pixels over 1/255 are counted (compare's default failing error is 0.01)."""
    ev = evaluate_pair(
        ref,
        test,
        hdr=masks is not None,
        tolerances=Tolerances(fail=1.0 / 255.0),
        masks=masks,
    )
    found = {
        "global": _json_safe(ev.metrics.as_dict()),
        "per_effect": {k: _json_safe(e.metrics.as_dict()) for k, e in ev.per_effect.items()},
    }
    # The difference maps' figures draw these; computing them again cost ~1 s of CPU each.
    return found, MapPair(ev.maps.flip_ldr, ev.maps.ssim) if keep_maps else None


def copy_file(src: Path, dst: Path) -> None:
    with atomic_output(dst) as tmp:  # only a regular file is replaced; no partial copy stays
        shutil.copyfile(src, tmp)


def render_seconds(img: Image) -> float:
    return float(img.header.get("rtval.render_seconds", "nan"))


def digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def derived_png(cache: RenderCache, sha: str, img: Callable[[], Image], target: Path) -> None:
    """The display PNG of a render, encoded once per render content."""
    cached = cache.derived(f"png-{sha[:24]}.png")
    if not cached.is_file():
        write_png(cached, img().rgb)
    copy_file(cached, target)


def derived_exr(cache: RenderCache, sha: str, img: Callable[[], Image], target: Path) -> None:
    """A render as a ZIP-compressed EXR with all its channels (lossless)."""
    cached = cache.derived(f"exr-zip-{sha[:24]}.exr")
    if not cached.is_file():
        image = img()
        write_exr(cached, image.rgb, aovs=image.aovs, header=image.header)
    copy_file(cached, target)


def derived_figure(
    cache: RenderCache, name: str, inputs: str, target: Path, draw: Callable[[Path], None]
) -> None:
    """A chart drawn once per input data (and figure code)."""
    cached = cache.derived(f"{name}-{digest(inputs + figures_identity())}.png")
    if not cached.is_file():
        draw(cached)
    copy_file(cached, target)


def derived_map(
    ev: Evaluator,
    kind: str,
    title: str,
    test: Callable[[], Image],
    test_hash: str,
    target: Path,
) -> None:
    """One difference map (kind "diff", "flip" or "ssim") of `test` against the reference."""
    ref = ev.ref

    def draw(p: Path) -> None:
        if kind == "diff":
            figs.signed_difference(ref().rgb, test().rgb, p, f"signed difference: {title}")
        elif kind == "flip":
            figs.map_figure(
                ev.maps(test, test_hash).flip_ldr,
                p,
                title=f"FLIP (LDR, 67 ppd): {title}",
                cmap="magma",
                vmin=0,
                vmax=1,
                label="FLIP error",
            )
        else:
            figs.map_figure(
                np.nan_to_num(ev.maps(test, test_hash).ssim, nan=1.0),
                p,
                title=f"SSIM map: {title}",
                cmap="viridis",
                vmin=0,
                vmax=1,
                label="SSIM",
            )

    derived_figure(ev.cache, f"map-{kind}", ev.ref_hash + test_hash + title, target, draw)
