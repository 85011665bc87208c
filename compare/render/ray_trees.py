"""The model's ray trees at a few differing pixels, for the pages (student page, check --html):
`rtdemo trace-pixel --pixels` traces them once, when the page is made, so the page stays
static. A failure never stops grading: the page then says why the trees are missing."""

from __future__ import annotations

import json
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from compare.judge.arrays import F32
from compare.judge.effects import BOOL
from compare.render.runner import rtdemo_path

MAX_PIXELS = 8
TIMEOUT_SECONDS = 20.0


def sample_differing(
    differing: BOOL, masks: dict[str, BOOL], n: int = MAX_PIXELS
) -> list[tuple[int, int]]:
    """Up to n differing pixels (x, y), spread over the effects in `masks` (the failing ones,
    worst first: each gets its share in turn, evenly over its differing pixels in row order),
    then topped up from every differing pixel: the same pixels every time for the same image."""
    pools = [np.flatnonzero(differing & m) for m in masks.values()]
    pools = [p for p in pools if p.size]
    chosen: list[int] = []
    for i, pool in enumerate(pools):
        share = (n - len(chosen)) // (len(pools) - i)  # an effect's unused share passes on
        chosen += [j for j in _evenly(pool, share) if j not in chosen]
    rest = np.setdiff1d(np.flatnonzero(differing), chosen)
    chosen += _evenly(rest, n - len(chosen))
    width = differing.shape[1]
    return [(i % width, i // width) for i in chosen[:n]]


def _evenly(pool: np.ndarray, k: int) -> list[int]:
    """k of a sorted pool's indices, spread evenly over it (the centres of k equal parts)."""
    k = min(k, pool.size)
    return [int(pool[int((j + 0.5) * pool.size / k)]) for j in range(k)] if k > 0 else []


def trace_trees(scene_file: str, model_args: list[str], pixels: list[tuple[int, int]],
                size: tuple[int, int]) -> dict[str, Any]:  # fmt: skip
    """{"pixels": [trace-pixel's objects]} for pixels of a size (w, h) render, or
    {"error": why} when rtdemo could not trace them."""
    if not pixels:
        return {"pixels": []}
    with tempfile.TemporaryDirectory(prefix="rtval-rays-") as tmp:
        listing = Path(tmp) / "pixels.txt"
        listing.write_text("".join(f"{x} {y}\n" for x, y in pixels))
        cmd = [rtdemo_path(), "trace-pixel", scene_file, "--pixels", str(listing), "--json"]
        cmd += [*model_args, "--width", str(size[0]), "--height", str(size[1])]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_SECONDS)
        except subprocess.TimeoutExpired:
            return {"error": f"rtdemo trace-pixel ran over {TIMEOUT_SECONDS:.0f} s"}
        except OSError as e:
            return {"error": f"rtdemo trace-pixel could not start ({e.strerror})"}
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        return {"error": f"rtdemo trace-pixel failed (exit {proc.returncode}): {last}"}
    try:
        return {"pixels": json.loads(proc.stdout)["pixels"]}
    except (ValueError, KeyError, TypeError):
        return {"error": "rtdemo trace-pixel printed no ray trees"}


def page_trees(
    scene_file: str, model_args: list[str], image: F32, differing: BOOL, masks: dict[str, BOOL]
) -> dict[str, Any]:
    """What a page shows: the traced pixels with the image's own value at each (linear),
    the image's size, and the model's trees; or the error."""
    h, w = differing.shape
    pixels = sample_differing(differing, masks)
    out = trace_trees(scene_file, model_args, pixels, (w, h)) | {"width": w, "height": h}
    for p in out.get("pixels", []):
        x, y = int(p["x"]), int(p["y"])
        p["image"] = [round(float(v), 4) for v in np.nan_to_num(image[y, x])]
    return out
