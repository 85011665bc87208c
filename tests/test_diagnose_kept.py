"""A candidate's exact-match bounds are kept between diagnoses (compare/diagnose/kept.py):
read back they are the bounds computed, a damaged or foreign file is computed again, and a second
image judged against the same candidates renders none of its perturbed renders."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, diagnosed, render_demo

from compare.diagnose import flip as diagnose_flip
from compare.diagnose import kept as diagnose_kept
from compare.diagnose import memo as diagnose_memo
from compare.diagnose import score as diagnose_score
from compare.diagnose import trials as diagnose_trials
from compare.diagnose.candidate import Candidate
from compare.judge.exact_match import Bounds, model_bounds
from compare.judge.images import Image
from compare.render.cache import RenderCache

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

    def once() -> tuple[dict[str, object], list[str]]:
        return diagnosed(image, CLASSIC, (W, H), cache)

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


def _file(head: object, payload: bytes) -> bytes:
    """A kept file with a valid check (its CRC-32) around any head: what a planted file can
    look like."""
    body = (head if isinstance(head, bytes) else json.dumps(head).encode()) + b"\n" + payload
    return b"%08x\n" % zlib.crc32(body) + body


@pytest.mark.parametrize(
    "head",
    [
        b"[" * 3000,  # nested past the recursion limit
        {"format": diagnose_kept.KEPT_FORMAT, "kind": "masks", "shape": 5, "names": ["direct"]},
        {"format": diagnose_kept.KEPT_FORMAT, "kind": "masks", "shape": [5, 7], "names": [[1]]},
        {"format": diagnose_kept.KEPT_FORMAT, "kind": "masks", "shape": None, "names": None},
        {"format": diagnose_kept.KEPT_FORMAT, "kind": "masks", "shape": [5, 7], "names": ["x"]},
    ],
)
def test_planted_mask_files_are_not_used(head: object) -> None:
    assert diagnose_kept.unpack_masks(_file(head, bytes(5)), (5, 7)) is None


def test_masks_with_an_empty_region_or_a_name_twice_are_not_used() -> None:
    full = np.ones((5, 7), bool)
    empty = diagnose_kept.pack_masks({"direct": full, "edges": np.zeros((5, 7), bool)})
    assert diagnose_kept.unpack_masks(empty, (5, 7)) is None
    head = {"format": diagnose_kept.KEPT_FORMAT, "kind": "masks", "shape": [5, 7]}
    twice = _file({**head, "names": ["direct", "direct"]}, 2 * np.packbits(full).tobytes())
    assert diagnose_kept.unpack_masks(twice, (5, 7)) is None


def test_planted_codes_out_of_range_are_not_used() -> None:
    head = {"format": diagnose_kept.KEPT_FORMAT, "kind": "codes", "pixels": 2, "digest": "0" * 40}
    assert diagnose_kept.unpack_codes(_file(head, bytes(6) + b"\x02"), 2) is None  # length
    payload = bytes(6) + bytes([0, 0, 2, 0, 0, 0])  # a half-level offset of 2
    assert diagnose_kept.unpack_codes(_file(head, payload), 2) is None
    assert diagnose_kept.unpack_codes(_file(head, bytes(12)), 2) is not None
    assert diagnose_kept.unpack_codes(_file({**head, "digest": 7}, bytes(12)), 2) is None


def test_names_are_the_same_in_every_process() -> None:
    """A candidate's set fields are named in one order whatever the hash seed."""
    code = (
        "from compare.diagnose.candidate import Candidate\n"
        "from compare.diagnose.kept import kept_name\n"
        "c = Candidate.of_mode('classic').with_mistake('no_offset', True)"
        ".with_mistake('double_gamma', True).with_effect('shadows', False)"
        ".with_effect('refraction', False)\n"
        "print(kept_name('codes', 'id', c, 'linear'))\n"
    )
    names = {
        subprocess.run(
            [sys.executable, "-c", code],
            env={**os.environ, "PYTHONHASHSEED": seed},
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for seed in ("1", "2", "3", "4")
    }
    assert len(names) == 1


def test_a_png_after_a_ppm_of_the_same_program_is_diagnosed_as_in_a_fresh_cache(
    tmp_path: Path, rtdemo: str
) -> None:
    """The two encodings share the renders but never each other's codes or bounds."""
    args = ("-q", "--mode", "classic", "--quirk", "Q2")
    ppm = render_demo(rtdemo, CLASSIC, tmp_path / "q2.ppm", *args, size=(W, H))
    png = render_demo(rtdemo, CLASSIC, tmp_path / "q2.png", *args, size=(W, H))

    shared = tmp_path / "shared"
    diagnosed(ppm, CLASSIC, (W, H), shared)
    in_shared = diagnosed(png, CLASSIC, (W, H), shared)[0]
    assert in_shared == diagnosed(png, CLASSIC, (W, H), tmp_path / "fresh")[0]


def test_a_newer_guess_replaces_a_flip_not_begun() -> None:
    pool = ThreadPoolExecutor(max_workers=1)
    gate = threading.Event()
    pool.submit(gate.wait)  # the background thread is busy
    flips = diagnose_flip.Flips(None, pool)
    a, b = Candidate.of_mode("classic"), Candidate.of_mode("paper")
    rgb = np.full((8, 8, 3), 0.5, np.float32)
    masks = {"direct": np.ones((8, 8), bool)}
    flips.guess(a, rgb, rgb, masks)
    flips.guess(b, rgb * 0.5, rgb, masks)
    assert a not in flips.jobs and b in flips.jobs
    gate.set()
    assert flips.means(b, rgb * 0.5, rgb, masks)["direct"] > 0
    assert flips.means(a, rgb, rgb, masks)["direct"] == 0  # asked again: computed then
    pool.shutdown()


def test_deeply_nested_stored_texts_are_searched_again() -> None:
    """The diagnosis and FLIP records beside the kept files: a planted one is ignored."""

    class Planted:
        identity = "x"

        def get(self, name: str) -> str:
            return "[" * 5000

    image = Image(np.zeros((2, 2, 3), np.float32), "x.ppm")
    assert diagnose_memo.load(Planted(), "n", image, 0.0) is None  # type: ignore[arg-type]
    assert (
        diagnose_flip._stored_means(Planted().get("n"), {"direct": np.ones((2, 2), bool)}) is None
    )
