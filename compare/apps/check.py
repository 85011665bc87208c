"""`rtval check`: the regression check for renderer changes.

Renders a scene set with rtdemo (every backend and mode asked for) or with any other program
(`--renderer 'CMD {scene} {out} ...'`, compare.render.foreign), compares each render with its
stored baseline, or with a demo model rendered by rtdemo (`--against classic`), under
per-scene tolerances, and names each failure's scene and effect (effect masks from an rtdemo
AOV render of the scene at the same size, cached). A missing baseline is a failure; `update`
rewrites only new or failing baselines.

Baseline layout (BASELINE = --baseline):
  rtdemo          BASELINE/<scene>/<mode>.exr  (per scene and mode, not per backend: the GL
                  backend must reproduce the CPU's)
  --renderer      BASELINE/<renderer-name>/<scene>/<mode or 'default'>.exr
Tolerances: BASELINE/tolerances.json, overlaid by BASELINE/<renderer-name>/tolerances.json.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare.judge.effects import BOOL, EFFECTS
from compare.judge.evaluate import evaluate_pair
from compare.judge.images import F32, Image, ImageError, read_image, write_exr
from compare.judge.target_model import ModelError, TargetModel, parse_model
from compare.judge.tolerances import EXIT_FAIL, EXIT_PASS, EXIT_WARN, Tolerances
from compare.render import aov_cache, foreign
from compare.render.runner import ToolError, run_rtdemo
from scene_model.scene import Scene, load_scene

DEFAULT_SCENES = ("scenes/paper.json", "scenes/classic.json")
DEFAULT_MODES = ("paper", "classic", "physical")
DEFAULT_SIZE = (320, 240)
# A change of 2/255 on 0.02 % of pixels (15 at 320x240) passes: compilers may round a
# silhouette pixel differently; every deliberate bug of the fault-injection test moves more.
DEFAULT_TOLERANCES = Tolerances(fail=2 / 255, failpercent=0.02, warn=1 / 255, warnpercent=0.0)
FOREIGN_MODE = "default"  # the mode of a renderer whose command has no {mode}
WHOLE_IMAGE = "image"  # the "effect" a failure is filed under when no effect mask explains it


@dataclass(frozen=True)
class FailurePictures:
    ref: F32
    test: F32
    flip: F32  # H x W, LDR FLIP


@dataclass
class EffectOutcome:
    status: str  # pass | warn | fail
    pixels: int
    failing_pixels: int
    flip: float | None  # mean FLIP over the effect's pixels (computed for failing cases)
    reasons: list[str] = field(default_factory=list)


@dataclass
class CaseResult:
    scene: str
    backend: str  # rtdemo's backend; the renderer's name for a foreign renderer
    mode: str
    status: str  # pass | warn | fail
    reasons: list[str] = field(default_factory=list)
    failing_pixels: int = 0
    max_display_error: float = 0.0
    ssim: float | None = None
    flip: float | None = None
    seconds: float = 0.0  # the renderer's own time
    overhead_seconds: float = 0.0  # everything else this case cost (masks, reading, judging)
    updated: bool = False
    renderer: str = "rtdemo"
    against: str | None = None  # the demo model compared with, instead of a baseline
    scene_file: str = ""
    test_encoding: str = "float"  # how the render's file was decoded (images.Image.encoding)
    effects: dict[str, EffectOutcome] = field(default_factory=dict)
    failed_effects: list[str] = field(default_factory=list)  # failures, named by effect
    # For --html, failing cases only: reference, render (linear RGB) and the FLIP map; not
    # the whole evaluation, whose maps would hold ~15 MB per 640x480 case.
    pictures: FailurePictures | None = field(default=None, repr=False)

    @property
    def label(self) -> str:
        """The scene (and mode or backend) a failure message starts with."""
        if self.renderer == "rtdemo":
            return f"{self.scene}/{self.backend}-{self.mode}"
        return self.scene if self.mode == FOREIGN_MODE else f"{self.scene}/{self.mode}"

    @property
    def name(self) -> str:
        return self.label if self.renderer == "rtdemo" else f"{self.renderer}/{self.label}"

    def as_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in self.__dict__.items() if k != "pictures"}
        d["effects"] = {k: v.__dict__ for k, v in self.effects.items()}
        return {**d, "name": self.name}


def load_tolerances(baseline_dir: Path, renderer: str | None = None) -> dict[str, Tolerances]:
    """tolerances.json: {"default": {...}, "<scene>": {...}}; keys are Tolerances fields. A
    renderer's own BASELINE/<renderer>/tolerances.json overrides the shared one per key."""
    files = [baseline_dir / "tolerances.json"]
    if renderer:
        files.append(baseline_dir / renderer / "tolerances.json")
    merged: dict[str, Tolerances] = {}
    for path in files:
        if not path.is_file():
            continue
        try:
            raw = json.loads(path.read_text())
            if not isinstance(raw, dict):
                raise TypeError("expected an object of scene names")
            for name, values in raw.items():
                if not isinstance(values, dict):
                    raise TypeError(f"{name!r}: expected an object of tolerance fields")
                for k, v in values.items():
                    nullable = k in ("hardfail", "min_ssim", "max_flip")
                    number = isinstance(v, (int, float)) and not isinstance(v, bool)
                    if not ((v is None and nullable) or (number and 0 <= v < math.inf)):
                        raise TypeError(f"{name}.{k}: expected a finite number >= 0, got {v!r}")
                known = {**dataclasses.asdict(DEFAULT_TOLERANCES), **values}
                if known.get("hardfail") is None:
                    known["hardfail"] = math.inf  # null: no hard limit
                tol = Tolerances(**known)
                merged[name] = tol
        except (json.JSONDecodeError, TypeError) as e:
            raise ValueError(f"{path}: invalid tolerances: {e}") from None
    return merged


