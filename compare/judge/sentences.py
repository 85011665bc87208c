"""Sentences a person reads: the largest differences of an evaluation, and what one effect adds
on each side of a comparison."""

from __future__ import annotations

from typing import Any

import numpy as np

from compare.judge.metrics import Metrics

EFFECT_WORDS = {
    "background": "background",
    "emitter": "the light",
    "direct": "directly lit surfaces",
    "shadow": "shadows",
    "reflection": "reflections",
    "refraction": "refraction",
    "edges": "silhouette edges",
}


def luminance(rgb: np.ndarray) -> np.ndarray:
    return np.asarray(0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2])


def difference_sentences(
    ref: np.ndarray,
    test: np.ndarray,
    masks: dict[str, np.ndarray],
    per_effect: dict[str, Metrics],
    label: str,
    n: int = 3,
) -> list[str]:
    """The n largest differences, by FLIP times the share of the image, as sentences."""
    h, w = ref.shape[:2]
    ranked = sorted(per_effect.items(), key=lambda kv: kv[1].flip_ldr * kv[1].pixels, reverse=True)
    out = []
    for name, m in ranked[:n]:
        mask = masks[name]
        lr = float(np.nanmean(np.clip(luminance(ref)[mask], 0, None)))
        lt = float(np.nanmean(np.clip(luminance(np.nan_to_num(test))[mask], 0, None)))
        share = 100.0 * m.pixels / (h * w)
        if lr > 1e-6:
            change = 100.0 * (lt / lr - 1.0)
            how = (
                f"{abs(change):.0f} % {'brighter' if change > 0 else 'darker'} than the reference"
                if abs(change) >= 0.5
                else "as bright as the reference"
            )
        else:
            how = (
                "bright where the reference is black" if lt > 1e-6 else "black, like the reference"
            )
        out.append(
            f"{EFFECT_WORDS.get(name, name).capitalize()} ({share:.1f} % of the image): {label} is "
            f"{how} (mean linear luminance {lt:.3g} vs {lr:.3g}); FLIP {m.flip_ldr:.3f}, "
            f"SSIM {m.ssim:.3f}."
        )
    return out


def contribution_sentence(
    effect: str,
    demo_full: np.ndarray,
    demo_without: np.ndarray,
    ref_full: np.ndarray,
    ref_without: np.ndarray,
    label: str,
) -> dict[str, Any]:
    """Compares what one effect adds (or, for shadows, removes) on each side."""
    d = float(
        np.nansum(luminance(np.nan_to_num(demo_full)) - luminance(np.nan_to_num(demo_without)))
    )
    r = float(np.nansum(luminance(ref_full) - luminance(ref_without)))
    data: dict[str, Any] = {"effect": effect, "demo_contribution": d, "reference_contribution": r}
    word = EFFECT_WORDS.get(effect, effect)
    if abs(r) < 1e-6 * max(1.0, abs(d)):
        data["ratio"] = None
        data["sentence"] = (
            f"The reference shows no {word}; {label}'s {word} "
            f"{'add' if d >= 0 else 'remove'} {abs(d):.3g} (summed linear luminance)."
        )
        return data
    ratio = d / r
    data["ratio"] = ratio
    pct = 100.0 * (abs(ratio) - 1.0)
    if effect == "shadows":
        verb = "remove" if r < 0 else "add"
        data["sentence"] = (
            f"{label.capitalize()}'s shadows {verb} {abs(pct):.0f} % "
            f"{'more' if pct > 0 else 'less'} light than the reference's."
        )
    else:
        data["sentence"] = (
            f"{label.capitalize()}'s {word} {'is' if effect == 'refraction' else 'are'} "
            f"{abs(pct):.0f} % too {'bright' if pct > 0 else 'dark'}."
        )
    if ratio < 0:
        data["sentence"] += " (opposite sign: it removes light where the reference adds it)"
    return data
