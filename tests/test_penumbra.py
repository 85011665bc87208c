"""compare.judge.penumbra: the demo's difference from the area-light reference, inside and outside
the penumbrae."""

from __future__ import annotations

import numpy as np

from compare.judge.penumbra import penumbra_numbers


def test_a_point_light_demo_differs_only_inside_the_penumbra() -> None:
    point = np.full((20, 30, 3), 0.5, np.float32)
    area = point.copy()
    area[5:10, 10:20] = 0.3  # the soft edge: 50 pixels
    demo = point.copy()
    demo[0, 0] = 0.5 + 1.0 / 255.0  # sampling noise below the threshold, outside
    n = penumbra_numbers(point, area, demo)
    assert n["penumbra_pixels"] == 50
    assert abs(n["penumbra_share"] - 50 / 600) < 1e-9
    assert n["error_share_in_penumbra"] > 0.98
    assert n["differing_pixels_outside_penumbra"] == 0
    assert abs(n["mae_vs_area_inside"] - 0.2) < 1e-6 and n["mae_vs_point_inside"] == 0.0
    assert n["mae_vs_area_outside"] == n["mae_vs_point_outside"] > 0


def test_a_difference_outside_the_penumbra_is_counted() -> None:
    point = np.zeros((10, 10, 3), np.float32)
    area = point.copy()
    area[0:2, 0:2] = 0.2
    demo = point.copy()
    demo[8, 8] = 0.9  # e.g. a wrong highlight: not a penumbra
    n = penumbra_numbers(point, area, demo)
    assert n["differing_pixels_outside_penumbra"] == 1
    assert n["error_share_in_penumbra"] < 0.6


def test_references_that_agree_everywhere_give_no_penumbra_and_no_nan() -> None:
    """Point and area references of a scene whose shadows cannot differ: no penumbra pixel,
    every number finite (the report skips the study for a scene without a light; a lit scene
    with no visible shadow edge ends up here)."""
    ref = np.full((6, 8, 3), 0.7, np.float32)
    demo = ref.copy()
    demo[2, 3] = 0.9
    n = penumbra_numbers(ref, ref.copy(), demo)
    assert n["penumbra_pixels"] == 0 and n["penumbra_share"] == 0.0
    assert n["error_share_in_penumbra"] == 0.0 and n["mae_vs_area_inside"] == 0.0
    assert n["differing_pixels_outside_penumbra"] == 1
    assert all(np.isfinite(v) for v in n.values())
