"""The search's score counted against a reference render (only the pixels that differ from
it judged again) is the score of judging every pixel, whatever differs: a few pixels, most
of them, NaN, -0, float noise in every pixel (most codes kept, so few pixels judged again),
values on the half-level boundaries, and for each way an image is encoded."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SCENES

from compare.diagnose.candidate import Candidate
from compare.diagnose.score import Target
from compare.judge.images import Image
from scene_model.scene import load_scene

H, W = 24, 32


def _render(rgb: np.ndarray) -> Image:
    ids = np.full((H, W), -1.0, np.float32)
    ids[4:20, 6:26] = 1.0
    ids[20:24, 0:5] = 2.0
    return Image(
        rgb=rgb, aovs={"id": ids, "depth": np.where(ids >= 0, 9.0, 0.0).astype(np.float32)}
    )


def _target(encoding: str, rng: np.random.Generator) -> Target:
    test = rng.random((H, W, 3), dtype=np.float32)
    target = Target(Image(rgb=test, encoding=encoding), load_scene(SCENES / "classic.json"))
    target.check(Candidate.of_mode("classic"), _render(test))
    return target


@pytest.mark.parametrize("encoding", ["linear", "srgb", "float"])
def test_counting_against_a_reference_changes_no_score(encoding: str) -> None:
    rng = np.random.default_rng(7)
    base = rng.random((H, W, 3), dtype=np.float32)
    variants = []
    for share in (0.0, 0.01, 0.2, 0.9):
        v = base.copy()
        hit = rng.random((H, W)) < share
        v[hit] = rng.random((int(hit.sum()), 3), dtype=np.float32)
        variants.append(v)
    odd = base.copy()
    odd[0, :4] = np.nan
    odd[1, :4] = -0.0
    odd[2, :4] = np.inf
    variants.append(odd)
    variants.append(np.nextafter(base, np.float32(2)))  # one ulp up in every value
    for v in variants:
        fresh = _target(encoding, np.random.default_rng(3))
        whole = fresh.score(v)  # its own reference: every pixel judged
        counted = _target(encoding, np.random.default_rng(3))
        counted.use_reference(base)
        assert counted.score(v) == whole


@pytest.mark.parametrize("step", [0.0, 0.5])
def test_values_crossing_a_level_boundary_by_an_ulp_are_judged_again(step: float) -> None:
    """A render one ulp either side of k / 255 or (k + 1/2) / 255 keeps its rounded code on
    one of them but not what a truncating writer stores: counted against its twin on the
    other side, against an image whose codes are k - 1, k and k + 1, the score is still the
    whole judging's."""
    rng = np.random.default_rng(5)
    k = rng.integers(1, 254, (H, W, 3))
    edge = ((k + step) / 255).astype(np.float32)
    below, above = np.nextafter(edge, np.float32(-1)), np.nextafter(edge, np.float32(2))
    image = ((k + rng.integers(-1, 2, (H, W, 3))) / 255).astype(np.float32)

    def target() -> Target:
        t = Target(Image(rgb=image, encoding="linear"), load_scene(SCENES / "classic.json"))
        t.check(Candidate.of_mode("classic"), _render(image))
        return t

    for ref, v in ((below, edge), (below, above), (above, below), (edge, below)):
        whole = target().score(v)
        counted = target()
        counted.use_reference(ref)
        assert counted.score(v) == whole
