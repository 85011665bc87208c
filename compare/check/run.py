"""`rtval check`: the regression check for renderer changes.

Renders a scene set with rtdemo (every backend and mode asked for) or with any other program
(`--renderer 'CMD {scene} {out} ...'`, compare.render.foreign), compares each render with its
stored baseline under per-scene tolerances, and names each failure's scene and effect (effect
masks from the classic model's AOVs at the same size, compare.render.models.scene_masks). A
missing baseline is a failure; `update` rewrites only new or failing baselines.

With `against` (a target model) each render is judged against the model instead of a
baseline, as compare and grade judge (compare/verdict/against.py): a demo model by exact match
(the model rendered by the installed rtdemo, or $RTVAL_RTDEMO), Mitsuba by the default
rubric's per-effect verdict; the model render's own masks name the failing effects.

Baseline layout (BASELINE = --baseline):
  rtdemo          BASELINE/<scene>/<mode>.exr  (per scene and mode, not per backend: the GL
                  backend must reproduce the CPU's)
  --renderer      BASELINE/<renderer-name>/<scene>/<mode or 'default'>.exr
Tolerances: BASELINE/tolerances.json, overlaid by BASELINE/<renderer-name>/tolerances.json.
"""

from __future__ import annotations

import contextlib
import difflib
import io
import json
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare.errors import ToolError
from compare.judge.arrays import F32
from compare.judge.effects import BOOL, EFFECTS
from compare.judge.evaluate import evaluate_pair
from compare.judge.exact_match import ExactMatch
from compare.judge.images import (
    Image,
    ImageError,
    ImageKindError,
    image_size,
    linear_to_srgb,
    read_image,
    write_exr,
)
from compare.judge.target_model import TargetModel
from compare.judge.tolerances import EXIT_FAIL, EXIT_PASS, EXIT_WARN, Tolerances
from compare.render import foreign
from compare.render.cache import RenderCache
from compare.render.jobs import RenderJob, run_jobs
from compare.render.models import scene_masks
from compare.render.progress import Progress
from compare.verdict import against
from compare.verdict.against import LoadedModel
from safe_files.paths import own_folder, read_bounded
from scene_model.scene import Scene, load_scene

DEFAULT_SCENES = ("paper", "lit", "classic")  # built-in scenes (scene_model/builtin.py)
DEFAULT_MODES = ("paper", "classic", "physical")
# A change of 2/255 on 0.02 % of pixels (15 at 320x240) passes: compilers may round a
# silhouette pixel differently; every deliberate bug of the fault-injection test moves more.
DEFAULT_TOLERANCES = Tolerances(fail=2 / 255, failpercent=0.02, warn=1 / 255, warnpercent=0.0)
FOREIGN_MODE = "default"  # the mode of a renderer whose command has no {mode}
WHOLE_IMAGE = "image"  # the "effect" a failure is filed under when no effect mask explains it
MAX_TOLERANCES_BYTES = 1 << 20  # a tolerances.json is a few lines


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
    baseline_action: str = ""  # with updated: "written" (there was none) or "replaced"
    cached: bool = False  # rtdemo's render came from the shared render cache
    renderer: str = "rtdemo"
    against: str = "baseline"  # what the render was judged against: a target model's name
    scene_file: str = ""
    size: tuple[int, int] | None = None  # (width, height) it was rendered at
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


class TolerancesFileError(OSError):
    """An invalid tolerances.json: an unreadable input, exit 4 like any other."""


# null in tolerances.json means "no limit" (docs/check.md): the value that never fails. A
# display error is at most 1 and only errors strictly over the threshold count.
_NO_LIMIT = {"fail": 1.0, "warn": 1.0, "failpercent": 100.0, "warnpercent": 100.0}


def _tolerances_of(values: dict[str, Any]) -> Tolerances:
    fields = DEFAULT_TOLERANCES.as_dict()
    for key in values:
        if key not in fields:
            close = difflib.get_close_matches(key, list(fields), n=1)
            hint = f"did you mean {close[0]}?" if close else f"expected {', '.join(fields)}"
            raise TypeError(f"unknown field {key!r} ({hint})")
    given = {k: (_NO_LIMIT[k] if v is None and k in _NO_LIMIT else v) for k, v in values.items()}
    return Tolerances(**{**DEFAULT_TOLERANCES.as_dict(), **given})