def default_cache_dir() -> Path:
    """$RTVAL_CACHE/check, else $XDG_CACHE_HOME/rtval/check or ~/.cache/rtval/check."""
    import os

    if os.environ.get("RTVAL_CACHE"):
        return Path(os.environ["RTVAL_CACHE"]) / "check"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "rtval" / "check"


def baseline_path(baseline_dir: Path, renderer: str | None, scene: str, mode: str) -> Path:
    if renderer is None:
        return baseline_dir / scene / f"{mode}.exr"
    return baseline_dir / renderer / scene / f"{mode}.exr"


def _effect_message(case: CaseResult, effect: str, outcome: EffectOutcome) -> str:
    reasons = "; ".join(outcome.reasons)
    if outcome.flip is not None and np.isfinite(outcome.flip) and "FLIP" not in reasons:
        return f"{case.label}: {effect} FLIP {outcome.flip:.3f}, {reasons}"
    return f"{case.label}: {effect} {reasons}"


def judge_case(
    case: CaseResult,
    ref: F32,
    test: F32,
    tol: Tolerances,
    masks: dict[str, BOOL] | None,
    *,
    keep: bool,
) -> None:
    """Fills the case's verdict and per-effect outcomes. The verdict is the whole image's (as
    check has always judged); a failing case is evaluated again with the effect masks and FLIP
    to say which effects fail. A passing one costs no FLIP (unless a tolerance asks for it)
    and no per-effect metrics: its effects get pixel counts only."""
    need_flip = tol.max_flip is not None
    ev = evaluate_pair(ref, test, tolerances=tol, flip=need_flip)
    if ev.verdict.status == "fail" and masks:
        ev = evaluate_pair(ref, test, tolerances=tol, masks=masks, flip=True)
    elif ev.verdict.status == "fail":
        ev = evaluate_pair(ref, test, tolerances=tol, flip=True)
    v = ev.verdict
    case.status, case.reasons = v.status, list(v.reasons)
    case.failing_pixels, case.max_display_error = v.failing_pixels, v.max_display_error
    case.ssim = ev.metrics.ssim if np.isfinite(ev.metrics.ssim) else None
    case.flip = ev.metrics.flip_ldr if np.isfinite(ev.metrics.flip_ldr) else None
    for name, r in ev.per_effect.items():
        flip = r.metrics.flip_ldr
        case.effects[name] = EffectOutcome(
            r.verdict.status,
            r.metrics.pixels,
            r.verdict.failing_pixels,
            flip if np.isfinite(flip) else None,
            list(r.verdict.reasons),
        )
    if not ev.per_effect:
        for name in EFFECTS:
            mask = (masks or {}).get(name)
            if mask is None or not mask.any():
                continue
            err = ev.maps.abs_display[mask]
            warned = v.status == "warn" and bool((err > tol.warn).any())
            case.effects[name] = EffectOutcome(
                "warn" if warned else "pass", int(mask.sum()), int((err > tol.fail).sum()), None
            )
    if case.status == "fail":
        # The image fails as a whole (the rule check has always had); name the effects whose
        # own pixels fail, or the image when the failure is spread too thin for any one.
        failing = [n for n in EFFECTS if n in case.effects and case.effects[n].status == "fail"]
        # The most visible first: the effect a person should look at.
        failing.sort(key=lambda n: -(case.effects[n].flip or 0.0))
        case.failed_effects = failing or [WHOLE_IMAGE]
        case.reasons = [
            _effect_message(case, n, case.effects[n])
            if n != WHOLE_IMAGE
            else f"{case.label}: {WHOLE_IMAGE} {'; '.join(v.reasons)}"
            for n in case.failed_effects
        ]
        if keep:
            case.pictures = FailurePictures(ev.ref, ev.test, ev.maps.flip_ldr)


