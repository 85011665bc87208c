"""`rtval report`: one scene through every renderer into reports/<scene>/.

Writes index.html (renders with a flip control, difference/FLIP/SSIM maps, global and
per-effect tables, sentences, speed-accuracy and convergence charts, the ablation ladder,
reproducibility facts, a one-screen verdict), report.json, report.pdf and the images.
Every render is a printed command, cached by content hash (render_cache.py).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import importlib.metadata
import json
import os
import platform
import shlex
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from jinja2 import Environment, PackageLoader, select_autoescape

from compare.apps import report_figures as figs
from compare.apps.page_security import printable, with_csp
from compare.escape import json_for_script
from compare.files import json_safe as _json_safe
from compare.files import sha256_file, write_atomic
from compare.judge.convergence import time_to_converged
from compare.judge.effects import effect_masks
from compare.judge.evaluate import evaluate_pair
from compare.judge.images import Image, ImageError, ImageSizeError, read_image, write_png
from compare.judge.metrics import metrics_from_dict
from compare.judge.penumbra import penumbra_numbers
from compare.judge.scoring import score_effects
from compare.judge.sentences import contribution_sentence, difference_sentences
from compare.judge.tolerances import Tolerances
from compare.render.cache import RenderJob, run_jobs
from compare.render.plan import (
    DEMO_YARDSTICK_SPP,
    EFFECT_SWITCHES,
    QUIRKS,
    REFERENCE_KEY,
    REFERENCE_SPP,
    plan,
)
from compare.render.runner import ToolError, rtdemo_path
from compare.safe_paths import check_output_target
from scene_model.scene import load_scene

# Renders compared in full (global + per effect), with maps.
FEATURED = [
    ("demo-paper-cpu", "demo, paper mode"),
    ("demo-classic-cpu", "demo, classic mode"),
    ("demo-physical-cpu-1spp", "demo, physical mode (pixel centres)"),
    ("demo-physical-cpu-16spp", "demo, physical mode, 16 spp"),
    ("demo-physical-gl-16spp", "demo, physical mode, GL, 16 spp"),
    ("mitsuba-path-llvm-64spp", "Mitsuba path tracer, 64 spp"),
]
MAPPED = ("demo-paper-cpu", "demo-physical-cpu-16spp", "mitsuba-path-llvm-64spp")


class Evaluator:
    """Metrics of images against the reference, cached by the pair's content hashes."""

    def __init__(
        self, ref: Image, ref_hash: str, masks: dict[str, np.ndarray], cache: Path
    ) -> None:
        self.ref, self.ref_hash, self.masks, self.cache = ref, ref_hash, masks, cache

    def evaluate(self, test: Image, test_hash: str, *, per_effect: bool) -> dict[str, Any]:
        path = self.cache / f"metrics-{self.ref_hash[:16]}-{test_hash[:16]}-{int(per_effect)}.json"
        if path.is_file():
            return dict(json.loads(path.read_text()))
        # Pixels over 1/255 are counted in the report (compare's default failing error is 0.01).
        ev = evaluate_pair(
            self.ref.rgb,
            test.rgb,
            hdr=per_effect,
            tolerances=Tolerances(fail=1.0 / 255.0),
            masks=self.masks if per_effect else None,
        )
        out: dict[str, Any] = {
            "global": _json_safe(ev.metrics.as_dict()),
            "per_effect": {k: _json_safe(e.metrics.as_dict()) for k, e in ev.per_effect.items()},
        }
        write_atomic(path, json.dumps(out))
        return out

    def maps(self, test: Image) -> Any:
        return evaluate_pair(self.ref.rgb, test.rgb).maps


