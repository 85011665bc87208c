"""Matplotlib figures for the report: maps with colour bars and the charts."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from compare.escape import mathtext_literal
from compare.judge.pareto import pareto_front
from compare.judge.sentences import luminance
from safe_files.paths import atomic_output


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: Path) -> None:
    try:
        with atomic_output(path) as tmp:
            fig.savefig(tmp, dpi=100, bbox_inches="tight", format="png")
    finally:
        _plt().close(fig)


def map_figure(
    data: np.ndarray, path: Path, *, title: str, cmap: str, vmin: float, vmax: float, label: str
) -> None:
    plt = _plt()
    h, w = data.shape
    fig, ax = plt.subplots(figsize=(6.4, 6.4 * h / w + 0.6))
    im = ax.imshow(data, cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
    ax.set_title(mathtext_literal(title), fontsize=10)  # titles carry user labels
    ax.axis("off")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02, label=mathtext_literal(label))
    _save(fig, path)


def signed_difference(ref: np.ndarray, test: np.ndarray, path: Path, title: str) -> None:
    diff = luminance(np.nan_to_num(test)) - luminance(ref)
    finite = np.abs(diff[np.isfinite(diff)])
    lim = float(np.percentile(finite, 99)) if finite.size else 1.0
    lim = max(lim, 1e-3)
    map_figure(
        np.clip(diff, -lim, lim),
        path,
        title=title,
        cmap="coolwarm",
        vmin=-lim,
        vmax=lim,
        label="test - reference (linear luminance)",
    )


def speed_accuracy_chart(rows: list[dict[str, Any]], path: Path) -> None:
    _save(speed_accuracy_figure(rows), path)


def speed_accuracy_figure(rows: list[dict[str, Any]]) -> Any:
    """Two log-log panels (1 - SSIM and FLIP against time), each point labelled with its spp
    where no other label or point is; the legend below both, off the data."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    families = sorted({r["family"] for r in rows})
    for ax, key, name in (
        (axes[0], "one_minus_ssim", "1 - SSIM"),
        (axes[1], "flip", "mean FLIP (LDR)"),
    ):
        points = _scatter_families(ax, rows, families, key)
        front = pareto_front(rows, key)
        if len(front) > 1:
            ax.step(
                [r["seconds"] for r in front],
                [r[key] for r in front],
                where="post",
                color="k",
                lw=1,
                alpha=0.6,
                label="Pareto front",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("render time, s (log)")
        ax.set_ylabel(f"{name} vs converged reference (log)")
        ax.grid(True, which="both", alpha=0.3)
        ax.autoscale_view()
        label_points(ax, points)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(5, len(labels)), fontsize=8)
    fig.suptitle("Speed against accuracy (numbers at points: samples per pixel)", fontsize=11)
    fig.tight_layout(rect=(0, 0.06 + 0.04 * (len(labels) // 5), 1, 1))
    return fig


_MARKERS = "osD^v<>ph*"


def _scatter_families(
    ax: Any, rows: list[dict[str, Any]], families: list[str], key: str
) -> list[tuple[float, float, str]]:
    """One marker style per family; the (x, y, spp label) of every point drawn."""
    points = []
    for i, fam in enumerate(families):
        sel = [r for r in rows if r["family"] == fam and r[key] > 0 and r["seconds"] > 0]
        if sel:
            xs, ys = [r["seconds"] for r in sel], [r[key] for r in sel]
            ax.scatter(xs, ys, marker=_MARKERS[i % len(_MARKERS)], label=fam, s=40)
            points += [(x, y, str(r["spp"])) for x, y, r in zip(xs, ys, sel, strict=True)]
    return points


# Where a point's label may go, in points from the point: right, then the other corners,
# then further out.
_LABEL_OFFSETS = [(4, 3), (4, -9), (-10, 3), (-10, -9), (0, 8), (0, -14), (8, 10), (8, -16)]


def label_points(ax: Any, points: list[tuple[float, float, str]], fontsize: float = 7) -> None:
    """Labels each point at the first offset whose box overlaps no label placed before and
    no marker; a label with no free place is left out (its value is in the page's table)."""
    scale = ax.figure.dpi / 72  # points to pixels
    centres = [ax.transData.transform((x, y)) for x, y, _ in points]
    taken: list[tuple[float, float, float, float]] = [
        (cx - 5 * scale, cy - 5 * scale, cx + 5 * scale, cy + 5 * scale) for cx, cy in centres
    ]
    for (x, y, text), (cx, cy) in zip(points, centres, strict=True):
        w, h = 0.62 * fontsize * len(text) * scale, fontsize * scale
        for dx, dy in _LABEL_OFFSETS:
            box = (cx + dx * scale, cy + dy * scale, cx + dx * scale + w, cy + dy * scale + h)
            own = (cx - 5 * scale, cy - 5 * scale, cx + 5 * scale, cy + 5 * scale)
            if not any(_overlap(box, t) for t in taken if t != own):
                taken.append(box)
                ax.annotate(
                    text, (x, y), fontsize=fontsize, xytext=(dx, dy), textcoords="offset points"
                )
                break


def _overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def convergence_chart(rows: list[dict[str, Any]], path: Path) -> dict[str, float]:
    """RMSE (display) against spp, log-log, with the fitted slope per family."""
    fig, slopes = convergence_figure(rows)
    _save(fig, path)
    return slopes


def convergence_figure(rows: list[dict[str, Any]]) -> tuple[Any, dict[str, float]]:
    """The convergence figure and its fitted slopes; the legend beside the axes (lines of
    equal error would otherwise run under it)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.8))
    slopes = {}
    for fam in sorted({r["family"] for r in rows}):
        sel = sorted(
            (r for r in rows if r["family"] == fam and r["rmse"] > 0), key=lambda r: r["spp"]
        )
        if len({r["spp"] for r in sel}) < 2:
            continue
        x = np.log([r["spp"] for r in sel])
        y = np.log([r["rmse"] for r in sel])
        slope, _intercept = np.polyfit(x, y, 1)
        slopes[fam] = float(slope)
        ax.loglog(
            [r["spp"] for r in sel],
            [r["rmse"] for r in sel],
            "o-",
            label=f"{fam} (slope {slope:.2f})",
        )
    ax.set_xlabel("samples per pixel (log)")
    ax.set_ylabel("RMSE (display) vs converged reference (log)")
    ax.grid(True, which="both", alpha=0.3)
    if slopes:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title("Convergence (Monte Carlo noise alone gives slope -0.5)", fontsize=10)
    return fig, slopes


def ladder_chart(steps: list[dict[str, Any]], path: Path) -> None:
    _save(ladder_figure(steps), path)


def ladder_figure(steps: list[dict[str, Any]]) -> Any:
    """FLIP and 1 - SSIM per step; a step whose render equals the one before (a quirk with
    nothing to act on in this scene) is drawn pale and labelled "no change". The legend
    stands beside the axes, where no bar or time label can be."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 4.2))
    x = np.arange(len(steps))
    alpha = [0.35 if s.get("changed_pixels") == 0 else 1.0 for s in steps]
    for offset, key, label, colour in (
        (-0.2, "flip", "mean FLIP (LDR)", "C0"),
        (0.2, "one_minus_ssim", "1 - SSIM", "C1"),
    ):
        bars = ax.bar(x + offset, [s[key] for s in steps], 0.4, label=label, color=colour)
        for bar, a in zip(bars, alpha, strict=True):
            bar.set_alpha(a)
    ax.set_xticks(x, [s["step"] for s in steps], rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("error vs converged reference")
    for i, s in enumerate(steps):
        if s.get("changed_pixels") == 0:  # upright from the axis: inside the plot, no overlap
            ax.annotate(
                "no change", (i, 0), fontsize=7, ha="center", va="bottom", xytext=(0, 3),
                textcoords="offset points", color="0.3", rotation=90,
            )  # fmt: skip
            continue
        ax.annotate(
            f"{s['seconds']:.2f} s",
            (i, max(s["flip"], s["one_minus_ssim"])),
            fontsize=7,
            ha="center",
            xytext=(0, 3),
            textcoords="offset points",
        )
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(
        "Ablation ladder: the paper's program with quirks fixed one after another\n"
        "(pale: the quirk changes nothing in this scene)",
        fontsize=10,
    )
    return fig
