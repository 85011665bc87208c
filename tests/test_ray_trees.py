"""compare/render/ray_trees.py: which pixels a page traces, and what it says when rtdemo
cannot trace them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from compare.pages.security import with_csp
from compare.pages.writer import environment
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
    # 4 from the first effect's share, its lone pixel from the second (whose unused 3 pass
    # on), then 3 more of the differing pixels: 8, each once, each differing.
    assert len(first) == len(set(first)) == 8
    assert all(differing[y, x] for x, y in first) and (30, 30) in first
    assert all(y < 20 for _, y in first[:4]) and first[4] == (30, 30)
    assert sample_differing(np.zeros((40, 60), bool), masks) == []


def test_overlapping_effects_and_no_effects_still_sample_differing_pixels_only() -> None:
    rng = np.random.default_rng(7)
    differing = rng.random((30, 40)) < 0.05
    everywhere = {"a": np.ones((30, 40), bool), "b": np.ones((30, 40), bool)}
    for masks in (everywhere, {}):
        picks = sample_differing(differing, masks)
        assert len(picks) == len(set(picks)) == 8
        assert all(differing[y, x] for x, y in picks)
    few = np.zeros((30, 40), bool)
    few[3, 4] = few[20, 9] = True
    assert sorted(sample_differing(few, everywhere)) == [(4, 3), (9, 20)]


def test_an_untraceable_pixel_is_said_not_raised(tmp_path: Path) -> None:
    scene = str(scene_path("classic"))
    out = trace_trees(scene, ["--mode", "classic"], [(500, 5)], (160, 120))
    assert "outside" in out["error"] and "exit 2" in out["error"]
    good = trace_trees(scene, ["--mode", "classic"], [(80, 60)], (160, 120))
    assert good["pixels"][0]["tree"]["hit"]["name"] == "glass"


def test_a_hostile_sphere_name_and_error_are_escaped_on_the_page() -> None:
    hostile = "</script><script>alert(1)</script>"
    node = {"kind": "camera", "depth": 0, "hit": {"sphere": 0, "name": hostile, "t": 1.0,
            "point": [0, 0, 1], "normal": [0, 0, -1], "inside": False}, "event": "diffuse",
            "fresnel": None, "shadow_rays": [], "children": [], "color": [0.5, 0.25, 0]}  # fmt: skip
    rt = {"width": 4, "height": 4, "pixels": [{"x": 1, "y": 2, "image": [0, 0, 0], "color": [0.5, 0.25, 0], "tree": node}]}  # fmt: skip
    macros = '{% from "_ray_tree.html.j2" import ray_marks %}'
    page = environment().from_string(macros + "{{ ray_marks(rt, pic, key) }}")
    html = page.render(rt=rt, pic='x.png" onerror="alert(1)', key="k")
    assert hostile not in html and "&lt;/script&gt;&lt;script&gt;alert(1)" in html
    assert 'onerror="' not in html and "(0.500, 0.250, 0.000)" in html
    assert "<script" not in with_csp("<html><head></head><body>" + html + "</body></html>")
