"""`rtval check`: the regression check for renderer changes.

Renders the demo on a scene set (every backend and mode asked for; renders come from the
shared render cache when the same rtdemo binary made them before), compares each render
with its stored baseline under per-scene tolerances and reports a table, JSON and JUnit XML.
A missing baseline is a failure; `update` rewrites only new or failing baselines.
Baselines are per scene and mode, not per backend: the GL backend must reproduce the CPU's.

With `against` (a target model) each render is judged against the model instead of a
baseline: a demo model by exact match (the model rendered by the installed rtdemo, or
$RTVAL_RTDEMO, the render by `rtdemo`), Mitsuba by the default rubric's per-effect verdict.
"""

from __future__ import annotations

import io
import json
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from compare.files import write_atomic
from compare.judge.evaluate import evaluate_pair
from compare.judge.images import read_image, write_exr
from compare.judge.tolerances import EXIT_FAIL, EXIT_PASS, EXIT_WARN, Tolerances
from compare.render.cache import RenderCache
from compare.render.jobs import RenderJob, run_jobs
from compare.render.progress import Progress
from scene_model.scene import load_scene

DEFAULT_SCENES = ("scenes/paper.json", "scenes/classic.json")
DEFAULT_MODES = ("paper", "classic", "physical")
DEFAULT_SIZE = (320, 240)
# A change of 2/255 on 0.02 % of pixels (15 at 320x240) passes: compilers may round a
# silhouette pixel differently; every deliberate bug of the fault-injection test moves more.
DEFAULT_TOLERANCES = Tolerances(fail=2 / 255, failpercent=0.02, warn=1 / 255, warnpercent=0.0)


@dataclass
class CaseResult:
    scene: str
    backend: str
    mode: str
    status: str  # pass | warn | fail
    reasons: list[str] = field(default_factory=list)
    failing_pixels: int = 0
    max_display_error: float = 0.0
    ssim: float | None = None
    seconds: float = 0.0
    updated: bool = False
    against: str = "baseline"  # what the render was judged against

    @property
    def name(self) -> str:
        return f"{self.scene}/{self.backend}-{self.mode}"


def load_tolerances(baseline_dir: Path) -> dict[str, Tolerances]:
    """tolerances.json: {"default": {...}, "<scene>": {...}}; keys are Tolerances fields."""
    path = baseline_dir / "tolerances.json"
    if not path.is_file():
        return {}
    try:
        raw = json.loads(path.read_text())
        return {
            name: Tolerances(**{**DEFAULT_TOLERANCES.as_dict(), **values})
            for name, values in raw.items()
        }
    except (json.JSONDecodeError, TypeError) as e:
        raise ValueError(f"{path}: invalid tolerances: {e}") from None


def run_check(
    *,
    scenes: list[str],
    modes: list[str] | None,
    backends: list[str],
    baseline_dir: Path,
    size: tuple[int, int],
    update: bool = False,
    rtdemo: str | None = None,
    against: str | None = None,
    cache_dir: Path | str | None = None,
    progress: Progress | None = None,
) -> list[CaseResult]:
    progress = progress or Progress()
    if against:
        return _check_against(
            scenes=scenes,
            modes=modes,
            backends=backends,
            size=size,
            rtdemo=rtdemo,
            against=against,
            cache_dir=cache_dir,
            progress=progress,
        )
    tolerances = load_tolerances(baseline_dir)
    modes = modes or list(DEFAULT_MODES)
    cache = RenderCache(cache_dir)
    cases: list[tuple[str, Tolerances, str, str, RenderJob]] = []
    for scene_path in scenes:
        scene = load_scene(scene_path)
        tol = tolerances.get(scene.name, tolerances.get("default", DEFAULT_TOLERANCES))
        for backend in backends:
            for mode in modes:
                job = _render_job(
                    scene_path, scene.name, backend, mode, ["--mode", mode], size, rtdemo
                )
                cases.append((scene.name, tol, backend, mode, job))
    # Renders come from the shared cache: its key holds the rtdemo binary's hash, so a
    # changed renderer is always rendered afresh.
    # check prints one line per case itself, after comparing: the runner's lines are dropped.
    run_jobs([c[4] for c in cases], cache, progress=_quiet())
    results: list[CaseResult] = []
    for scene_name, tol, backend, mode, job in cases:
        out = job.exr(cache)
        case = CaseResult(scene_name, backend, mode, "pass", seconds=job.seconds)
        # One baseline per scene and mode: every backend must reproduce it.
        baseline = baseline_dir / scene_name / f"{mode}.exr"
        if not baseline.is_file():
            case.status, case.reasons = "fail", [f"no baseline {baseline}"]
        else:
            ref, test = read_image(baseline), read_image(out)
            if ref.shape != test.shape:
                case.status = "fail"
                case.reasons = [
                    f"size {test.shape[1]}x{test.shape[0]} differs from the "
                    f"baseline's {ref.shape[1]}x{ref.shape[0]}"
                ]
            else:
                c = evaluate_pair(ref.rgb, test.rgb, tolerances=tol)
                case.status, case.reasons = c.verdict.status, c.verdict.reasons
                case.failing_pixels = c.verdict.failing_pixels
                case.max_display_error = c.verdict.max_display_error
                case.ssim = c.metrics.ssim
        if update and case.status == "fail":
            baseline.parent.mkdir(parents=True, exist_ok=True)
            # Colour only: the AOVs are not compared and would triple the size.
            fresh = read_image(out)
            write_exr(baseline, fresh.rgb, header=fresh.header)
            case.updated = True
        progress(
            f"{case.name:<28} {case.status.upper():<5}"
            + (" (cached render)" if job.cached else "")
            + (" (baseline updated)" if case.updated else "")
            + (f"  {'; '.join(case.reasons)}" if case.reasons else "")
        )
        results.append(case)
    return results


