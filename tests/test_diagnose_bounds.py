"""A candidate's exact-match bounds are kept between diagnoses (compare/judge/diagnose_bounds.py):
read back they are the bounds computed, a damaged or foreign file is computed again, and a second
image judged against the same candidates renders none of its perturbed renders."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo

from compare.judge import diagnose_bounds, diagnose_trials
from compare.judge.diagnose import diagnose
from compare.judge.exact_match import Bounds, model_bounds
from compare.render.cache import RenderCache
from compare.render.candidates import CandidateRenderer, forget_recent
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 16, 12


def _pair(rng: np.random.Generator, shape: tuple[int, ...]) -> tuple[Bounds, Bounds]:
    renders = [rng.random(shape, np.float32) * 1.2 - 0.1 for _ in range(4)]
    renders[1][0, 0, 0] = np.nan  # a model NaN is kept too
    return model_bounds(renders, "srgb")


def _equal(a: tuple[Bounds, Bounds], b: tuple[Bounds, Bounds]) -> bool:
    return all(
        np.array_equal(x.lo, y.lo) and np.array_equal(x.hi, y.hi) and np.array_equal(x.nan, y.nan)
        for x, y in zip(a, b, strict=True)
    )


def test_packed_bounds_read_back_as_computed() -> None:
    shape = (5, 7, 3)
    pair = _pair(np.random.default_rng(3), shape)
    data = diagnose_bounds.pack(pair)
    assert data is not None and len(data) <= diagnose_bounds.packed_size(shape)
    back = diagnose_bounds.unpack(data, shape)
    assert back is not None and _equal(back, pair)
    assert back[1].nan[0, 0, 0] and back[0].lo.dtype == np.float32


def test_damaged_or_foreign_bounds_are_not_used() -> None:
    shape = (5, 7, 3)
    data = diagnose_bounds.pack(_pair(np.random.default_rng(4), shape))
    assert data is not None
    flipped = bytearray(data)
    flipped[-3] ^= 1
    assert diagnose_bounds.unpack(bytes(flipped), shape) is None
    assert diagnose_bounds.unpack(data[:-1], shape) is None
    assert diagnose_bounds.unpack(data, (7, 5, 3)) is None
    assert diagnose_bounds.unpack(b"not bounds", shape) is None


def test_float_bounds_are_not_kept() -> None:
    renders = [np.full((2, 2, 3), 0.3, np.float32), np.full((2, 2, 3), 0.31, np.float32)]
    assert diagnose_bounds.pack(model_bounds(renders, "float")) is None


def test_a_second_image_reads_the_candidates_bounds(
    tmp_path: Path, rtdemo: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    image = render_demo(rtdemo, CLASSIC, tmp_path / "q2.ppm", "-q", "--mode", "classic",
                        "--quirk", "Q2", size=(W, H))  # fmt: skip
    cache = RenderCache(tmp_path / "c")
    scene = load_scene(CLASSIC)

    def once() -> tuple[dict[str, object], list[str]]:
        forget_recent()
        with CandidateRenderer(CLASSIC, W, H, cache=cache) as render:
            d = diagnose(image, scene, render).as_dict()
        d.pop("seconds")
        return d, [name for name in render.seen if "camera turned" in name or " ulps]" in name]

    first, perturbed = once()
    assert perturbed and list(cache.derived_dir.glob("diagnose-bounds-*.bin"))
    for kept in cache.derived_dir.glob("diagnosis-*.json"):
        kept.unlink()  # searched again

    def no_bounds(*_a: object) -> None:
        raise AssertionError("bounds computed again")

    monkeypatch.setattr(diagnose_trials, "model_bounds", no_bounds)
    again, perturbed_again = once()
    assert again == first and perturbed_again == []