@dataclass
class CheckSettings:
    scenes: list[str]
    baseline_dir: Path
    size: tuple[int, int] = DEFAULT_SIZE
    modes: list[str] | None = None  # None: every demo mode, or the --against model's own
    backends: list[str] = field(default_factory=lambda: ["cpu"])
    update: bool = False
    rtdemo: str | None = None
    renderer: foreign.RendererCommand | None = None
    against: str | None = None
    spp: int = 1
    timeout: float | None = None
    cache_dir: Path | None = None
    keep_images: bool = False  # keep failing cases' evaluations (for --html)


def _render_rtdemo(
    settings: CheckSettings, scene_path: str, backend: str, mode_args: list[str], tmp: Path
) -> tuple[Image, float]:
    out = tmp / f"render-{backend}.exr"
    args = ["render", scene_path, "-o", str(out), *mode_args, "--backend", backend]
    args += ["--width", str(settings.size[0]), "--height", str(settings.size[1]), "-q"]
    if settings.spp != 1:
        args += ["--spp", str(settings.spp)]
    start = time.perf_counter()
    run_rtdemo(args, executable=settings.rtdemo)
    seconds = time.perf_counter() - start
    return read_image(out), seconds


def _target(settings: CheckSettings) -> TargetModel | None:
    if settings.against is None:
        return None
    try:
        model = parse_model(settings.against)
    except ModelError as e:
        raise ValueError(f"--against: {e}") from None
    if not model.is_demo:
        raise ValueError(
            f"--against {model.name}: only demo models (paper, classic, physical with +Qn/-Qn) "
            "are rendered by check; compare with a Mitsuba reference through `rtval compare`"
        )
    return model


