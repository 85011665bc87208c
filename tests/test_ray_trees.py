"""compare/render/ray_trees.py: which pixels a page traces, and what it says when rtdemo
cannot trace them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from compare.render.ray_trees import sample_differing, trace_trees
from scene_model.builtin import scene_path


def test_the_sample_is_spread_over_the_differing_effects_and_always_the_same() -> None:
    differing = np.zeros((40, 60), bool)
    differing[5:10, 5:50] = True  # 225 px of one effect
    differing[30, 30] = True  # one pixel of another
    masks = {"direct": np.zeros((40, 60), bool), "shadow": np.zeros((40, 60), bool)}
    masks["direct"][:20] = True
    masks["shadow"][20:] = True
    first = sample_differing(differing, masks)
    assert first == sample_differing(differing.copy(), masks)
    assert len(first) == 5  # 4 from the first effect's share, then the lone pixel
    assert all(differing[y, x] for x, y in first) and (30, 30) in first
    assert sample_differing(np.zeros((40, 60), bool), masks) == []


def test_an_untraceable_pixel_is_said_not_raised(tmp_path: Path) -> None:
    scene = str(scene_path("classic"))
    out = trace_trees(scene, ["--mode", "classic"], [(500, 5)], (160, 120))
    assert "outside" in out["error"] and "exit 2" in out["error"]
    good = trace_trees(scene, ["--mode", "classic"], [(80, 60)], (160, 120))
    assert good["pixels"][0]["tree"]["hit"]["name"] == "glass"
