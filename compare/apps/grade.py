"""`rtval grade`: a class's renders against a target model, one gradebook.

A submission is an image (its file name is the student id; one --scene only) or a folder
of images named after the scenes. The model (--against, the rubric's `against`, else
`classic`: README "Grading a class") is rendered once per scene through the shared render
cache (the same entries `rtval report` makes); a demo model needs no Mitsuba render at all.
Every row names the model; every fail says why.
Each student is an idempotent task keyed by the hashes of its files, the model's renders and the
rubric: a re-run (or a resumed, interrupted one) skips what is done. Bad submissions become
rows with a reason, never an aborted batch. Tasks run in a local process pool or on a Dask
cluster.

A submission that fails against a demo model is diagnosed (compare/apps/diagnosis.py): the
gradebook's `diagnosis` column and the fail reasons say what it looks like ("looks like Q2
(...)"), its page shows the evidence. Passing submissions cost nothing more; --no-diagnose
skips it. Candidate renders are cached in the render cache's candidates/ folder by content hash, shared by every
student and worker.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import shutil
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.apps.against import ModelRenders
from compare.apps.programs import ProgramJob, ProgramOptions, ProgramSpec, resolve_spec
from compare.apps.submissions import IMAGE_SUFFIXES  # noqa: F401  (re-exported)
from compare.csv_safe import csv_text
from compare.files import atomic_output, sha256_file, write_atomic
from compare.student_ids import student_slug


@dataclass(frozen=True)
class GradeTask:
    student: str
    files: dict[str, str | None]  # scene name -> image path (None: missing)
    problem: str | None  # a reason the submission cannot be graded at all
    models: dict[str, ModelRenders]  # scene name -> the model's renders
    models_key: str  # digest of every model render (computed once, not per student)
    rubric_text: str
    rubric_source: str
    out_dir: str
    diagnose: int = 0  # diagnose failing scenes with this many renders at once; 0: never
    candidates_dir: str = ""  # the diagnosis' candidate renders, inside the render cache
    # A program submission (compare/apps/programs.py): built and run first, in the sandbox.
    program: ProgramJob | None = None
    scene_problems: dict[str, str] = dataclasses.field(default_factory=dict)  # failed runs


def task_key(task: GradeTask) -> str:
    h = hashlib.sha256(task.rubric_text.encode())
    h.update((task.problem or "").encode())
    h.update(task.models_key.encode())
    h.update(f"diagnose={bool(task.diagnose)}".encode())
    if task.program is not None:  # its code, commands, limits and scenes
        h.update(task.program.digest().encode())
    for scene in sorted(task.files):
        f = task.files[scene]
        h.update(scene.encode())
        h.update((sha256_file(Path(f)) if f and Path(f).is_file() else "missing").encode())
    return h.hexdigest()[:24]


def _grade_scene(
    scene_name: str, path: str | None, task: GradeTask, rubric: Any, page_dir: Path
) -> dict[str, Any]:
    from compare.apps.against import judge, load, nan_pixels
    from compare.judge.images import ImageError, ImageSizeError, read_image
    from compare.judge.sentences import difference_sentences

    renders = task.models[scene_name]
    base = {"scene": scene_name, "model": renders.model, "diagnosis": ""}
    if scene_name in task.scene_problems:  # the program's run gave no image: why
        return base | {"status": "error", "score": 0.0, "reason": task.scene_problems[scene_name]}
    if path is None:
        return base | {
            "status": "missing",
            "score": 0.0,
            "reason": f"no image for scene '{scene_name}'",
        }
    model = load(renders)
    ref = model.reference
    try:  # the size is checked in the header, before decoding: memory stays bounded
        img = read_image(path, expected_size=ref.shape)
    except ImageSizeError as e:
        (h, w), (eh, ew) = e.size, e.expected
        return base | {
            "status": "error",
            "score": 0.0,
            "reason": f"wrong size {w}x{h}, expected {ew}x{eh}",
        }
    except ImageError as e:
        return base | {"status": "error", "score": 0.0, "reason": f"unreadable: {e}"}
    nan = nan_pixels(img)
    ev = judge(img, model, rubric)
    assert ev.score is not None  # the model's masks were given
    verdict = ev.score.as_dict()
    reasons = ev.score.reasons()
    if ev.exact is not None:
        verdict["exact"] = ev.exact.as_dict()
    if nan and ev.exact is None:  # exact judging already counts NaN pixels as differing
        verdict["status"] = "fail"
        reasons.insert(0, f"{nan} NaN/Inf pixels")
    # Against a demo model the reasons say what differs; the sentences' SSIM and full FLIP maps
    # would double a failing submission's cost (bench/bench_grade.py).
    sentences = (
        difference_sentences(
            ref.rgb, img.rgb, model.masks, ev.effect_metrics(), f"{task.student}'s render"
        )
        if ev.exact is None
        else list(reasons)
    )
    diagnosis = None
    if verdict["status"] != "pass" and task.diagnose and model.target.is_demo:
        diagnosis = _diagnose_scene(img, scene_name, renders, task, page_dir)
        diagnosis["short"] = _beside_verdict(diagnosis, renders.model, verdict)
        reasons.append(diagnosis["short"])
    # Pictures for the student's page: the submission and |difference| x 8 (display).
    from PIL import Image as PILImage

    from compare.judge.images import linear_to_srgb

    a, b = linear_to_srgb(ref.rgb), linear_to_srgb(img.rgb)
    for name, data in (
        (f"{scene_name}.png", b),
        (f"{scene_name}-diff.png", np.clip(np.abs(a - b) * 8, 0, 1)),
    ):
        buf = io.BytesIO()
        PILImage.fromarray(np.round(data * 255).astype(np.uint8)).save(
            buf, format="PNG", compress_level=1
        )
        write_atomic(page_dir / name, buf.getvalue())
    return base | {
        "status": verdict["status"],
        "score": verdict["score"],
        "reason": "; ".join(reasons),
        "verdict": verdict,
        "sentences": sentences,
        "nan_pixels": nan,
        "diagnosis": diagnosis["short"] if diagnosis else "",
        "diagnosis_detail": diagnosis,
    }


def _beside_verdict(diagnosis: dict[str, Any], model: str, verdict: dict[str, Any]) -> str:
    """The diagnosis' cell, never contradicting the failed verdict beside it. Both judge by
    exact match, so the diagnosis finds the assigned model matching only when every effect
    is within the allowance and the score alone (a pass_score above it) failed."""
    short = str(diagnosis["short"])
    if diagnosis.get("matches") and diagnosis.get("result") == model and not diagnosis["causes"]:
        return (
            f"matches {model} in every effect within the exact-match allowance; the score "
            f"{verdict['score']:.2f} is below the pass score"
        )
    return short


def _diagnose_scene(
    img: Any, scene_name: str, renders: ModelRenders, task: GradeTask, page_dir: Path
) -> dict[str, Any]:
    """What a failing submission looks like; a diagnosis that cannot run says why in the
    cell instead of failing the student's grading."""
    from compare.apps.diagnosis import diagnose_image
    from compare.judge.diagnose import DiagnoseError
    from compare.render.runner import ToolError

    try:
        return diagnose_image(
            img,
            renders.scene_file,
            Path(task.candidates_dir),
            page_dir,
            prefix=f"{scene_name}-diagnosis",
            assigned=renders.model,
            parallel=task.diagnose,
        )
    except (DiagnoseError, ToolError, OSError) as e:
        return {"short": f"no diagnosis: {e}", "sentences": [], "evidence": []}