def _versions() -> dict[str, str]:
    v = {}
    for dist in (
        "rtval",
        "mitsuba",
        "drjit",
        "numpy",
        "scikit-image",
        "flip-evaluator",
        "OpenEXR",
        "matplotlib",
        "jinja2",
    ):
        try:
            v[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            v[dist] = "not installed"
    try:
        v["rtdemo"] = subprocess.run(
            [rtdemo_path(), "--version"], capture_output=True, text=True, check=False
        ).stdout.strip()
    except ToolError:
        v["rtdemo"] = "not found"
    v["python"] = platform.python_version()
    return v


def _machine() -> str:
    cpu = ""
    with contextlib.suppress(OSError):
        cpu = next(
            (
                line.split(":", 1)[1].strip()
                for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")
            ),
            "",
        )
    return f"{cpu or platform.processor()} x {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def build_report(
    scene_path: str | Path,
    reports_dir: str | Path = "reports",
    *,
    size: tuple[int, int] | None = None,
    test_image: str | None = None,
    test_label: str | None = None,
    test_encoding: str | None = None,
    against: str | None = None,
    jobs: int = 1,
    pdf: bool = True,
    progress: Callable[[str], None] = print,
) -> Path:
    scene_file = Path(scene_path)
    scene = load_scene(scene_file)
    out = Path(reports_dir) / scene.name
    cache = out / "cache"
    images_dir = out / "images"
    for d in (out, cache, images_dir):
        d.mkdir(parents=True, exist_ok=True)

    render_jobs = plan(str(scene_file), size)
    run_jobs(render_jobs, scene_file, cache, images_dir, jobs_in_parallel=jobs, progress=progress)
    by_key: dict[str, RenderJob] = {j.key: j for j in render_jobs}
    imgs: dict[str, Image] = {k: read_image(images_dir / f"{k}.exr") for k in by_key}
    hashes = {k: sha256_file(images_dir / f"{k}.exr") for k in by_key}
    for k, img in imgs.items():
        write_png(images_dir / f"{k}.png", img.rgb)

    ref = imgs[REFERENCE_KEY]
    masks = effect_masks(scene, ref.aovs["id"], ref.aovs["depth"])
    ev = Evaluator(ref, hashes[REFERENCE_KEY], masks, cache)

    # The image under test: the demo's paper mode, or a foreign render.
    test_key = "demo-paper-cpu"
    label = test_label or "the demo (paper mode)"
    featured = list(FEATURED)
    if test_image:
        try:  # the size is checked in the header: a huge declared size costs nothing
            foreign = read_image(test_image, encoding=test_encoding, expected_size=ref.shape)
        except ImageSizeError as e:
            raise ImageError(
                f"{test_image}: {e.size[1]}x{e.size[0]}, the scene renders at "
                f"{ref.shape[1]}x{ref.shape[0]} (never resampled)"
            ) from None
        test_key = "test-image"
        label = test_label or Path(test_image).stem
        imgs[test_key] = foreign
        hashes[test_key] = sha256_file(Path(test_image))
        write_png(images_dir / "test-image.png", foreign.rgb)
        featured.insert(0, (test_key, label))
    progress("metrics ...")
    results = {k: ev.evaluate(imgs[k], hashes[k], per_effect=True) for k, _ in featured}

    # Maps for the main comparisons (cached by the pair's hashes).
    maps_info = []
    for k in ([test_key] if test_image else []) + list(MAPPED):
        stamp = cache / f"maps-{k}.sha"
        pair = hashes[REFERENCE_KEY] + hashes[k]
        files = {kind: f"images/map-{k}-{kind}.png" for kind in ("diff", "flip", "ssim")}
        if not (
            stamp.is_file()
            and stamp.read_text() == pair
            and all((out / f).is_file() for f in files.values())
        ):
            m = ev.maps(imgs[k])
            title = dict(featured).get(k, k)
            figs.signed_difference(
                ref.rgb, imgs[k].rgb, out / files["diff"], f"signed difference: {title}"
            )
            figs.map_figure(
                m.flip_ldr,
                out / files["flip"],
                title=f"FLIP (LDR, 67 ppd): {title}",
                cmap="magma",
                vmin=0,
                vmax=1,
                label="FLIP error",
            )
            figs.map_figure(
                np.nan_to_num(m.ssim, nan=1.0),
                out / files["ssim"],
                title=f"SSIM map: {title}",
                cmap="viridis",
                vmin=0,
                vmax=1,
                label="SSIM",
            )
            stamp.write_text(pair)
        maps_info.append({"key": k, "label": dict(featured).get(k, k), **files})

    # Speed against accuracy, convergence.
    chart_rows = []
    for j in render_jobs:
        if j.family in ("reference", "ablation", "ladder", "reference area"):
            continue
        g = ev.evaluate(imgs[j.key], hashes[j.key], per_effect=False)["global"]
        seconds = float(imgs[j.key].header.get("rtval.render_seconds", "nan"))
        chart_rows.append(
            {
                "key": j.key,
                "label": j.label,
                "family": j.family,
                "spp": j.spp,
                "seconds": seconds,
                "one_minus_ssim": max(1.0 - (g["ssim"] or 0.0), 1e-7),
                "flip": g["flip_ldr"],
                "rmse": g["rmse_display"],
            }
        )
    figs.speed_accuracy_chart(chart_rows, out / "images" / "speed-accuracy.png")
    slopes = figs.convergence_chart(chart_rows, out / "images" / "convergence.png")

    # Ablation ladder: paper -> Q1 fixed -> Q1,Q2 fixed ... -> physical (Q10: 16 spp).
    ladder_keys = (
        ["demo-paper-cpu"] + [f"ladder-{i:02d}" for i in range(1, 10)] + ["demo-physical-cpu-16spp"]
    )
    ladder_names = ["paper"] + [f"+{q}" for q in QUIRKS[:9]] + ["+Q10 = physical 16 spp"]
    ladder = []
    for name, k in zip(ladder_names, ladder_keys, strict=False):
        g = ev.evaluate(imgs[k], hashes[k], per_effect=False)["global"]
        ladder.append(
            {
                "step": name,
                "key": k,
                "flip": g["flip_ldr"],
                "one_minus_ssim": 1.0 - (g["ssim"] or 0.0),
                "seconds": float(imgs[k].header.get("rtval.render_seconds", "nan")),
                "command": by_key[k].command_text(images_dir / f"{k}.exr"),
            }
        )
    figs.ladder_chart(ladder, out / "images" / "ablation-ladder.png")

    # Effect contributions at pixel centres: what shadows / reflection / refraction add.
    contributions = []
    if not test_image:
        for effect in EFFECT_SWITCHES:
            for demo_mode in ("paper", "physical"):
                base = "demo-paper-cpu" if demo_mode == "paper" else "demo-physical-cpu-1spp"
                contributions.append(
                    {
                        "mode": demo_mode,
                        **contribution_sentence(
                            effect,
                            imgs[base].rgb,
                            imgs[f"demo-{demo_mode}-cpu-no-{effect}"].rgb,
                            imgs["ref-centre"].rgb,
                            imgs[f"ref-centre-no-{effect}"].rgb,
                            f"the demo ({demo_mode} mode)",
                        ),
                    }
                )

    test_effects = {k: metrics_from_dict(v) for k, v in results[test_key]["per_effect"].items()}
    verdict = score_effects(test_effects).as_dict() | {"against": "mitsuba"}
    model_verdict = None
    if test_image:
        model_verdict = _model_verdict(
            imgs[test_key], against, scene_file, size, cache, ladder, progress
        )
    diagnosis = None
    if test_image and model_verdict is not None:
        diagnosis = _diagnosis(
            imgs[test_key], scene_file, cache, images_dir, model_verdict["model"], jobs, progress
        )
    sentences = difference_sentences(ref.rgb, imgs[test_key].rgb, masks, test_effects, label)
    penumbra = penumbra_numbers(ref.rgb, imgs["ref-area"].rgb, imgs["demo-physical-cpu-16spp"].rgb)
    converged = time_to_converged(
        ref, {spp: imgs[f"demo-physical-cpu-{spp}spp"] for spp in (1, 4, 16, DEMO_YARDSTICK_SPP)}
    )

    renders = [
        {
            "key": j.key,
            "label": j.label,
            "png": f"images/{j.key}.png",
            "exr": f"images/{j.key}.exr",
            "command": j.command_text(images_dir / f"{j.key}.exr"),
            "family": j.family,
            "seconds": float(imgs[j.key].header.get("rtval.render_seconds", "nan")),
            "cached": j.cached,
            "sha256": hashes[j.key],
        }
        for j in render_jobs
    ]
    if test_image:
        renders.insert(
            0,
            {
                "key": test_key,
                "label": label,
                "png": "images/test-image.png",
                "exr": str(test_image),
                "command": f"(given) {test_image}",
                "family": "test",
                "seconds": float("nan"),
                "cached": True,
                "sha256": hashes[test_key],
            },
        )
    command = ["rtval", "report", str(scene_file)]
    if size:
        command += ["--size", f"{size[0]}x{size[1]}"]
    if test_image:
        command += ["--test-image", str(test_image)] + (
            ["--label", test_label] if test_label else []
        )
        if against:
            command += ["--against", against]
    data = _json_safe(
        {
            "scene": scene.name,
            "scene_file": str(scene_file),
            "scene_sha256": sha256_file(scene_file),
            "size": [ref.shape[1], ref.shape[0]],
            "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "machine": _machine(),
            "versions": _versions(),
            "command": shlex.join(command),
            "reference": {
                "key": REFERENCE_KEY,
                "label": by_key[REFERENCE_KEY].label,
                "spp": REFERENCE_SPP,
                "command": by_key[REFERENCE_KEY].command_text(images_dir / f"{REFERENCE_KEY}.exr"),
            },
            "test": {"key": test_key, "label": label},
            "verdict": verdict,
            "model_verdict": model_verdict,
            "diagnosis": diagnosis,
            "sentences": sentences,
            "contributions": contributions,
            "featured": [{"key": k, "label": name, **results[k]} for k, name in featured],
            "maps": maps_info,
            "speed_accuracy": chart_rows,
            "convergence_slopes": slopes,
            "ladder": ladder,
            "penumbra": penumbra,
            "time_to_converged": converged,
            "renders": renders,
            "effect_pixels": {k: int(v.sum()) for k, v in masks.items()},
        }
    )
    write_atomic(out / "report.json", json.dumps(data, indent=2) + "\n")
    env = Environment(
        loader=PackageLoader("compare.apps", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    # Data reaches the page as inert, script-escaped JSON; the CSP admits only the
    # template's own script (compare/apps/page_security.py).
    html = env.get_template("report.html.j2").render(
        report=data, renders_json=json_for_script(renders)
    )
    html = with_csp(html)
    write_atomic(out / "index.html", html)
    if pdf:
        write_pdf(out / "index.html", out / "report.pdf")
    return out / "index.html"


def _model_verdict(
    test: Image,
    against: str | None,
    scene_file: Path,
    size: tuple[int, int] | None,
    cache: Path,
    ladder: list[dict[str, Any]],
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """The test image against its assigned model (is the implementation right?), and what
    each of the model's quirks costs against Mitsuba (how far is that algorithm from physics),
    read from the ablation ladder."""
    from compare.apps.against import GRADE_DEFAULT, judge, load, prepare
    from compare.judge.target_model import MODE_QUIRKS, parse_model

    model = parse_model(against or GRADE_DEFAULT)
    progress(f"model {model.name} ...")
    loaded = load(prepare(model, scene_file, size, cache, progress=progress))
    ev = judge(test, loaded)
    assert ev.score is not None
    # Ladder step i fixes Q(i) on top of Q1..Q(i-1): its FLIP drop is what that quirk costs
    # there (cumulative, so conditional on the earlier fixes).
    present = model.quirks if model.is_demo else frozenset()
    costs = [
        {
            "quirk": q,
            "present": int(q[1:]) in present,
            "flip_with": ladder[i - 1]["flip"],
            "flip_fixed": ladder[i]["flip"],
            "cost": ladder[i - 1]["flip"] - ladder[i]["flip"],
        }
        for i, q in enumerate(QUIRKS, start=1)
        if i < len(ladder) and int(q[1:]) in MODE_QUIRKS["paper"]
    ]
    return {
        "model": model.name,
        "basis": ev.score.basis,
        "score": ev.score.as_dict(),
        "reasons": ev.score.reasons(),
        "exact": ev.exact.as_dict() if ev.exact else None,
        "quirk_costs": costs,
    }


def _diagnosis(
    test: Image,
    scene_file: Path,
    cache: Path,
    images_dir: Path,
    assigned: str,
    jobs: int,
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """The section "What this image implements": the test image explained as the nearest demo model
    (compare/apps/diagnosis.py), with its evidence PNGs in images/. A diagnosis that cannot
    run (e.g. a renderer without AOVs) leaves the section saying why, not a failed report."""
    from compare.apps.diagnosis import diagnose_image
    from compare.judge.diagnose import DiagnoseError

    progress("diagnosis ...")
    try:
        return diagnose_image(
            test,
            scene_file,
            cache / "diagnose",
            images_dir,
            prefix="diagnosis",
            href="images/",
            assigned=assigned,
            parallel=max(1, jobs),
        )
    except (DiagnoseError, ToolError) as e:
        return {"error": str(e)}


def _sandbox_flags() -> list[str]:
    """Chromium refuses to start its sandbox as root; only then is it switched off. The
    copy it prints holds no script and a policy that forbids them (page_security.printable):
    nothing runs in the unsandboxed browser. (--blink-settings=scriptEnabled=false would
    say the same, but headless Chromium then writes no PDF at all.)"""
    return ["--no-sandbox"] if hasattr(os, "geteuid") and os.geteuid() == 0 else []


def write_pdf(html: Path, pdf: Path) -> None:
    """The same page printed by headless Chromium."""
    chromium = (
        shutil.which("chromium")
        or shutil.which("chromium-browser")
        or shutil.which("google-chrome")
    )
    if not chromium:
        raise ToolError(
            "report.pdf needs Chromium (make setup installs Debian's chromium); or pass --no-pdf"
        )
    check_output_target(pdf)
    tmp = pdf.with_name(f".{pdf.stem}.{os.getpid()}.tmp.pdf")
    # Printed from a script-free copy beside the page (so its relative images resolve).
    copy = html.with_name(f".{html.stem}.{os.getpid()}.print.html")
    try:
        write_atomic(copy, printable(html.read_text(encoding="utf-8")))
        _print_pdf(chromium, copy, tmp)
        check_output_target(pdf)
        tmp.replace(pdf)
    finally:  # never a partial PDF or a stray copy left behind
        tmp.unlink(missing_ok=True)
        copy.unlink(missing_ok=True)


def _print_pdf(chromium: str, html: Path, tmp: Path) -> None:
    proc = subprocess.run(
        [
            chromium,
            "--headless",
            *_sandbox_flags(),
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-pdf-header-footer",
            f"--print-to-pdf={tmp}",
            html.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    if proc.returncode != 0 or not tmp.is_file():
        raise ToolError(f"Chromium could not print {html} to PDF: {proc.stderr.strip()[-500:]}")