def load_tolerances(baseline_dir: Path, renderer: str | None = None) -> dict[str, Tolerances]:
    """tolerances.json: {"default": {...}, "<scene>": {...}}; keys are Tolerances fields (which
    checks each number; null hardfail: no hard limit). A renderer's own
    BASELINE/<renderer>/tolerances.json overrides the shared one per key."""
    files = [baseline_dir / "tolerances.json"]
    if renderer:
        files.append(baseline_dir / renderer / "tolerances.json")
    merged: dict[str, Tolerances] = {}
    for path in files:
        if not path.exists():
            continue
        text = read_bounded(path, MAX_TOLERANCES_BYTES).decode("utf-8", errors="replace")
        try:
            raw = json.loads(text)
            if not isinstance(raw, dict):
                raise TypeError("expected an object of scene names")
            for name, values in raw.items():
                if not isinstance(values, dict):
                    raise TypeError(f"{name!r}: expected an object of tolerance fields")
                try:
                    merged[name] = _tolerances_of(values)
                except (TypeError, ValueError) as e:
                    raise TypeError(f"{name!r}: {e}") from None
        except json.JSONDecodeError as e:
            raise TolerancesFileError(
                f"{path}: invalid tolerances: not JSON: {e.msg.lower()} at line {e.lineno}, "
                f"column {e.colno}"
            ) from None
        except TypeError as e:
            raise TolerancesFileError(f"{path}: invalid tolerances: {e}") from None
    return merged


def baseline_path(baseline_dir: Path, renderer: str | None, scene: str, mode: str) -> Path:
    if renderer is None:
        return baseline_dir / scene / f"{mode}.exr"
    return baseline_dir / renderer / scene / f"{mode}.exr"


def _effect_message(case: CaseResult, effect: str, outcome: EffectOutcome) -> str:
    reasons = "; ".join(outcome.reasons)
    if outcome.flip is not None and np.isfinite(outcome.flip) and "FLIP" not in reasons:
        return f"{case.label}: {effect} FLIP {outcome.flip:.3f}, {reasons}"
    return f"{case.label}: {effect} {reasons}"


def _name_failures(case: CaseResult, whole: list[str]) -> None:
    """A failing case's failures, named by effect: the effects whose own pixels fail, the most
    visible (highest FLIP) first, or the image when the failure is spread too thin for any
    one. `whole`: the whole image's reasons."""
    failing = [n for n in EFFECTS if n in case.effects and case.effects[n].status == "fail"]
    failing.sort(key=lambda n: -(case.effects[n].flip or 0.0))
    case.failed_effects = failing or [WHOLE_IMAGE]
    case.reasons = [
        _effect_message(case, n, case.effects[n])
        if n != WHOLE_IMAGE
        else f"{case.label}: {WHOLE_IMAGE} {'; '.join(whole)}"
        for n in case.failed_effects
    ]


def _finite(x: float) -> float | None:
    return x if np.isfinite(x) else None


