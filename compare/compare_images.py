"""`rtval compare REF TEST`: every metric, globally and per effect, and a verdict."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare.effects import EFFECTS, effect_masks
from compare.files import write_atomic
from compare.images import Image, ImageError, read_image, write_png
from compare.judge import Tolerances, Verdict, diff_image, judge
from compare.metrics import Maps, Metrics, check_same_size, compute_maps, compute_metrics, display
from mitsuba_ref.scene import Scene


@dataclass
class Comparison:
    ref: Image
    test: Image
    maps: Maps
    metrics: Metrics
    verdict: Verdict
    tolerances: Tolerances
    per_effect: dict[str, tuple[Metrics, Verdict]] = field(default_factory=dict)
    aov_source: str | None = None

    def as_dict(self) -> dict[str, Any]:
        h, w = self.ref.shape
        return {
            "reference": self.ref.path, "test": self.test.path, "size": [w, h],
            "encodings": {"reference": self.ref.encoding, "test": self.test.encoding},
            "hdr": self.maps.flip_hdr is not None,
            "status": self.verdict.status, "exit_code": self.verdict.exit_code,
            "reasons": self.verdict.reasons, "failing_pixels": self.verdict.failing_pixels,
            "warning_pixels": self.verdict.warning_pixels,
            "tolerances": self.tolerances.as_dict(), "metrics": self.metrics.as_dict(),
            "per_effect_aovs_from": self.aov_source,
            "per_effect": {k: {"status": v.status, "reasons": v.reasons, **m.as_dict()}
                           for k, (m, v) in self.per_effect.items()},
        }


def load_mask(path: str | Path, shape: tuple[int, int]) -> np.ndarray:
    img = read_image(path, encoding="linear")
    if img.shape != shape:
        raise ImageError(f"{path}: mask is {img.shape[1]}x{img.shape[0]}, images are "
                         f"{shape[1]}x{shape[0]}")
    return np.asarray(img.rgb.mean(axis=-1) > 0.5)


def run_comparison(ref: Image, test: Image, *, tolerances: Tolerances = Tolerances(),
                   mask: np.ndarray | None = None, scene: Scene | None = None,
                   aovs: Image | None = None) -> Comparison:
    check_same_size(ref.rgb, test.rgb, ref.path or "reference", test.path or "test")
    hdr = ref.encoding == "float" or test.encoding == "float"
    maps = compute_maps(ref.rgb, test.rgb, hdr=hdr)
    metrics = compute_metrics(ref.rgb, test.rgb, maps, mask=mask, threshold=tolerances.fail)
    verdict = judge(metrics, maps, tolerances, mask)
    result = Comparison(ref, test, maps, metrics, verdict, tolerances)
    if scene is not None:
        source = next((im for im in (aovs, ref, test) if im is not None and "id" in im.aovs), None)
        if source is None:
            raise ImageError("per-effect metrics need id and depth AOVs: neither image has them "
                             "(give --aovs FILE.exr, e.g. a demo render of the scene)")
        if source.shape != ref.shape:
            raise ImageError(f"{source.path}: AOVs are {source.shape[1]}x{source.shape[0]}, images "
                             f"are {ref.shape[1]}x{ref.shape[0]}")
        result.aov_source = source.path
        masks = effect_masks(scene, source.aovs["id"], source.aovs["depth"])
        for name in EFFECTS:
            region = masks[name] if mask is None else masks[name] & mask
            if not region.any():
                continue
            m = compute_metrics(ref.rgb, test.rgb, maps, mask=region, threshold=tolerances.fail)
            result.per_effect[name] = (m, judge(m, maps, tolerances, region))
    return result


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return f"{v:.5g}"
    return str(v)


def table(c: Comparison) -> str:
    m = c.metrics
    rows = [
        ("SSIM", m.ssim, "display"), ("FLIP (LDR, 67 ppd)", m.flip_ldr, "display"),
        ("FLIP (HDR, 67 ppd)", m.flip_hdr, "linear"), ("PSNR dB", m.psnr_db, "display"),
        ("RMSE", m.rmse_display, "display"), ("MAE", m.mae_display, "display"),
        ("RMSE", m.rmse_linear, "linear"), ("MAE", m.mae_linear, "linear"),
        ("relative MSE", m.rel_mse_linear, "linear"),
        ("max error", f"{_fmt(m.max_error_linear)} at {m.max_error_at}", "linear"),
        (f"pixels over {m.threshold:.4g}", m.over_threshold, "display"),
        ("NaN / Inf (ref)", f"{m.nan_ref} / {m.inf_ref}", ""),
        ("NaN / Inf (test)", f"{m.nan_test} / {m.inf_test}", ""),
    ]
    h, w = c.ref.shape
    lines = [f"reference {c.ref.path} ({c.ref.encoding}), test {c.test.path} ({c.test.encoding}), {w}x{h}",
             f"{'metric':<24} {'value':>28}  space"]
    lines += [f"{name:<24} {_fmt(v):>28}  {space}" for name, v, space in rows]
    if c.per_effect:
        lines.append("")
        lines.append(f"per effect (masks from {c.aov_source}):")
        lines.append(f"{'effect':<12} {'pixels':>8} {'SSIM':>8} {'FLIP':>8} {'MAE lin':>9} "
                     f"{'relMSE':>9} {'over':>7}  status")
        order = sorted(c.per_effect.items(), key=lambda kv: ("pass", "warn", "fail").index(kv[1][1].status),
                       reverse=True)
        for name, (pm, pv) in order:
            lines.append(f"{name:<12} {pm.pixels:>8} {pm.ssim:>8.4f} {pm.flip_ldr:>8.4f} "
                         f"{pm.mae_linear:>9.3g} {pm.rel_mse_linear:>9.3g} {pm.over_threshold:>7}  {pv.status}")
    lines.append("")
    lines.append(f"verdict: {c.verdict.status.upper()}" +
                 (": " + "; ".join(c.verdict.reasons) if c.verdict.reasons else ""))
    return "\n".join(lines)


def write_outputs(c: Comparison, *, json_path: str | None, diff_path: str | None) -> None:
    if json_path:
        write_atomic(json_path, json.dumps(json_safe(c.as_dict()), indent=2) + "\n")
    if diff_path:
        d = diff_image(display(c.ref.rgb), display(c.test.rgb))
        # diff_image is already display-encoded; write it as linear so it is not re-encoded
        from compare.images import srgb_to_linear

        write_png(diff_path, srgb_to_linear(d))


def json_safe(x: Any) -> Any:
    """NaN and Inf are not JSON: write them as null."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    return x
