"""`rtval grade`: a class's renders against the references, one gradebook.

A submission is an image (its file name is the student id; one --scene only) or a folder
of images named after the scenes. References come from the shared render cache (the same
entry `rtval report` makes), rendered only when missing.
Each student is an idempotent task keyed by the hashes of its files, the references and the
rubric: a re-run (or a resumed, interrupted one) skips what is done. Bad submissions become
rows with a reason, never an aborted batch. Tasks run in a local process pool or on a Dask
cluster.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.files import sha256_file, write_atomic

IMAGE_SUFFIXES = (".exr", ".png", ".ppm", ".pfm")


@dataclass(frozen=True)
class GradeTask:
    student: str
    files: dict[str, str | None]  # scene name -> image path (None: missing)
    problem: str | None  # a reason the submission cannot be graded at all
    references: dict[str, str]  # scene name -> reference EXR
    scene_files: dict[str, str]
    rubric_text: str
    rubric_source: str
    out_dir: str


def task_key(task: GradeTask) -> str:
    h = hashlib.sha256(task.rubric_text.encode())
    h.update((task.problem or "").encode())
    for scene in sorted(task.files):
        f = task.files[scene]
        h.update(scene.encode())
        h.update((sha256_file(Path(f)) if f and Path(f).is_file() else "missing").encode())
        h.update(sha256_file(Path(task.references[scene])).encode())
    return h.hexdigest()[:24]


def _grade_scene(
    scene_name: str, path: str | None, task: GradeTask, rubric: Any, page_dir: Path
) -> dict[str, Any]:
    from compare.judge.effects import effect_masks
    from compare.judge.evaluate import evaluate_pair
    from compare.judge.images import ImageError, read_image
    from compare.judge.sentences import difference_sentences
    from scene_model.scene import load_scene

    if path is None:
        return {
            "scene": scene_name,
            "status": "missing",
            "score": 0.0,
            "reason": f"no image for scene '{scene_name}'",
        }
    ref = read_image(task.references[scene_name])
    try:
        img = read_image(path)
    except ImageError as e:
        return {"scene": scene_name, "status": "error", "score": 0.0, "reason": f"unreadable: {e}"}
    if img.shape != ref.shape:
        return {
            "scene": scene_name,
            "status": "error",
            "score": 0.0,
            "reason": f"wrong size {img.shape[1]}x{img.shape[0]}, expected {ref.shape[1]}x{ref.shape[0]}",
        }
    nan = int((~np.isfinite(img.rgb)).any(-1).sum())
    scene = load_scene(task.scene_files[scene_name])
    masks = effect_masks(scene, ref.aovs["id"], ref.aovs["depth"])
    ev = evaluate_pair(
        ref.rgb,
        img.rgb,
        masks=masks,
        rules=rubric.effects,
        flip_at_zero=rubric.flip_at_zero,
        pass_score=rubric.pass_score,
    )
    assert ev.score is not None  # masks were given
    verdict = ev.score.as_dict()
    reason = ""
    if nan:
        verdict["status"] = "fail"
        reason = f"{nan} NaN/Inf pixels"
    sentences = difference_sentences(
        ref.rgb, img.rgb, masks, ev.effect_metrics(), f"{task.student}'s render"
    )
    # Pictures for the student's page: the submission and |difference| x 8 (display).
    from PIL import Image as PILImage

    from compare.judge.images import linear_to_srgb

    a, b = linear_to_srgb(ref.rgb), linear_to_srgb(img.rgb)
    for name, data in (
        (f"{scene_name}.png", b),
        (f"{scene_name}-diff.png", np.clip(np.abs(a - b) * 8, 0, 1)),
    ):
        buf = io.BytesIO()
        PILImage.fromarray(np.round(data * 255).astype(np.uint8)).save(buf, format="PNG")
        write_atomic(page_dir / name, buf.getvalue())
    return {
        "scene": scene_name,
        "status": verdict["status"],
        "score": verdict["score"],
        "reason": reason,
        "verdict": verdict,
        "sentences": sentences,
        "nan_pixels": nan,
    }


def grade_one(task: GradeTask) -> dict[str, Any]:
    """Grades one student; returns (and stores) the result. Idempotent: a result with the
    same key on disk is returned as is."""
    from jinja2 import Environment, PackageLoader, select_autoescape

    from compare.judge.rubric import parse_rubric

    out = Path(task.out_dir)
    result_path = out / "results" / f"{task.student}.json"
    key = task_key(task)
    if result_path.is_file():
        old = json.loads(result_path.read_text())
        if old.get("key") == key:
            return {**old, "resumed": True}
    rubric = parse_rubric(task.rubric_text, task.rubric_source)
    page_dir = out / "students" / task.student
    page_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    if task.problem:
        scenes = [
            {"scene": s, "status": "error", "score": 0.0, "reason": task.problem}
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
    result = {
        "student": task.student,
        "key": key,
        "status": status,
        "score": score,
        "reasons": reasons,
        "scenes": scenes,
        "rubric": rubric.source,
        "seconds": time.perf_counter() - start,
        "page": f"students/{task.student}/index.html",
    }
    env = Environment(
        loader=PackageLoader("compare.apps", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    write_atomic(page_dir / "index.html", env.get_template("student.html.j2").render(r=result))
    (out / "results").mkdir(exist_ok=True)
    write_atomic(result_path, json.dumps(result, indent=2, default=float))
    return result


def collect(
    submissions: Path, scenes: list[str]
) -> list[tuple[str, dict[str, str | None], str | None]]:
    """(student, scene -> file, problem) for every entry of the submissions folder."""
    if not submissions.is_dir():
        raise OSError(f"{submissions}: not a folder of submissions")
    out = []
    for entry in sorted(submissions.iterdir()):
        if entry.name.startswith("."):
            continue
        student = entry.stem if entry.is_file() else entry.name
        files: dict[str, str | None] = dict.fromkeys(scenes)
        problem = None
        if entry.is_file():
            if entry.suffix.lower() not in IMAGE_SUFFIXES:
                problem = (
                    f"unsupported file type '{entry.suffix}' (expected {', '.join(IMAGE_SUFFIXES)})"
                )
            elif len(scenes) > 1:
                problem = "one image for several scenes: hand in a folder with one image per scene"
            else:
                files[scenes[0]] = str(entry)
        else:
            for scene in scenes:
                hits = [
                    p
                    for p in sorted(entry.iterdir())
                    if p.stem == scene and p.suffix.lower() in IMAGE_SUFFIXES
                ]
                files[scene] = str(hits[0]) if hits else None
        out.append((student, files, problem))
    return out


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
    cache_dir: Path | str | None = None,
    progress: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    from compare.judge.rubric import DEFAULT_RUBRIC_TEXT, load_rubric
    from compare.render.cache import RenderCache
    from compare.render.jobs import run_jobs
    from compare.render.plan import REFERENCE_KEY, plan
    from compare.render.progress import Progress
    from scene_model.scene import load_scene

    rubric = load_rubric(rubric_path)  # validates before any work
    rubric_text = Path(rubric_path).read_text() if rubric_path else DEFAULT_RUBRIC_TEXT
    out.mkdir(parents=True, exist_ok=True)
    (out / "references").mkdir(exist_ok=True)
    cache = RenderCache(cache_dir)
    names = {}
    references = {}
    ref_jobs = []
    for scene_file in scene_files:
        scene = load_scene(scene_file)
        names[scene.name] = str(scene_file)
        # The report's own reference job: the same command, so the same cache entry.
        job = next(j for j in plan(str(scene_file), size) if j.key == REFERENCE_KEY)
        job.key, job.label = scene.name, f"reference of {scene.name}: {job.label}"
        ref_jobs.append(job)
    run_jobs(ref_jobs, cache, progress=progress if isinstance(progress, Progress) else Progress())
    for job in ref_jobs:
        # A copy beside the grades: the tasks (maybe on other machines) read it from there.
        target = out / "references" / f"{job.key}.exr"
        if not (target.is_file() and sha256_file(target) == job.info["sha256"]):
            cache.copy_out(job.cache_key, target)
        references[job.key] = str(target)
    tasks = [
        GradeTask(student, files, problem, references, names, rubric_text, rubric.source, str(out))
        for student, files, problem in collect(submissions, list(names))
    ]
    progress(f"grading {len(tasks)} submissions ({executor} executor)")
    start = time.perf_counter()
    if executor == "dask":
        from dask.distributed import Client

        if not scheduler:
            raise ValueError(
                "--executor dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)"
            )
        with Client(scheduler, timeout=30) as client:
            futures = client.map(grade_one, tasks, pure=False)
            results = list(client.gather(futures))
    elif executor == "local":
        if jobs <= 1:
            results = [grade_one(t) for t in tasks]
        else:
            with ProcessPoolExecutor(max_workers=jobs) as pool:
                results = list(pool.map(grade_one, tasks))
    else:
        raise ValueError(f"unknown executor {executor!r} (expected local or dask)")
    elapsed = time.perf_counter() - start
    write_gradebook(results, out, rubric.source, elapsed)
    progress(
        f"graded {len(results)} in {elapsed:.1f} s ({sum(bool(r.get('resumed')) for r in results)} resumed)"
    )
    return results


def write_gradebook(results: list[dict[str, Any]], out: Path, rubric: str, seconds: float) -> None:
    buf = io.StringIO()
    w = csv.writer(buf)
    scenes = sorted({s["scene"] for r in results for s in r["scenes"]})
    w.writerow(
        [
            "student",
            "status",
            "score",
            *[f"{s} score" for s in scenes],
            *[f"{s} status" for s in scenes],
            "reasons",
            "page",
        ]
    )
    for r in results:
        by = {s["scene"]: s for s in r["scenes"]}
        w.writerow(
            [
                r["student"],
                r["status"],
                f"{r['score']:.2f}",
                *[f"{by[s]['score']:.2f}" if s in by else "" for s in scenes],
                *[by[s]["status"] if s in by else "" for s in scenes],
                r["reasons"],
                r["page"],
            ]
        )
    write_atomic(out / "gradebook.csv", buf.getvalue())
    summary = [
        {k: r[k] for k in ("student", "status", "score", "reasons", "page")}
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
    path = out / "results" / f"{student}.json"
    if not path.is_file():
        raise OSError(f"{path}: no result for '{student}' (run rtval grade first)")
    r = json.loads(path.read_text())
    lines = [
        f"{student}: {r['status'].upper()}, score {r['score']:.1f} = mean of the scene scores "
        f"(rubric: {r['rubric']})"
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
        for name, e in v["effects"].items():
            w = e["pixels"] * e["rule"]["weight"] / total
            lines.append(
                f"    {name:<11} {e['status']:<4} SSIM {e['ssim']:.4f} (min {e['rule']['min_ssim']}), "
                f"FLIP {e['flip']:.4f} (max {e['rule']['max_flip']}): score {e['score']:.1f} x weight "
                f"{w:.3f} = {e['score'] * w:.1f}"
            )
        lines.append(
            f"    score = 100 (1 - FLIP / {v['flip_at_zero_score']}) per effect, weighted by pixels x weight; "
            f"pass needs every effect to pass and score >= {v['pass_score']}"
        )
    return "\n".join(lines)
