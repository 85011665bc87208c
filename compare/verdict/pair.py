"""`rtval compare REF TEST`: every metric, globally and per effect, and a verdict."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.judge.effects import effect_masks
from compare.judge.evaluate import Evaluation, evaluate_pair
from compare.judge.exact_match import ENCODING_WORDS
from compare.judge.images import Image, ImageError, read_image, srgb_to_linear
from compare.judge.metrics import Metrics, check_same_size, display
from compare.judge.png import write_png
from compare.judge.target_model import TargetModel
from compare.judge.tolerances import Tolerances, Verdict, diff_image
from compare.render.cache import RenderCache
from compare.render.progress import Progress
from compare.verdict.against import judge_against_model, load, prepare
from safe_files.content import json_safe
from safe_files.paths import write_atomic
from scene_model.scene import Scene


@dataclass
class Comparison:
    """`rtval compare`'s result: the evaluation plus where its inputs came from."""

    ref: Image
    test: Image
    evaluation: Evaluation
    aov_source: str | None = None
    against: str | None = None  # the target model; None: the reference image as given

    @property
    def verdict(self) -> Verdict:
        return self.evaluation.verdict

    @property
    def metrics(self) -> Metrics:
        return self.evaluation.metrics

    def as_dict(self) -> dict[str, Any]:
        h, w = self.ref.shape
        ev = self.evaluation
        return {
            "against": self.against or "reference image",
            "reference": self.ref.path,
            "test": self.test.path,
            "size": [w, h],
            "encodings": {"reference": self.ref.encoding, "test": self.test.encoding},
            "hdr": ev.maps.flip_hdr is not None,
            "status": ev.verdict.status,
            "exit_code": ev.verdict.exit_code,
            "reasons": ev.verdict.reasons,
            "failing_pixels": ev.verdict.failing_pixels,
            "warning_pixels": ev.verdict.warning_pixels,
            "tolerances": ev.tolerances.as_dict(),
            "metrics": ev.metrics.as_dict(),
            "per_effect_aovs_from": self.aov_source,
            "per_effect": {
                k: {
                    "status": self._effect_status(k),
                    "reasons": self._effect_reasons(k),
                    **e.metrics.as_dict(),
                }
                for k, e in ev.per_effect.items()
            },
            "exact": ev.exact.as_dict() if ev.exact else None,
            "score": ev.score.as_dict() if ev.score else None,
        }

    def _effect_status(self, name: str) -> str:
        ex = self.evaluation.exact
        if ex is not None and name in ex.per_effect:
            return "pass" if ex.per_effect[name].passed else "fail"
        return self.evaluation.per_effect[name].verdict.status

    def _effect_reasons(self, name: str) -> list[str]:
        ex = self.evaluation.exact
        if ex is not None and name in ex.per_effect:
            return [] if ex.per_effect[name].passed else [ex.sentence(name)]
        return self.evaluation.per_effect[name].verdict.reasons


def load_mask(path: str | Path, shape: tuple[int, int]) -> np.ndarray:
    img = read_image(path, encoding="linear")
    if img.shape != shape:
        raise ImageError(
            f"{path}: mask is {img.shape[1]}x{img.shape[0]}, images are {shape[1]}x{shape[0]}"
        )
    return np.asarray(img.rgb.mean(axis=-1) > 0.5)


def run_comparison(
    ref: Image,
    test: Image,
    *,
    tolerances: Tolerances = Tolerances(),
    mask: np.ndarray | None = None,
    scene: Scene | None = None,
    aovs: Image | None = None,
) -> Comparison:
    check_same_size(ref.rgb, test.rgb, ref.path or "reference", test.path or "test")
    hdr = ref.encoding == "float" or test.encoding == "float"
    masks = None
    source = None
    if scene is not None:
        source = next((im for im in (aovs, ref, test) if im is not None and "id" in im.aovs), None)
        if source is None:
            raise ImageError(
                "per-effect metrics need id and depth AOVs: neither image has them "
                "(give --aovs FILE.exr, e.g. a demo render of the scene)"
            )
        if source.shape != ref.shape:
            raise ImageError(
                f"{source.path}: AOVs are {source.shape[1]}x{source.shape[0]}, images "
                f"are {ref.shape[1]}x{ref.shape[0]}"
            )
        masks = effect_masks(scene, source.aovs["id"], source.aovs["depth"])
    evaluation = evaluate_pair(
        ref.rgb, test.rgb, hdr=hdr, tolerances=tolerances, region=mask, masks=masks
    )
    return Comparison(ref, test, evaluation, source.path if source is not None else None)