def _render_job(
    scene_path: str,
    scene_name: str,
    backend: str,
    name: str,
    mode_args: list[str],
    size: tuple[int, int],
    rtdemo: str | None,
) -> RenderJob:
    """The render of one case, as a command for the shared cache."""
    args = ["render", "{scene}", "-o", "{out}", *mode_args, "--backend", backend]
    args += ["--width", str(size[0]), "--height", str(size[1]), "-q"]
    return RenderJob(
        f"{scene_name}/{backend}-{name}",
        f"{scene_name} {backend} {name}",
        "rtdemo",
        args,
        "check",
        scene=scene_path,
        executable=rtdemo,
    )


def _quiet() -> Progress:
    return Progress(io.StringIO(), tty=False)


def _check_against(
    *,
    scenes: list[str],
    modes: list[str] | None,
    backends: list[str],
    size: tuple[int, int],
    rtdemo: str | None,
    against: str,
    cache_dir: Path | str | None,
    progress: Progress,
) -> list[CaseResult]:
    from compare.apps.against import judge, load, prepare
    from compare.judge.target_model import parse_model

    model = parse_model(against)
    cache = RenderCache(cache_dir)
    # A demo model checks its own algorithm unless modes are asked for: the render under test
    # runs with the model's options, so a correct build matches it exactly.
    cases: list[tuple[str, list[str]]] = (
        [(model.name, model.rtdemo_args())]
        if model.is_demo and not modes
        else [(m, ["--mode", m]) for m in (modes or list(DEFAULT_MODES))]
    )
    results: list[CaseResult] = []
    for scene_path in scenes:
        scene = load_scene(scene_path)
        loaded = load(prepare(model, Path(scene_path), size, cache, progress=progress))
        jobs = [
            (backend, name, _render_job(scene_path, scene.name, backend, name, args, size, rtdemo))
            for backend in backends
            for name, args in cases
        ]
        run_jobs([j for _, _, j in jobs], cache, progress=_quiet())
        for backend, name, job in jobs:
            case = CaseResult(
                scene.name, backend, name, "pass", seconds=job.seconds, against=model.name
            )
            ev = judge(read_image(job.exr(cache)), loaded)
            assert ev.score is not None
            case.status = ev.score.status
            case.reasons = ev.score.reasons()
            case.failing_pixels = ev.exact.differing if ev.exact else ev.verdict.failing_pixels
            progress(
                f"{case.name:<28} {case.status.upper():<5} against {model.name}"
                + (" (cached render)" if job.cached else "")
                + (f"  {'; '.join(case.reasons)}" if case.reasons else "")
            )
            results.append(case)
    return results


def exit_code(results: list[CaseResult]) -> int:
    effective = [r for r in results if not r.updated]
    if any(r.status == "fail" for r in effective):
        return EXIT_FAIL
    if any(r.status == "warn" for r in effective):
        return EXIT_WARN
    return EXIT_PASS


def table(results: list[CaseResult]) -> str:
    lines = [
        f"{'case':<28} {'status':<7} {'failing px':>10} {'max err':>8} {'SSIM':>8} {'time s':>7}"
        "  against"
    ]
    order = sorted(results, key=lambda r: ("fail", "warn", "pass").index(r.status))
    for r in order:
        ssim = f"{r.ssim:.5f}" if r.ssim is not None else "-"
        lines.append(
            f"{r.name:<28} {r.status:<7} {r.failing_pixels:>10} "
            f"{r.max_display_error:>8.4f} {ssim:>8} {r.seconds:>7.2f}  {r.against}"
            + ("  updated" if r.updated else "")
        )
    n_fail = sum(r.status == "fail" for r in results)
    lines.append(f"{len(results) - n_fail} passed, {n_fail} failed")
    return "\n".join(lines)


def write_json(results: list[CaseResult], path: Path) -> None:
    data: list[dict[str, Any]] = [{**r.__dict__, "name": r.name} for r in results]
    write_atomic(
        path,
        json.dumps(
            {"status": ("pass", "warn", "fail")[exit_code(results)], "cases": data}, indent=2
        )
        + "\n",
    )


def write_junit(results: list[CaseResult], path: Path) -> None:
    suite = ET.Element(
        "testsuite",
        name="rtval check",
        tests=str(len(results)),
        failures=str(sum(r.status == "fail" for r in results)),
    )
    for r in results:
        case = ET.SubElement(
            suite,
            "testcase",
            classname=f"rtval.{r.scene}",
            name=f"{r.backend}-{r.mode}",
            time=f"{r.seconds:.3f}",
        )
        ET.SubElement(
            ET.SubElement(case, "properties"), "property", name="against", value=r.against
        )
        if r.status == "fail":
            ET.SubElement(case, "failure", message="; ".join(r.reasons)).text = "; ".join(r.reasons)
        elif r.status == "warn":
            ET.SubElement(case, "system-out").text = "warning: " + "; ".join(r.reasons)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
