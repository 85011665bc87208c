"""Grading a render against the reference, per effect: pass/fail, a score, and sentences.

Defaults (a rubric may override them): an effect passes with mean LDR FLIP <= 0.10 over its
pixels and SSIM >= 0.5. FLIP decides; SSIM is only a floor against broken structure, because
display-space SSIM collapses on faint noise in near-black regions (a render with linear noise of
sigma 0.002 scores SSIM 0.65 in the classic scene's shadows at FLIP 0.04). An effect's score is 100 (1 - FLIP / 0.5), clamped to [0, 100]: a
FLIP of 0.5 (half the perceptual range) scores nothing. The overall score is the mean of the
effect scores weighted by their pixel counts; the verdict passes when every effect does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

EFFECT_WORDS = {
    "background": "background", "emitter": "the light", "direct": "directly lit surfaces",
    "shadow": "shadows", "reflection": "reflections", "refraction": "refraction",
    "edges": "silhouette edges",
}


@dataclass(frozen=True)
class EffectRule:
    min_ssim: float = 0.5
    max_flip: float = 0.10
    weight: float = 1.0  # multiplies the pixel-count weight in the overall score


DEFAULT_RULES: dict[str, EffectRule] = {}
FLIP_AT_ZERO_SCORE = 0.5


def effect_score(flip: float, flip_at_zero: float = FLIP_AT_ZERO_SCORE) -> float:
    return float(np.clip(100.0 * (1.0 - flip / flip_at_zero), 0.0, 100.0))


def grade(per_effect: dict[str, dict[str, Any]], rules: dict[str, EffectRule] | None = None, *,
          flip_at_zero: float = FLIP_AT_ZERO_SCORE, pass_score: float | None = None) -> dict[str, Any]:
    """per_effect: name -> {"pixels", "ssim", "flip_ldr", ...} -> verdict dictionary. With
    `pass_score`, the overall score must also reach it."""
    rules = rules or DEFAULT_RULES
    effects = {}
    total_w = 0.0
    total = 0.0
    for name, m in per_effect.items():
        rule = rules.get(name, EffectRule())
        ssim, flip = m["ssim"], m["flip_ldr"]
        ok = (ssim is not None and ssim >= rule.min_ssim) and flip <= rule.max_flip
        reasons = []
        if ssim is None or not ssim >= rule.min_ssim:
            reasons.append(f"SSIM {ssim:.3f} < {rule.min_ssim}" if ssim is not None else "SSIM undefined")
        if not flip <= rule.max_flip:
            reasons.append(f"FLIP {flip:.3f} > {rule.max_flip}")
        score = effect_score(flip, flip_at_zero)
        w = m["pixels"] * rule.weight
        total_w += w
        total += w * score
        effects[name] = {"status": "pass" if ok else "fail", "score": score, "reasons": reasons,
                         "pixels": m["pixels"], "ssim": ssim, "flip": flip,
                         "rule": {"min_ssim": rule.min_ssim, "max_flip": rule.max_flip, "weight": rule.weight}}
    overall = total / total_w if total_w else 0.0
    status = "pass" if effects and all(e["status"] == "pass" for e in effects.values()) else "fail"
    if pass_score is not None and overall < pass_score:
        status = "fail"
    return {"status": status, "score": overall, "effects": effects, "flip_at_zero_score": flip_at_zero,
            "pass_score": pass_score}


def luminance(rgb: np.ndarray) -> np.ndarray:
    return np.asarray(0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2])


def difference_sentences(ref: np.ndarray, test: np.ndarray, masks: dict[str, np.ndarray],
                         per_effect: dict[str, dict[str, Any]], label: str, n: int = 3) -> list[str]:
    """The n largest differences, by FLIP times the share of the image, as sentences."""
    h, w = ref.shape[:2]
    ranked = sorted(per_effect.items(), key=lambda kv: kv[1]["flip_ldr"] * kv[1]["pixels"], reverse=True)
    out = []
    for name, m in ranked[:n]:
        mask = masks[name]
        lr = float(np.nanmean(np.clip(luminance(ref)[mask], 0, None)))
        lt = float(np.nanmean(np.clip(luminance(np.nan_to_num(test))[mask], 0, None)))
        share = 100.0 * m["pixels"] / (h * w)
        if lr > 1e-6:
            change = 100.0 * (lt / lr - 1.0)
            how = (f"{abs(change):.0f} % {'brighter' if change > 0 else 'darker'} than the reference"
                   if abs(change) >= 0.5 else "as bright as the reference")
        else:
            how = "bright where the reference is black" if lt > 1e-6 else "black, like the reference"
        out.append(f"{EFFECT_WORDS.get(name, name).capitalize()} ({share:.1f} % of the image): {label} is "
                   f"{how} (mean linear luminance {lt:.3g} vs {lr:.3g}); FLIP {m['flip_ldr']:.3f}, "
                   f"SSIM {m['ssim']:.3f}.")
    return out


def contribution_sentence(effect: str, demo_full: np.ndarray, demo_without: np.ndarray,
                          ref_full: np.ndarray, ref_without: np.ndarray, label: str) -> dict[str, Any]:
    """Compares what one effect adds (or, for shadows, removes) on each side."""
    d = float(np.nansum(luminance(np.nan_to_num(demo_full)) - luminance(np.nan_to_num(demo_without))))
    r = float(np.nansum(luminance(ref_full) - luminance(ref_without)))
    data: dict[str, Any] = {"effect": effect, "demo_contribution": d, "reference_contribution": r}
    word = EFFECT_WORDS.get(effect, effect)
    if abs(r) < 1e-6 * max(1.0, abs(d)):
        data["ratio"] = None
        data["sentence"] = (f"The reference shows no {word}; {label}'s {word} "
                            f"{'add' if d >= 0 else 'remove'} {abs(d):.3g} (summed linear luminance).")
        return data
    ratio = d / r
    data["ratio"] = ratio
    pct = 100.0 * (abs(ratio) - 1.0)
    if effect == "shadows":
        verb = "remove" if r < 0 else "add"
        data["sentence"] = (f"{label.capitalize()}'s shadows {verb} {abs(pct):.0f} % "
                            f"{'more' if pct > 0 else 'less'} light than the reference's.")
    else:
        data["sentence"] = (f"{label.capitalize()}'s {word} {'is' if effect == 'refraction' else 'are'} "
                            f"{abs(pct):.0f} % too {'bright' if pct > 0 else 'dark'}.")
    if ratio < 0:
        data["sentence"] += " (opposite sign: it removes light where the reference adds it)"
    return data