def run_against(
    test: Image,
    model: TargetModel,
    scene_file: Path,
    cache: RenderCache,
    *,
    tolerances: Tolerances = Tolerances(),
    mask: np.ndarray | None = None,
    progress: Progress | None = None,
) -> Comparison:
    """`test` judged against a target model rendered at the test's size (never resampled)."""

    h, w = test.shape
    renders = prepare(model, scene_file, (w, h), cache, progress=progress)
    loaded = load(renders)
    evaluation = judge_against_model(test, loaded, region=mask, tolerances=tolerances)
    return Comparison(loaded.reference, test, evaluation, renders.reference, model.name)


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return f"{v:.5g}"
    return str(v)


def _metric_lines(c: Comparison) -> list[str]:
    """The inputs, then one line per whole-image metric with the space it is measured in."""
    m = c.metrics
    rows = [
        ("SSIM", m.ssim, "display"),
        ("FLIP (LDR, 67 ppd)", m.flip_ldr, "display"),
        ("FLIP (HDR, 67 ppd)", m.flip_hdr, "linear"),
        ("PSNR dB", m.psnr_db, "display"),
        ("RMSE", m.rmse_display, "display"),
        ("MAE", m.mae_display, "display"),
        ("RMSE", m.rmse_linear, "linear"),
        ("MAE", m.mae_linear, "linear"),
        ("relative MSE", m.rel_mse_linear, "linear"),
        ("max error", f"{_fmt(m.max_error_linear)} at {m.max_error_at}", "linear"),
        (f"pixels over {m.threshold:.4g}", m.over_threshold, "display"),
        ("NaN / Inf (ref)", f"{m.nan_ref} / {m.inf_ref}", ""),
        ("NaN / Inf (test)", f"{m.nan_test} / {m.inf_test}", ""),
    ]
    h, w = c.ref.shape
    lines = [
        f"reference {c.ref.path} ({c.ref.encoding}), test {c.test.path} ({c.test.encoding}), {w}x{h}",
        f"{'metric':<24} {'value':>28}  space",
    ]
    return lines + [f"{name:<24} {_fmt(v):>28}  {space}" for name, v, space in rows]


def _effect_lines(c: Comparison) -> list[str]:
    """One line per effect, failing ones first; none without per-effect masks."""
    if not c.evaluation.per_effect:
        return []
    ex = c.evaluation.exact
    lines = [
        "",
        f"per effect (masks from {c.aov_source}):",
        f"{'effect':<12} {'pixels':>8} {'SSIM':>8} {'FLIP':>8} {'MAE lin':>9} "
        f"{'relMSE':>9} {'over':>7}"
        + (f" {'differ':>7} {'unstable':>8}" if ex else "")
        + "  status",
    ]
    order = sorted(
        c.evaluation.per_effect.items(),
        key=lambda kv: ("pass", "warn", "fail").index(c._effect_status(kv[0])),
        reverse=True,
    )
    for name, e in order:
        pm = e.metrics
        em = ex.per_effect.get(name) if ex else None
        lines.append(
            f"{name:<12} {pm.pixels:>8} {pm.ssim:>8.4f} {pm.flip_ldr:>8.4f} "
            f"{pm.mae_linear:>9.3g} {pm.rel_mse_linear:>9.3g} {pm.over_threshold:>7}"
            + (f" {em.differing:>7} {em.unstable:>8}" if em else "")
            + f"  {c._effect_status(name)}"
        )
    return lines


def table(c: Comparison) -> str:
    lines = _metric_lines(c) + _effect_lines(c)
    lines.append("")
    ex = c.evaluation.exact
    if ex is not None:
        lines.append(
            f"exact match against {ex.model}: {ex.differing:,} px differ beyond "
            f"{ENCODING_WORDS[ex.encoding]}; {ex.unstable_pixels:,} px where the model is unstable accepted "
            f"within the spread of its {ex.renders - 1} perturbed renders"
        )
    against = c.against or f"the reference image {c.ref.path}"
    lines.append(
        f"verdict against {against}: {c.verdict.status.upper()}"
        + (": " + "; ".join(c.verdict.reasons) if c.verdict.reasons else "")
    )
    return "\n".join(lines)


def write_outputs(c: Comparison, *, json_path: str | None, diff_path: str | None) -> None:
    if json_path:
        write_atomic(json_path, json.dumps(json_safe(c.as_dict()), indent=2) + "\n")
    if diff_path:
        d = diff_image(display(c.ref.rgb), display(c.test.rgb))
        # diff_image is already display-encoded; write it as linear so it is not re-encoded

        write_png(diff_path, srgb_to_linear(d))
