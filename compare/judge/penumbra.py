"""Point lights against sphere (area) lights: is the demo's difference confined to penumbrae?

The penumbrae are where the two Mitsuba references, point lights and area lights, differ by
more than 2/255. The demo (physical mode, point lights) is compared with the area-light
reference inside and outside them, and with the point-light reference as the yardstick of
pixel-sampling noise: outside the penumbrae the area light should add nothing to it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

THRESHOLD = 2.0 / 255.0


def penumbra_numbers(
    point_ref: np.ndarray, area_ref: np.ndarray, demo: np.ndarray
) -> dict[str, Any]:
    """All arguments are H x W x 3 linear RGB of the same pixel grid."""

    def display(x: np.ndarray) -> np.ndarray:
        return np.asarray(np.clip(np.nan_to_num(x), 0.0, 1.0))

    soft = np.abs(area_ref - point_ref).max(-1) > THRESHOLD
    err = np.abs(np.nan_to_num(demo) - area_ref).mean(-1)
    total = float(err.sum())
    vs_area = np.abs(display(demo) - display(area_ref)).mean(-1)
    vs_point = np.abs(display(demo) - display(point_ref)).mean(-1)

    def mean(values: np.ndarray, where: np.ndarray) -> float:
        return float(values[where].mean()) if where.any() else 0.0

    return {
        "penumbra_pixels": int(soft.sum()),
        "penumbra_share": float(soft.mean()),
        "error_share_in_penumbra": float(err[soft].sum()) / total if total > 0 else 0.0,
        "differing_pixels_outside_penumbra": int(
            ((np.abs(display(demo) - display(area_ref)).max(-1) > THRESHOLD) & ~soft).sum()
        ),
        # mean |demo - reference| per pixel, displayed values, inside and outside
        "mae_vs_area_inside": mean(vs_area, soft),
        "mae_vs_point_inside": mean(vs_point, soft),
        "mae_vs_area_outside": mean(vs_area, ~soft),
        "mae_vs_point_outside": mean(vs_point, ~soft),
    }