def judge_case(
    case: CaseResult,
    ref: F32,
    test: F32,
    tol: Tolerances,
    masks: dict[str, BOOL] | None,
    *,
    keep: bool,
) -> None:
    """Fills the case's verdict and per-effect outcomes against a baseline. The verdict is the
    whole image's (what a baseline pins); a failing case is evaluated again with the
    effect masks and FLIP to say which effects fail. A passing one costs no FLIP (unless a
    tolerance asks for it) and no per-effect metrics: its effects get pixel counts only."""
    ev = evaluate_pair(ref, test, tolerances=tol, flip=tol.max_flip is not None)
    if ev.verdict.status == "fail":
        ev = evaluate_pair(ref, test, tolerances=tol, masks=masks, flip=True)
    v = ev.verdict
    case.status, case.reasons = v.status, list(v.reasons)
    case.failing_pixels, case.max_display_error = v.failing_pixels, v.max_display_error
    case.ssim, case.flip = _finite(ev.metrics.ssim), _finite(ev.metrics.flip_ldr)
    for name, r in ev.per_effect.items():
        case.effects[name] = EffectOutcome(
            r.verdict.status,
            r.metrics.pixels,
            r.verdict.failing_pixels,
            _finite(r.metrics.flip_ldr),
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
        _name_failures(case, list(v.reasons))
        if keep:
            case.pictures = FailurePictures(ev.ref, ev.test, ev.maps.flip_ldr)


def judge_against(case: CaseResult, test: Image, model: LoadedModel, *, keep: bool) -> None:
    """Fills the case's verdict against a target model (against.judge_against_model: a demo model's exact
    match, Mitsuba's rubric), per effect of the model render's masks. An exact pass computes
    no FLIP and no SSIM."""
    ev = against.judge_against_model(test, model)
    score = ev.score
    if score is None:  # a model render without effect pixels: nothing to judge per effect
        raise ImageError(f"{model.renders.reference}: the model render has no effect pixels")
    exact = ev.exact
    case.status = score.status
    if exact is not None:
        case.failing_pixels = exact.differing
        case.max_display_error = _largest_differing_error(ev.ref, ev.test, exact)
    else:
        case.failing_pixels = ev.verdict.failing_pixels
        case.max_display_error = ev.verdict.max_display_error
        case.ssim, case.flip = _finite(ev.metrics.ssim), _finite(ev.metrics.flip_ldr)
    for name, e in score.effects.items():
        if exact is not None:
            failing = exact.per_effect[name].differing
            reasons = [] if e.status == "pass" else [exact.sentence(name)]
        else:
            failing = ev.per_effect[name].verdict.failing_pixels
            reasons = list(e.reasons)
        case.effects[name] = EffectOutcome(e.status, e.pixels, failing, e.flip, reasons)
    if case.status == "fail":
        whole = score.reasons() or [f"{case.failing_pixels:,} px differ from {model.target.name}"]
        _name_failures(case, whole)
        if keep:
            case.pictures = FailurePictures(ev.ref, ev.test, ev.maps.flip_ldr)


def _largest_differing_error(ref: F32, test: F32, exact: ExactMatch) -> float:
    """The largest display-channel difference from the model's pixel-centre render over the
    pixels the exact match counts as differing; 0 when none does. The table's "max err" then
    tells the same story as its failing pixels (the exact verdict has no error of its own)."""
    differ = ~exact.matches if exact.region is None else ~exact.matches & exact.region
    if not differ.any():
        return 0.0
    return float(np.abs(linear_to_srgb(test[differ]) - linear_to_srgb(ref[differ])).max())


@dataclass
class CheckSettings:
    scenes: list[str]
    baseline_dir: Path
    size: tuple[int, int] | None = None  # None: case_size's rule
    modes: list[str] | None = None  # None: every demo mode, or the --against model's own
    backends: list[str] = field(default_factory=lambda: ["cpu"])
    update: bool = False
    rtdemo: str | None = None
    renderer: foreign.RendererCommand | None = None
    against: TargetModel | None = None
    spp: int = 1
    timeout: float | None = None
    sandbox: bool = False  # run the renderer in the grading sandbox (docs/sandbox.md)
    # Model renders and effect masks: the render cache every command shares.
    cache: RenderCache = field(default_factory=RenderCache)
    keep_images: bool = False  # keep failing cases' pictures (for --html)


def case_size(
    settings: CheckSettings, scene: Scene, baseline: Path | None
) -> tuple[tuple[int, int], str]:
    """((width, height), where it came from) of a case's render: --size when given, else its
    stored baseline's size (a baseline made at another size keeps being checked at it), else
    the scene's own camera size, so that a renderer that always writes the scene's size needs
    no option."""
    if settings.size is not None:
        return settings.size, "--size"
    if baseline is not None and baseline.is_file():
        with contextlib.suppress(ImageError):
            h, w = image_size(baseline)
            return (w, h), "baseline"
    return (scene.camera.width, scene.camera.height), "scene"


def _render_rtdemo(
    settings: CheckSettings,
    scene_path: str,
    backend: str,
    mode_args: list[str],
    cache: RenderCache,
    size: tuple[int, int],
) -> tuple[Image, float, bool]:
    """rtdemo's render of one case, through the shared cache: its key holds the binary's hash,
    so a changed build always renders afresh. Returns (image, seconds, from the cache)."""
    args = ["render", "{scene}", "-o", "{out}", *mode_args, "--backend", backend]
    args += ["--width", str(size[0]), "--height", str(size[1]), "-q"]
    if settings.spp != 1:
        args += ["--spp", str(settings.spp)]
    name = "-".join(a.lstrip("-") for a in mode_args)
    job = RenderJob(
        f"check-{backend}-{name}",
        f"check {backend} {name}",
        "rtdemo",
        args,
        "check",
        scene=scene_path,
        executable=settings.rtdemo,
    )
    run_jobs([job], cache, progress=Progress(io.StringIO(), tty=False))  # check prints its own
    return read_image(job.exr(cache)), job.seconds, job.cached


def _target(settings: CheckSettings) -> TargetModel | None:
    if settings.against is None:
        return None
    model = settings.against
    if settings.update:
        raise ValueError("--update writes baselines; with --against there are none to write")
    if model.is_demo and settings.spp != 1:
        # The model is one pixel-centre ray per pixel; exact match judges against exactly that.
        raise ValueError(f"--against {model.name}: a demo model is judged at --spp 1 only")
    return model


def _runs(settings: CheckSettings, model: TargetModel | None) -> list[tuple[str, str]]:
    """(backend or renderer name, mode) of every case per scene."""
    cmd = settings.renderer
    modes = settings.modes or list(DEFAULT_MODES)
    if cmd is None and model is not None and model.is_demo and settings.modes is None:
        # rtdemo against a demo model checks the model's own algorithm: the render under test
        # runs with the model's options, so a correct build matches it exactly.
        return [(b, model.name) for b in settings.backends]
    if cmd is None:
        return [(b, m) for b in settings.backends for m in modes]
    if cmd.uses_mode:
        # Against a demo model, {mode} is the model's mode: one case per scene.
        return [(cmd.name, m) for m in ([model.mode] if model and model.mode else modes)]
    return [(cmd.name, FOREIGN_MODE)]


def run_check(
    settings: CheckSettings, *, progress: Callable[[str], None] = print
) -> list[CaseResult]:
    model = _target(settings)
    _check_inputs(settings)
    cmd = settings.renderer
    tolerances = load_tolerances(settings.baseline_dir, cmd.name if cmd else None)
    cache = settings.cache
    runs = _runs(settings, model)
    results: list[CaseResult] = []
    for scene_path in settings.scenes:
        scene = load_scene(scene_path)
        tol = tolerances.get(scene.name, tolerances.get("default", DEFAULT_TOLERANCES))
        loaded = None
        if model is not None:
            renders = against.prepare(model, Path(scene_path), settings.size, cache)
            loaded = against.load(renders)
        run = _SceneRun(settings, scene, scene_path, loaded, tol, cache)
        for backend, mode in runs:
            case = _one_case(run, backend, mode)
            progress(_progress_line(case, model is not None))
            results.append(case)
    return results


def _check_inputs(settings: CheckSettings) -> None:
    """Before any render: the baseline folder, rtdemo and the renderer's program are there
    (else every case would fail alike, one render after another). OSError: exit 4."""
    baseline = settings.baseline_dir
    if baseline.exists() and not baseline.is_dir():
        raise OSError(f"--baseline {baseline}: not a folder")
    rtdemo = settings.rtdemo
    if rtdemo and not (Path(rtdemo).is_file() and os.access(rtdemo, os.X_OK)):
        raise OSError(f"--rtdemo {rtdemo}: no such program (an executable file)")
    program = settings.renderer.words[0] if settings.renderer else None
    if program and "{" not in program and shutil.which(program) is None:
        where = "no such executable file" if os.sep in program else "not found on PATH"
        raise OSError(f"--renderer: cannot run '{program}': {where}")


def _progress_line(case: CaseResult, against_model: bool) -> str:
    """One case as it finishes. A baseline written by --update is news, not a failure: a new
    one says so alone; a replaced one keeps the reasons the old one failed for."""
    cached = " (cached render)" if case.cached else ""
    if case.baseline_action == "written":
        return f"{case.name:<28} baseline written{cached}"
    if case.baseline_action == "replaced":
        return f"{case.name:<28} baseline replaced{cached}; it failed: {'; '.join(case.reasons)}"
    return (
        f"{case.name:<28} {case.status.upper():<5}"
        + (f" against {case.against}" if against_model else "")
        + cached
        + (f"  {'; '.join(case.reasons)}" if case.reasons else "")
    )


@dataclass(frozen=True)
class _SceneRun:
    """What every case of one scene shares."""

    settings: CheckSettings
    scene: Scene
    scene_path: str
    model: LoadedModel | None
    tol: Tolerances
    cache: RenderCache


def _one_case(run: _SceneRun, backend: str, mode: str) -> CaseResult:
    settings, scene, model = run.settings, run.scene, run.model
    cmd = settings.renderer
    start = time.perf_counter()
    case = CaseResult(
        scene.name,
        backend,
        mode,
        "pass",
        renderer=cmd.name if cmd else "rtdemo",
        against=model.target.name if model else "baseline",
        scene_file=str(run.scene_path),
    )
    baseline = baseline_path(settings.baseline_dir, cmd.name if cmd else None, scene.name, mode)
    # Against a model there is no baseline: the model was rendered at --size or the scene's.
    sized = case_size(settings, scene, None if model else baseline)
    case.size = sized[0]
    try:
        test = _render_case(run, case, backend, sized)
    except (foreign.RenderFailed, ToolError, ImageError) as e:
        case.status, case.failed_effects = "fail", ["render"]
        case.reasons = [f"{case.label}: render failed: {_render_failure(e, cmd)}"]
        case.overhead_seconds = time.perf_counter() - start - case.seconds
        return case
    case.test_encoding = test.encoding
    _judge_case_image(run, case, test, baseline, sized[0])
    if settings.update and case.status == "fail":
        had_one = os.path.lexists(baseline)
        _write_baseline(settings.baseline_dir, baseline, test, header=cmd is None)
        case.updated = True
        case.baseline_action = "replaced" if had_one else "written"
    case.overhead_seconds = time.perf_counter() - start - case.seconds
    return case


def _render_failure(e: Exception, cmd: foreign.RendererCommand | None) -> str:
    """Why a render gave no image. An image of another format than --output-format says so,
    from its first bytes (the path of the renderer's temporary {out} would help no one)."""
    # foreign.render raises RenderFailed while handling the reader's error: its context.
    cause = e.__context__ if isinstance(e, foreign.RenderFailed) else e
    if cmd is None or not isinstance(cause, ImageKindError):
        return str(e)
    hint = f": pass --output-format {cause.found.key}" if cause.found and cause.found.key else ""
    return f"the renderer wrote {cause.holds} but --output-format is {cmd.output_format}{hint}"


def _render_case(
    run: _SceneRun, case: CaseResult, backend: str, sized: tuple[tuple[int, int], str]
) -> Image:
    """The case's image, by rtdemo or by the renderer under test; its seconds on the case."""
    settings, model, scene_path = run.settings, run.model, run.scene_path
    cmd, (size, size_from) = settings.renderer, sized
    if cmd is None:
        demo = model is not None and model.target.is_demo and case.mode == model.target.name
        mode_args = model.target.rtdemo_args() if model and demo else ["--mode", case.mode]
        test, case.seconds, case.cached = _render_rtdemo(
            settings, scene_path, backend, mode_args, run.cache, size
        )
        return test
    request = foreign.SceneRequest(
        run.scene, Path(scene_path), size, settings.spp, case.mode, size_from
    )
    got = foreign.render(cmd, request, timeout=settings.timeout, sandbox=settings.sandbox)
    case.seconds = got.seconds
    return got.image


def _judge_case_image(
    run: _SceneRun, case: CaseResult, test: Image, baseline: Path, size: tuple[int, int]
) -> None:
    """The case's verdict: against the model, or against its baseline (none: a failure)."""
    model, keep = run.model, run.settings.keep_images
    try:
        ref = model.reference.rgb if model else stored_baseline(baseline)
    except ImageError as e:
        ref, missing = None, f"unreadable baseline: {e}"
    else:
        missing = f"no baseline {baseline}"
    if ref is None:
        case.status, case.reasons = "fail", [f"{case.label}: {missing}"]
        case.failed_effects = ["baseline"]
    elif ref.shape != test.rgb.shape:
        case.status = "fail"
        case.failed_effects = ["baseline"]
        case.reasons = [
            f"{case.label}: size {test.shape[1]}x{test.shape[0]} differs from the "
            f"{'model' if model else 'baseline'}'s {ref.shape[1]}x{ref.shape[0]}"
        ]
    elif model is not None:
        judge_against(case, test, model, keep=keep)
    else:
        masks = scene_masks(Path(run.scene_path), size, run.cache)
        judge_case(case, ref, test.rgb, run.tol, masks, keep=keep)


def stored_baseline(baseline: Path) -> F32 | None:
    """A baseline's colour; None when nothing is there. Something that is there but no
    readable image (a link to /dev/zero, a FIFO, a truncated EXR) is an ImageError naming
    it, never "no baseline"."""
    if not os.path.lexists(baseline):
        return None
    return read_image(baseline).rgb


def _write_baseline(baseline_dir: Path, baseline: Path, test: Image, *, header: bool) -> None:
    """Writes a new baseline. The folders below --baseline are made by rtval and never a
    planted link (own_folder); the file replaces only a regular file (write_exr)."""
    baseline_dir.mkdir(parents=True, exist_ok=True)
    own_folder(baseline_dir, *baseline.parent.relative_to(baseline_dir).parts)
    # Colour only: the AOVs are not compared and would triple the size. rtdemo's header
    # (mode, quirks, ray counts) says what made the baseline.
    rgb = np.asarray(test.rgb, np.float32)
    write_exr(baseline, rgb, header=test.header if header else None)


def exit_code(results: list[CaseResult]) -> int:
    effective = [r for r in results if not r.updated]
    if any(r.status == "fail" for r in effective):
        return EXIT_FAIL
    if any(r.status == "warn" for r in effective):
        return EXIT_WARN
    return EXIT_PASS
