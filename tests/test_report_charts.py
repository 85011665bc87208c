"""The report's charts: no label overlaps another label or a legend, however close the
points are (a chart printed in the PDF cannot be zoomed into)."""

from __future__ import annotations

import itertools
from typing import Any

from compare.report import figures


def _boxes(fig: Any) -> tuple[list[Any], list[Any]]:
    """The drawn extents of the point labels and of the legends."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [t.get_window_extent(renderer) for ax in fig.axes for t in ax.texts]
    legends = [
        lg.get_window_extent(renderer)
        for lg in [*fig.legends, *(a.get_legend() for a in fig.axes)]
        if lg
    ]
    return labels, legends


def _crowded_rows() -> list[dict[str, Any]]:
    """Points of several families a few per cent apart: where fixed offsets collided."""
    rows = []
    for i, (fam, spp) in enumerate(itertools.product(["demo paper cpu", "demo paper gl",
                                                      "mitsuba path llvm"], [1, 4, 16, 64])):  # fmt: skip
        rows.append({"key": f"k{i}", "label": f"r{i}", "family": fam, "spp": spp,
                     "seconds": 1.15**i, "one_minus_ssim": 0.3 + 0.002 * i,
                     "flip": 0.4 - 0.001 * i, "rmse": 0.1})  # fmt: skip
    # Two far points stretch the axes over decades, as a report's do: the rest crowd.
    for i, (t, e) in enumerate([(0.01, 1e-3), (100.0, 1.0)]):
        rows.append({"key": f"far{i}", "label": f"far{i}", "family": "mitsuba whitted llvm",
                     "spp": 1, "seconds": t, "one_minus_ssim": e, "flip": e, "rmse": 0.1})  # fmt: skip
    return rows


def test_speed_accuracy_labels_never_overlap_each_other_or_the_legend() -> None:
    rows = _crowded_rows()
    labels, legends = _boxes(figures.speed_accuracy_figure(rows))
    assert len(labels) == 2 * len(rows) and legends  # every point labelled, in both panels
    for a, b in itertools.combinations(labels, 2):
        assert not a.overlaps(b), (a, b)
    assert not any(lab.overlaps(leg) for lab in labels for leg in legends)


def test_ladder_time_labels_stay_clear_of_the_legend() -> None:
    steps = [{"step": f"+Q{i}", "flip": 0.5, "one_minus_ssim": 0.4, "seconds": 0.2,
              "changed_pixels": 5} for i in range(14)]  # fmt: skip
    labels, legends = _boxes(figures.ladder_figure(steps))
    assert len(labels) == 14 and legends
    assert not any(lab.overlaps(leg) for lab in labels for leg in legends)