def run_check(
    settings: CheckSettings, *, progress: Callable[[str], None] = print
) -> list[CaseResult]:
    model = _target(settings)
    if settings.update and model is not None:
        raise ValueError("--update writes baselines; with --against there are none to write")
    cmd = settings.renderer
    name = cmd.name if cmd else None
    tolerances = load_tolerances(settings.baseline_dir, name)
    cache_dir = settings.cache_dir or default_cache_dir()
    modes = settings.modes or list(DEFAULT_MODES)
    if cmd is None and model is not None and settings.modes is None:
        # rtdemo against a model checks the model's own algorithm: a correct build matches.
        runs = [(b, model.name) for b in settings.backends]
    elif cmd is None:
        runs = [(b, m) for b in settings.backends for m in modes]
    elif cmd.uses_mode:
        # Against a model, {mode} is the model's mode: one case per scene.
        runs = [(cmd.name, m) for m in ([model.mode] if model and model.mode else modes)]
    else:
        runs = [(cmd.name, FOREIGN_MODE)]
    results: list[CaseResult] = []
    with tempfile.TemporaryDirectory(prefix="rtval-check-") as tmp:
        for scene_path in settings.scenes:
            scene = load_scene(scene_path)
            tol = tolerances.get(scene.name, tolerances.get("default", DEFAULT_TOLERANCES))
            for backend, mode in runs:
                case = _one_case(
                    settings, scene, scene_path, backend, mode, model, tol, cache_dir, Path(tmp)
                )
                progress(
                    f"{case.name:<28} {case.status.upper():<5}"
                    + (" (baseline updated)" if case.updated else "")
                    + (f"  {'; '.join(case.reasons)}" if case.reasons else "")
                )
                results.append(case)
    return results


def _one_case(
    settings: CheckSettings,
    scene: Scene,
    scene_path: str,
    backend: str,
    mode: str,
    model: TargetModel | None,
    tol: Tolerances,
    cache_dir: Path,
    tmp: Path,
) -> CaseResult:
    cmd = settings.renderer
    start = time.perf_counter()
    case = CaseResult(
        scene.name,
        backend,
        mode,
        "pass",
        renderer=cmd.name if cmd else "rtdemo",
        against=model.name if model else None,
        scene_file=str(scene_path),
    )
    try:
        if cmd is None:
            mode_args = model.rtdemo_args() if model and mode == model.name else ["--mode", mode]
            test, case.seconds = _render_rtdemo(settings, scene_path, backend, mode_args, tmp)
        else:
            got = foreign.render(
                cmd,
                scene=scene,
                scene_file=Path(scene_path),
                size=settings.size,
                spp=settings.spp,
                mode=mode,
                timeout=settings.timeout,
            )
            test, case.seconds = got.image, got.seconds
    except (foreign.RenderFailed, ToolError, ImageError) as e:
        case.status, case.failed_effects = "fail", ["render"]
        case.reasons = [f"{case.label}: render failed: {e}"]
        case.overhead_seconds = time.perf_counter() - start - case.seconds
        return case
    case.test_encoding = test.encoding
    baseline = baseline_path(settings.baseline_dir, cmd.name if cmd else None, scene.name, mode)
    ref: F32 | None = None
    if model is not None:
        ref = aov_cache.model_render(
            Path(scene_path), model.rtdemo_args(), settings.size, settings.spp, cache_dir
        ).rgb
    elif baseline.is_file():
        ref = read_image(baseline).rgb
    if ref is None:
        case.status, case.reasons = "fail", [f"{case.label}: no baseline {baseline}"]
        case.failed_effects = ["baseline"]
    elif ref.shape != test.rgb.shape:
        case.status = "fail"
        case.failed_effects = ["baseline"]
        case.reasons = [
            f"{case.label}: size {test.shape[1]}x{test.shape[0]} differs from the "
            f"baseline's {ref.shape[1]}x{ref.shape[0]}"
        ]
    else:
        masks = aov_cache.scene_masks(Path(scene_path), settings.size, cache_dir)
        judge_case(case, ref, test.rgb, tol, masks, keep=settings.keep_images)
    if settings.update and case.status == "fail":
        baseline.parent.mkdir(parents=True, exist_ok=True)
        # Colour only: the AOVs are not compared and would triple the size. rtdemo's header
        # (mode, quirks, ray counts) says what made the baseline.
        header = test.header if cmd is None else None
        write_exr(baseline, np.asarray(test.rgb, np.float32), header=header)
        case.updated = True
    case.overhead_seconds = time.perf_counter() - start - case.seconds
    return case


def exit_code(results: list[CaseResult]) -> int:
    effective = [r for r in results if not r.updated]
    if any(r.status == "fail" for r in effective):
        return EXIT_FAIL
    if any(r.status == "warn" for r in effective):
        return EXIT_WARN
    return EXIT_PASS
