"""A candidate's exact-match bounds are kept between diagnoses (compare/judge/diagnose_kept.py):
read back they are the bounds computed, a damaged or foreign file is computed again, and a second
image judged against the same candidates renders none of its perturbed renders."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo

from compare.judge import diagnose_kept, diagnose_score, diagnose_trials
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
    data = diagnose_kept.pack_bounds(pair)
    assert data is not None and len(data) <= diagnose_kept.bounds_size(shape)
    back = diagnose_kept.unpack_bounds(data, shape)
    assert back is not None and _equal(back, pair)
    assert back[1].nan[0, 0, 0] and back[0].lo.dtype == np.float32


def test_damaged_or_foreign_bounds_are_not_used() -> None:
    shape = (5, 7, 3)
    data = diagnose_kept.pack_bounds(_pair(np.random.default_rng(4), shape))
    assert data is not None
    flipped = bytearray(data)
    flipped[-3] ^= 1
    assert diagnose_kept.unpack_bounds(bytes(flipped), shape) is None
    assert diagnose_kept.unpack_bounds(data[:-1], shape) is None
    assert diagnose_kept.unpack_bounds(data, (7, 5, 3)) is None
    assert diagnose_kept.unpack_bounds(b"not bounds", shape) is None


def test_packed_masks_read_back_as_found() -> None:
    rng = np.random.default_rng(5)
    masks = {"direct": rng.random((5, 7)) < 0.5, "edges": rng.random((5, 7)) < 0.2}
    data = diagnose_kept.pack_masks(masks)
    back = diagnose_kept.unpack_masks(data, (5, 7))
    assert back is not None and list(back) == ["direct", "edges"]
    assert all(np.array_equal(back[k], masks[k]) for k in masks)
    assert diagnose_kept.unpack_masks(data, (7, 5)) is None
    assert diagnose_kept.unpack_masks(data[:-1], (5, 7)) is None
    assert diagnose_kept.unpack_bounds(data, (5, 7)) is None  # masks are not bounds


def test_float_bounds_are_not_kept() -> None:
    renders = [np.full((2, 2, 3), 0.3, np.float32), np.full((2, 2, 3), 0.31, np.float32)]
    assert diagnose_kept.pack_bounds(model_bounds(renders, "float")) is None


def test_a_second_image_reads_what_the_candidates_gave(
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
        return d, list(render.seen)

    def perturbed(names: list[str]) -> list[str]:
        return [n for n in names if "camera turned" in n or " ulps]" in n]

    first, seen = once()
    assert perturbed(seen)
    for kind in ("bounds", "masks", "codes"):
        assert list(cache.derived_dir.glob(f"diagnose-{kind}-*.bin")), kind
    for kept in cache.derived_dir.glob("diagnosis-*.json"):
        kept.unlink()  # searched again

    def again_(what: str) -> object:
        def fail(*_a: object) -> None:
            raise AssertionError(f"{what} computed again")

        return fail

    monkeypatch.setattr(diagnose_trials, "model_bounds", again_("bounds"))
    monkeypatch.setattr(diagnose_score, "effect_masks", again_("effect masks"))
    again, seen_again = once()
    assert again == first and perturbed(seen_again) == []
    # Only the renders the search keeps (the modes, for the mirror test and FLIP) are read.
    assert len(seen_again) <= 8 < int(str(first["renders"]))


def test_codes_read_back_as_made() -> None:
    rng = np.random.default_rng(6)
    rgb = rng.random((40, 3), np.float32) * 1.4 - 0.2
    rgb[::7] = np.float32(0.5) / np.float32(255.0)  # exactly half a level
    for kind in ("linear", "srgb"):
        codes = diagnose_score.Codes.of(rgb, kind, values=False)
        back = diagnose_kept.unpack_codes(diagnose_kept.pack_codes(codes), len(rgb))
        assert back is not None and back.rgb is None and back.digest == codes.digest
        assert np.array_equal(back.enc, codes.enc) and np.array_equal(back.halves, codes.halves)
        assert diagnose_kept.unpack_codes(diagnose_kept.pack_codes(codes), len(rgb) + 1) is None