def grade_one(task: GradeTask) -> dict[str, Any]:
    """Grades one student; returns (and stores) the result. Idempotent: a result with the
    same key on disk is returned as is."""
    from jinja2 import Environment, PackageLoader, select_autoescape

    from compare.apps.page_security import with_csp
    from compare.judge.rubric import parse_rubric

    out = Path(task.out_dir)
    slug = student_slug(task.student)  # the id on disk; the real id stays in the result
    result_path = out / "results" / f"{slug}.json"
    key = task_key(task)
    old = _load_result(result_path)  # None when missing, truncated or corrupt: regrade
    if old is not None and old.get("key") == key and old.get("student") == task.student:
        return {**old, "resumed": True}
    rubric = parse_rubric(task.rubric_text, task.rubric_source)
    page_dir = out / "students" / slug
    page_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    program = None
    if task.program is not None and not task.problem:  # build and run it, then grade as images
        from compare.apps.programs import build_and_run

        program = build_and_run(task.program, out / "programs" / slug)
        task = dataclasses.replace(
            task,
            files=program.files,
            problem=program.problem,
            scene_problems=program.scene_problems,
        )
    scenes: list[dict[str, Any]]
    if task.problem:
        scenes = [
            {
                "scene": s,
                "model": task.models[s].model,
                "diagnosis": "",
                "status": "error",
                "score": 0.0,
                "reason": task.problem,
            }
            for s in task.files
        ]
    else:
        scenes = [_grade_scene(s, p, task, rubric, page_dir) for s, p in sorted(task.files.items())]
    score = float(np.mean([s["score"] for s in scenes])) if scenes else 0.0
    status = (
        "pass"
        if scenes and all(s["status"] == "pass" for s in scenes) and score >= rubric.pass_score
        else "fail"
    )
    reasons = "; ".join(f"{s['scene']}: {s['reason']}" for s in scenes if s.get("reason"))
    if status == "fail" and not reasons:  # every scene passed, the mean is short of pass_score
        reasons = f"score {score:.1f} < {rubric.pass_score:g}"
    models = sorted({str(s["model"]) for s in scenes})
    result = {
        "student": task.student,
        "key": key,
        "status": status,
        "score": score,
        "model": ", ".join(models),
        "reasons": reasons,
        # Failing scenes against a demo model: what they look like (compare/apps/diagnosis.py).
        "diagnosis": "; ".join(
            (f"{s['scene']}: " if len(scenes) > 1 else "") + s["diagnosis"]
            for s in scenes
            if s.get("diagnosis")
        ),
        "scenes": scenes,
        "rubric": rubric.source,
        "seconds": time.perf_counter() - start,
        "page": f"students/{slug}/index.html",
    }
    if program is not None:  # build and run logs, times and peak memory for the page
        result["program"] = program.info
    env = Environment(
        loader=PackageLoader("compare.apps", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    page = with_csp(env.get_template("student.html.j2").render(r=result))
    write_atomic(page_dir / "index.html", page)
    (out / "results").mkdir(exist_ok=True)
    write_atomic(result_path, json.dumps(result, indent=2, default=float))
    return result


def _load_result(path: Path) -> dict[str, Any] | None:
    """A stored result, or None when it is missing or unreadable (a run killed mid-write
    before writes were atomic, a full disk, a hand edit): such a student is graded again."""
    try:
        old = json.loads(path.read_bytes())
    except (OSError, ValueError):
        return None
    return old if isinstance(old, dict) else None


def collect(
    submissions: Path,
    scenes: list[str],
    *,
    exclude: list[Path] | None = None,
    notice: Callable[[str], None] | None = None,
) -> list[tuple[str, dict[str, str | None], str | None]]:
    """(student, scene -> file, problem) for every id in the submissions folder (see
    compare/apps/submissions.py: what is a submission, and the reasons for what is not)."""
    from compare.apps.submissions import collect_entries

    return [
        (e.student, e.files, "; ".join(e.problems) or None)
        for e in collect_entries(submissions, scenes, exclude=exclude, notice=notice)
    ]


def _entries(
    submissions: Path,
    models: dict[str, ModelRenders],
    spec: ProgramSpec | None,
    size: tuple[int, int] | None,
    out: Path,
    cache_root: Path,
    progress: Callable[[str], None],
) -> list[tuple[str, dict[str, str | None], str | None, ProgramJob | None]]:
    """(student, scene -> file, problem, program) for every submission: images, or programs
    to build and run when the class has a [program] (compare/apps/programs.py)."""
    if spec is None:
        found = collect(submissions, list(models), exclude=[out], notice=progress)
        return [(student, files, problem, None) for student, files, problem in found]
    from compare.apps.programs import program_entries

    return program_entries(submissions, models, spec, size, out, cache_root, progress)


def _beside(renders: ModelRenders, scene_name: str, folder: Path) -> ModelRenders:
    """The model's renders copied out of the shared cache beside the grades, as
    references/SCENE-MODEL.exr (and -offsetN.exr): the tasks (maybe on other machines) read
    them from there. A copy already there with the same bytes stays."""
    folder.mkdir(parents=True, exist_ok=True)
    stem = student_slug(f"{scene_name}-{renders.model}")  # names from the scene file: made safe

    def copy(src: str, suffix: str) -> str:
        target = folder / f"{stem}{suffix}.exr"
        if not (target.is_file() and sha256_file(target) == sha256_file(src)):
            with atomic_output(target) as tmp:
                shutil.copyfile(src, tmp)
        return str(target)

    return dataclasses.replace(
        renders,
        reference=copy(renders.reference, ""),
        offsets=tuple(copy(p, f"-offset{i}") for i, p in enumerate(renders.offsets)),
    )


def run_grading(
    submissions: Path,
    scene_files: list[Path],
    out: Path,
    *,
    rubric_path: str | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    jobs: int = 2,
    size: tuple[int, int] | None = None,
    against: str | None = None,
    diagnose: bool = True,
    cache_dir: Path | str | None = None,
    progress: Callable[[str], None] = print,
    program: ProgramOptions | None = None,
) -> list[dict[str, Any]]:
    from compare.apps.against import GRADE_DEFAULT, prepare, resolve_model
    from compare.judge.rubric import DEFAULT_RUBRIC_TEXT, load_rubric
    from compare.render.cache import RenderCache
    from compare.render.progress import Progress
    from scene_model.scene import load_scene

    rubric = load_rubric(rubric_path)  # validates before any work
    rubric_text = Path(rubric_path).read_text() if rubric_path else DEFAULT_RUBRIC_TEXT
    model = resolve_model(against, rubric, GRADE_DEFAULT)
    spec = resolve_spec(program, rubric.program)  # None: a class of images
    if spec is not None and spec.sandboxed:
        from compare.sandbox import require_sandbox

        require_sandbox()  # before any work: refuse rather than run students' code bare
    out.mkdir(parents=True, exist_ok=True)
    cache = RenderCache(cache_dir)
    models: dict[str, ModelRenders] = {}
    for scene_file in scene_files:
        scene = load_scene(scene_file)
        progress(f"model {model.name} on {scene.name} ...")
        renders = prepare(
            model,
            scene_file,
            size,
            cache,
            progress=progress if isinstance(progress, Progress) else None,
        )
        models[scene.name] = _beside(renders, scene.name, out / "references")
    h = hashlib.sha256()
    for name in sorted(models):
        h.update(name.encode() + models[name].digest().encode())
    models_key = h.hexdigest()[:24]
    # One render at a time per worker when workers run side by side; two for a lone one.
    diagnose_parallel = 0 if not diagnose else 1 if executor == "dask" or jobs > 1 else 2
    tasks = [
        GradeTask(
            student,
            files,
            problem,
            models,
            models_key,
            rubric_text,
            rubric.source,
            str(out),
            diagnose_parallel,
            str(cache.root / "candidates"),
            job,
        )
        for student, files, problem, job in _entries(
            submissions, models, spec, size, out, cache.root, progress
        )
    ]
    progress(f"grading {len(tasks)} submissions against {model.name} ({executor} executor)")
    start = time.perf_counter()
    results: list[dict[str, Any]] = []

    def arrived(r: dict[str, Any]) -> None:
        results.append(r)
        state = "resumed" if r.get("resumed") else f"{r['seconds']:.2f} s"
        progress(
            f"[{len(results)}/{len(tasks)}] {r['student']}: {r['status']} {r['score']:.1f} ({state})"
        )

    if executor == "dask":
        from dask.distributed import Client, as_completed

        if not scheduler:
            raise ValueError(
                "--executor dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)"
            )
        with Client(scheduler, timeout=30) as client:
            for future in as_completed(client.map(grade_one, tasks, pure=False)):
                arrived(future.result())
    elif executor == "local":
        if jobs <= 1:
            for t in tasks:
                arrived(grade_one(t))
        else:
            from concurrent.futures import as_completed as done

            with ProcessPoolExecutor(max_workers=jobs) as pool:
                for f in done([pool.submit(grade_one, t) for t in tasks]):
                    arrived(f.result())
    else:
        raise ValueError(f"unknown executor {executor!r} (expected local or dask)")
    results.sort(key=lambda r: str(r["student"]))
    elapsed = time.perf_counter() - start
    write_gradebook(results, out, rubric.source, elapsed)
    progress(
        f"graded {len(results)} in {elapsed:.1f} s ({sum(bool(r.get('resumed')) for r in results)} resumed)"
    )
    return results


def write_gradebook(results: list[dict[str, Any]], out: Path, rubric: str, seconds: float) -> None:
    rows: list[list[object]] = []  # written by csv_text, which neutralises formulas
    scenes = sorted({s["scene"] for r in results for s in r["scenes"]})
    rows.append(
        [
            "student",
            "status",
            "score",
            "model",
            *[f"{s} score" for s in scenes],
            *[f"{s} status" for s in scenes],
            "reasons",
            "diagnosis",
            "page",
        ]
    )
    for r in results:
        by = {s["scene"]: s for s in r["scenes"]}
        rows.append(
            [
                r["student"],
                r["status"],
                f"{r['score']:.2f}",
                r.get("model", ""),
                *[f"{by[s]['score']:.2f}" if s in by else "" for s in scenes],
                *[by[s]["status"] if s in by else "" for s in scenes],
                r["reasons"],
                r.get("diagnosis", ""),
                r["page"],
            ]
        )
    write_atomic(out / "gradebook.csv", csv_text(rows))
    summary = [
        {
            k: r.get(k, "")
            for k in ("student", "status", "score", "model", "reasons", "diagnosis", "page")
        }
        | {
            "scenes": {
                s["scene"]: {"status": s["status"], "score": s["score"]} for s in r["scenes"]
            }
        }
        for r in results
    ]
    write_atomic(
        out / "gradebook.json",
        json.dumps({"rubric": rubric, "seconds": seconds, "students": summary}, indent=2),
    )


def explain(out: Path, student: str) -> str:
    path = out / "results" / f"{student_slug(student)}.json"
    if not path.is_file():
        raise OSError(f"{path}: no result for {student!r} (run rtval grade first)")
    r = _load_result(path)
    if r is not None and r.get("student") != student:  # never a classmate's result
        raise OSError(f"{path}: holds the result of another id, not {student!r}")
    if r is None or not {"status", "score", "rubric", "scenes"} <= r.keys():
        raise OSError(
            f"{path}: the result for {student!r} is truncated or corrupt; "
            "run rtval grade again: it regrades this student"
        )
    lines = [
        f"{student}: {r['status'].upper()}, score {r['score']:.1f} = mean of the scene scores "
        f"(judged against {r.get('model') or 'mitsuba'}; rubric: {r['rubric']})"
    ]
    for s in r["scenes"]:
        lines.append(
            f"  scene {s['scene']}: {s['status']}, score {s['score']:.1f}"
            + (f" — {s['reason']}" if s.get("reason") else "")
        )
        v = s.get("verdict")
        if not v:
            continue
        total = sum(e["pixels"] * e["rule"]["weight"] for e in v["effects"].values()) or 1
        exact = v.get("basis") == "exact"
        for name, e in v["effects"].items():
            w = e["pixels"] * e["rule"]["weight"] / total
            if exact:
                how = f"{e['differing']} of {e['pixels']} px differ" + (
                    f", FLIP {e['flip']:.4f}" if e["flip"] is not None else ""
                )
            else:
                ssim = f"{e['ssim']:.4f}" if e["ssim"] is not None else "undefined"
                how = (
                    f"SSIM {ssim} (min {e['rule']['min_ssim']}), "
                    f"FLIP {e['flip']:.4f} (max {e['rule']['max_flip']})"
                )
            lines.append(
                f"    {name:<11} {e['status']:<4} {how}: score {e['score']:.1f} x weight "
                f"{w:.3f} = {e['score'] * w:.1f}"
            )
        if exact:
            lines.append(
                "    score = 100 x the share of the effect's pixels that match the model within "
                f"{v['exact']['rule']}, weighted by pixels x weight; an effect passes with at "
                f"most {v['exact']['stray_rule']} of its pixels differing; "
                f"pass needs every effect to pass and score >= {v['pass_score']}"
            )
        else:
            lines.append(
                f"    score = 100 (1 - FLIP / {v['flip_at_zero_score']}) per effect, weighted by "
                f"pixels x weight; pass needs every effect to pass and score >= {v['pass_score']}"
            )
    return "\n".join(lines)
