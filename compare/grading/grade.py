"""`rtval grade`: a class's renders against a target model, one gradebook.

A submission is an image (its file name is the student id; one --scene only) or a folder
of images named after the scenes. The model (--against, the rubric's `against`, else
`classic`: README "Grading a class") is rendered once per scene through the shared render
cache (the same entries `rtval report` makes); a demo model needs no Mitsuba render at all.
Every row names the model; every fail says why.
Each student is an idempotent task keyed by the hashes of its files, the model's renders and the
rubric: a re-run (or a resumed, interrupted one) skips what is done. Bad submissions become
rows with a reason, never an aborted batch. Tasks run in a local process pool or on a Dask
cluster (grade_executors.py); each gives a typed result (grade_results.py), summed up in the
gradebook (gradebook.py). Every folder written under OUT is made without following a link
(safe_paths.own_folder): a link planted there stops the run, naming it.

A submission that fails against a demo model is diagnosed (compare/diagnose/evidence.py): the
gradebook's `diagnosis` column and the fail reasons say what it looks like ("looks like Q2
(...)"), its page shows the evidence. Passing submissions cost nothing more; --no-diagnose
skips it. Candidate renders are entries of the render cache like any render, shared by every
student and worker.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import stat
import time
from collections.abc import Callable
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from compare.diagnose.evidence import EvidenceOptions, diagnose_image
from compare.diagnose.search import DiagnoseError
from compare.errors import ToolError
from compare.grading.class_page import write_class_page
from compare.grading.encodings import choose_encoding, with_encoding, with_encoding_cause
from compare.grading.executors import Executor, run_on_dask, run_tasks
from compare.grading.gradebook import write_gradebook
from compare.grading.lms import write_lms_exports
from compare.grading.programs import (
    ProgramJob,
    ProgramOptions,
    ProgramResult,
    ProgramSpec,
    build_and_run,
    program_entries,
    resolve_spec,
)
from compare.grading.results import (
    BadResult,
    SceneResult,
    StudentResult,
    discard_special,
    read_result,
)
from compare.grading.shipping import (
    Returned,
    Shipped,
    ShippedModels,
    cleanup,
    client_names,
    page_files,
    renamed,
    ship_images,
    ship_models,
    ship_program,
    task_folder,
    worker_paths,
)
from compare.grading.student_page import write_student_page
from compare.grading.submissions import (
    IMAGE_SUFFIXES,  # noqa: F401  (re-exported)
    collect_entries,
)
from compare.judge.images import ImageError, ImageSizeError, read_image
from compare.judge.png import FAST, display_values, write_display_png
from compare.judge.rubric import parse_rubric, read_rubric
from compare.judge.scoring import student_passes, student_score
from compare.judge.sentences import difference_sentences
from compare.render.cache import RenderCache
from compare.render.progress import Progress
from compare.render.ray_trees import page_trees
from compare.sandbox.bwrap import require_sandbox
from compare.student_ids import displayable, student_slug
from compare.verdict.against import (
    GRADE_DEFAULT,
    ModelRenders,
    load,
    nan_pixels,
    prepare,
    resolve_model,
)
from safe_files.content import sha256_file
from safe_files.paths import atomic_output, own_folder, write_atomic
from scene_model.scene import load_scene

if TYPE_CHECKING:
    from compare.diagnose.search import FlipSeed
    from compare.grading.programs import ProgramResult
    from compare.judge.arrays import F32
    from compare.judge.evaluate import Evaluation
    from compare.judge.exact_match import BOOL
    from compare.judge.images import Image
    from compare.judge.rubric import Rubric
    from compare.judge.target_model import TargetModel
    from compare.verdict.against import LoadedModel


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
    cache_root: str = ""  # the render cache, which also holds the diagnoses' candidate renders
    # A program submission (compare/grading/programs.py): built and run first, in the sandbox.
    program: ProgramJob | None = None
    scene_problems: dict[str, str] = dataclasses.field(default_factory=dict)  # failed runs
    test_encoding: str | None = None  # 8-bit images: None judges both (grading/encodings.py)


def task_key(task: GradeTask) -> str:
    h = hashlib.sha256(task.rubric_text.encode())
    h.update((task.problem or "").encode())
    h.update(task.models_key.encode())
    h.update(f"diagnose={bool(task.diagnose)}".encode())
    h.update(f"encoding={task.test_encoding or 'both'}".encode())
    if task.program is not None:  # its code, commands, limits and scenes
        h.update(task.program.digest().encode())
    for scene in sorted(task.files):
        f = task.files[scene]
        h.update(scene.encode())
        h.update((sha256_file(f) if f and _is_regular_file(Path(f)) else "missing").encode())
    return h.hexdigest()[:24]


def _grade_scene(
    scene_name: str, path: str | None, task: GradeTask, rubric: Rubric, page_dir: Path
) -> SceneResult:
    """One scene: not judged (with the reason) when there is no image of the right size to
    judge, else judged against the model."""

    model_name = task.models[scene_name].model
    if scene_name in task.scene_problems:  # the program's run gave no image: why
        return SceneResult(scene_name, model_name, "error", 0.0, task.scene_problems[scene_name])
    if path is None:
        return SceneResult(
            scene_name, model_name, "missing", 0.0, f"no image for scene '{scene_name}'"
        )
    model = load(task.models[scene_name])
    img = _read_submission(path, model.reference.shape)
    if isinstance(img, str):
        return SceneResult(scene_name, model_name, "error", 0.0, img)
    judged = choose_encoding(img, model, rubric, task.test_encoding)
    return with_encoding(_judge_scene(scene_name, judged, model, task, rubric, page_dir), judged[0])


def _read_submission(path: str, shape: tuple[int, int]) -> Image | str:
    """The submitted image, or why it cannot be judged. The size is checked in the header,
    before decoding: memory stays bounded."""

    try:
        return read_image(path, expected_size=shape)
    except ImageSizeError as e:
        (h, w), (eh, ew) = e.size, e.expected
        return f"wrong size {w}x{h}, expected {ew}x{eh}"
    except ImageError as e:
        return f"unreadable: {e}"


def _judge_scene(
    scene_name: str,
    judged: tuple[Image, Evaluation],
    model: LoadedModel,
    task: GradeTask,
    rubric: Rubric,
    page_dir: Path,
) -> SceneResult:
    """The verdict, the reasons and the sentences of a scene's image; a failing image against
    a demo model is diagnosed. Writes the image and its difference for the page."""

    img, ev = judged
    nan = nan_pixels(img)
    verdict, reasons = _verdict(ev, nan)
    # Against a demo model the reasons say what differs; the sentences' SSIM and full FLIP maps
    # would double a failing submission's cost (bench/bench_grade.py).
    sentences = (
        difference_sentences(
            model.reference.rgb,
            img.rgb,
            model.masks,
            ev.effect_metrics(),
            f"{task.student}'s render",
        )
        if ev.exact is None
        else list(reasons)
    )
    diagnosis = None
    if verdict["status"] != "pass" and task.diagnose and model.target.is_demo:
        known = ev.known_flip()  # the verdict's FLIP: the diagnosis' starts from it
        seed = None if known is None else (model.reference.rgb, *known)
        diagnosis = _diagnose_scene(img, scene_name, task.models[scene_name], task, page_dir, seed)
        diagnosis = with_encoding_cause(diagnosis, img)
        reasons.append(diagnosis["short"])
    matches = ev.exact.matches if ev.exact is not None else None
    if diagnosis is not None and matches is not None:
        assert ev.score is not None  # _verdict needs it too
        failing = {k: model.masks[k] for k in ev.score.failing_effects if k in model.masks}
        diagnosis["ray_trees"] = page_trees(
            model.renders.scene_file, model.target.rtdemo_args(), img.rgb, ~matches, failing
        )
    _write_scene_pictures(page_dir, scene_name, model.reference.rgb, img.rgb, matches)
    return SceneResult(
        scene_name,
        model.renders.model,
        verdict["status"],
        verdict["score"],
        "; ".join(reasons),
        diagnosis=diagnosis["short"] if diagnosis else "",
        verdict=verdict,
        sentences=tuple(sentences),
        nan_pixels=nan,
        diagnosis_detail=diagnosis,
    )


def _verdict(ev: Evaluation, nan: int) -> tuple[dict[str, Any], list[str]]:
    """The scene's verdict as stored, and its reasons; NaN/Inf pixels fail it."""
    assert ev.score is not None  # the model's masks were given
    verdict = ev.score.as_dict()
    reasons = ev.score.reasons()
    if ev.exact is not None:
        verdict["exact"] = ev.exact.as_dict()
    if nan and ev.exact is None:  # exact judging already counts NaN pixels as differing
        verdict["status"] = "fail"
        reasons.insert(0, f"{nan} NaN/Inf pixels")
    return verdict, reasons


def _write_scene_pictures(
    page_dir: Path, scene_name: str, reference: F32, test: F32, matches: BOOL | None = None
) -> None:
    """The submission, the model and |difference| x 8 (display), for the student's page;
    NaN/Inf pixels in the marker colour (compare/judge/png.py). Judged exactly, a pixel that
    matches is black: what is left of 8-bit rounding there is no difference."""

    a, b = display_values(reference), display_values(test)
    write_display_png(page_dir / f"{scene_name}.png", b, compress_level=FAST)
    write_display_png(page_dir / f"{scene_name}-model.png", a, compress_level=FAST)
    diff = np.clip(np.abs(a - b) * 8, 0, 1)
    if matches is not None:
        diff = np.where(matches[..., None], np.float32(0), diff)
    write_display_png(page_dir / f"{scene_name}-diff.png", diff, compress_level=FAST)


def _diagnose_scene(
    img: Any,
    scene_name: str,
    renders: ModelRenders,
    task: GradeTask,
    page_dir: Path,
    flip_seed: FlipSeed | None,
) -> dict[str, Any]:
    """What a failing submission looks like; a diagnosis that cannot run says why in the
    cell instead of failing the student's grading."""

    try:
        return diagnose_image(
            img,
            renders.scene_file,
            task.cache_root,
            page_dir,
            EvidenceOptions(
                prefix=f"{scene_name}-diagnosis",
                assigned=renders.model,
                parallel=task.diagnose,
                flip_seed=flip_seed,
            ),
        )
    except (DiagnoseError, ToolError, OSError) as e:
        return {"short": f"no diagnosis: {e}", "sentences": [], "evidence": []}


def grade_one(task: GradeTask) -> StudentResult:
    """Grades one student; returns (and stores) the result. Idempotent: a result with the
    same key on disk is returned as is. A stored file that is not a result (truncated, a
    link, a FIFO) is graded again, with a warning naming it."""

    out = Path(task.out_dir)
    slug = student_slug(task.student)  # the id on disk; the real id stays in the result
    result_path = own_folder(out, "results") / f"{slug}.json"
    key = task_key(task)
    old, warnings = _stored_result(result_path, task.student, key)
    if old is not None:
        return old.as_resumed()
    rubric = parse_rubric(task.rubric_text, task.rubric_source)
    page_dir = own_folder(out, "students", slug)
    start = time.perf_counter()
    program = None
    if task.program is not None and not task.problem:  # build and run it, then grade as images
        task, program = _run_program(task, out, slug)
    if task.problem:
        scenes = [
            SceneResult(s, task.models[s].model, "error", 0.0, task.problem) for s in task.files
        ]
    else:
        scenes = [_grade_scene(s, p, task, rubric, page_dir) for s, p in sorted(task.files.items())]
    result = _student_result(task, key, scenes, rubric, slug)
    result = dataclasses.replace(
        result,
        seconds=time.perf_counter() - start,
        program=program.info if program is not None else None,
        warnings=warnings,
    )
    write_student_page(page_dir, result)
    if program is None or not program.transient:  # the machine's trouble is never kept
        write_atomic(result_path, result.dumps())
    return result


def grade_safely(task: GradeTask) -> StudentResult:
    """grade_one, where anything that goes wrong inside one submission's grading (a bug, a
    tree too deep for some walk, the machine out of memory or descriptors) becomes that
    student's row, stored nowhere: the next run grades it again. The class goes on."""
    try:
        return grade_one(task)
    except Exception as e:  # one student's failure must not end the class
        return not_graded(task, displayable(str(e)[:300]) or "an internal error")


def not_graded(task: GradeTask, why: str) -> StudentResult:
    """The row of a student whose grading failed on rtval's side (never stored)."""
    reason = f"not graded: {why} (grading failed here, not the program; run again)"
    scenes = tuple(
        SceneResult(s, task.models[s].model, "error", 0.0, reason) for s in sorted(task.files)
    )
    return StudentResult(
        student=task.student,
        key="",
        status="fail",
        score=0.0,
        model=", ".join(sorted({s.model for s in scenes})),
        reasons=reason,
        diagnosis="",
        scenes=scenes,
        rubric=task.rubric_source,
        seconds=0.0,
        page=f"students/{student_slug(task.student)}/index.html",
    )


def _run_all(
    tasks: list[GradeTask], arrived: Callable[[StudentResult], None], where: Executor
) -> None:
    """Every task's result, or its row: a worker process that dies (the kernel's OOM killer)
    breaks the pool, and each student not graded yet gets a row saying so."""
    done: set[str] = set()

    def note(r: StudentResult) -> None:
        done.add(r.student)
        arrived(r)

    if where.kind == "dask":  # workers see nothing of this machine: inputs travel
        _run_shipped(tasks, note, where)
        return
    try:
        run_tasks(grade_safely, tasks, note, where)
    except BrokenProcessPool:
        for t in tasks:
            if t.student not in done:
                note(not_graded(t, "a grading process died (the machine out of memory?)"))


def _run_shipped(
    tasks: list[GradeTask], arrived: Callable[[StudentResult], None], where: Executor
) -> None:
    """On a Dask cluster: a result stored here under the task's key is resumed here; every
    other task travels with its inputs (shipping.py), and what comes back is written here."""
    if not tasks:
        return
    out = Path(tasks[0].out_dir)
    pending = []
    for t in tasks:
        key = task_key(t)
        path = own_folder(out, "results") / f"{student_slug(t.student)}.json"
        old, warnings = _stored_result(path, t.student, key)
        if old is not None:
            arrived(old.as_resumed())
            continue
        try:
            images = ship_images(t.files)
            program = ship_program(t.program.source) if t.program and not t.problem else None
        except (OSError, ValueError) as e:  # too large, or gone: that student's row
            arrived(not_graded(t, displayable(str(e)[:300])))
            continue
        pending.append(Shipped(t, key, images, program, warnings))
    shared = ship_models(tasks[0].models, tasks[0].models_key)
    run_on_dask(
        grade_shipped,
        pending,
        shared,
        lambda back: arrived(_write_returned(back, out)),
        _shipped_failed,
        where,
    )


def grade_shipped(shipped: Shipped, shared: ShippedModels) -> Returned:
    """On a Dask worker: the task graded in a folder of the worker's own (under its TMPDIR),
    with the worker's own render cache; the row, the result to store and the student's page
    come back as bytes. The folder goes afterwards."""
    task = shipped.task
    assert isinstance(task, GradeTask)
    folder = task_folder()
    try:
        local = dataclasses.replace(task, **worker_paths(shipped, shared, folder, RenderCache()))
        names = client_names(local.files, task.files)
        if local.program is not None and task.program is not None:
            names[local.program.source] = task.program.source
        result = dataclasses.replace(grade_safely(local), key=shipped.key)
        result = StudentResult.from_json(json.loads(renamed(result.dumps(), names)))
        slug = student_slug(task.student)
        stored = (Path(local.out_dir) / "results" / f"{slug}.json").is_file()
        pages = page_files(Path(local.out_dir), slug)
        text = result.dumps() if stored else None
        return Returned(dataclasses.replace(result, warnings=shipped.warnings), text, pages)
    except Exception as e:  # the worker's disk or memory: that student's row says so
        return Returned(not_graded(task, displayable(str(e)[:300]) or "an internal error"))
    finally:
        cleanup(folder)


def _shipped_failed(shipped: Shipped, why: str) -> Returned:
    assert isinstance(shipped.task, GradeTask)
    return Returned(not_graded(shipped.task, why))


def _write_returned(back: Returned, out: Path) -> StudentResult:
    """A worker's result written under OUT: the page's files, and the result unless the
    machine failed (then the next run grades it again)."""
    r = back.result
    assert isinstance(r, StudentResult)
    slug = student_slug(r.student)
    page_dir = own_folder(out, "students", slug)
    for rel, data in back.page_files.items():
        *folders, name = rel.split("/")
        write_atomic(own_folder(page_dir, *folders) / name, data)
    if back.stored is not None:
        write_atomic(own_folder(out, "results") / f"{slug}.json", back.stored)
    return r


def _stored_result(
    path: Path, student: str, key: str
) -> tuple[StudentResult | None, tuple[str, ...]]:
    """The stored result when it is this student's and made from these inputs; else None,
    with a warning when the file there is not a result at all."""
    try:
        old = read_result(path)
    except BadResult as e:
        discard_special(path)  # a planted link or FIFO goes; the new result takes its place
        return None, (f"{e}: graded again",)
    if old is not None and old.key == key and old.student == student:
        return old, ()
    return None, ()


def _run_program(task: GradeTask, out: Path, slug: str) -> tuple[GradeTask, ProgramResult]:
    """A program submission built and run in the sandbox: the task, now of its images."""

    assert task.program is not None
    program = build_and_run(task.program, own_folder(out, "programs", slug))
    task = dataclasses.replace(
        task, files=program.files, problem=program.problem, scene_problems=program.scene_problems
    )
    return task, program


def _student_result(
    task: GradeTask, key: str, scenes: list[SceneResult], rubric: Rubric, slug: str
) -> StudentResult:
    """The scenes summed up: the score and the verdict (scoring.py's), the reasons of every
    failing scene and the diagnoses of the failing ones."""
    score = student_score([s.score for s in scenes])
    passed = student_passes([s.status for s in scenes], score, rubric.pass_score)
    reasons = "; ".join(f"{s.scene}: {s.reason}" for s in scenes if s.reason)
    if not passed and not reasons:  # every scene passed, the mean is short of pass_score
        reasons = f"score {score:.1f} < {rubric.pass_score:g}"
    return StudentResult(
        student=task.student,
        key=key,
        status="pass" if passed else "fail",
        score=score,
        model=", ".join(sorted({s.model for s in scenes})),
        reasons=reasons,
        # Failing scenes against a demo model: what they look like (compare/diagnose/evidence.py).
        diagnosis="; ".join(
            (f"{s.scene}: " if len(scenes) > 1 else "") + s.diagnosis for s in scenes if s.diagnosis
        ),
        scenes=tuple(scenes),
        rubric=rubric.source,
        seconds=0.0,
        page=f"students/{slug}/index.html",
    )


class Submission(NamedTuple):
    """One student's row before grading: the images per scene (None: missing), why it
    cannot be graded at all (None: it can), and the program to build first, if any."""

    student: str
    files: dict[str, str | None]
    problem: str | None
    program: ProgramJob | None = None


def collect(
    submissions: Path,
    scenes: list[str],
    *,
    exclude: list[Path] | None = None,
    notice: Callable[[str], None] | None = None,
) -> list[Submission]:
    """Every id in the submissions folder (see compare/grading/submissions.py: what is a
    submission, and the reasons for what is not)."""

    return [
        Submission(e.student, e.files, "; ".join(e.problems) or None)
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
) -> list[Submission]:
    """Every submission: images, or programs to build and run when the class has a
    [program] (compare/grading/programs.py)."""
    if spec is None:
        return collect(submissions, list(models), exclude=[out], notice=progress)
    found = program_entries(submissions, models, spec, size, out, cache_root, progress)
    return [Submission(*entry) for entry in found]


def _copy_model_renders_out(renders: ModelRenders, scene_name: str, folder: Path) -> ModelRenders:
    """The model's renders copied out of the shared cache beside the grades, as
    references/SCENE-MODEL.exr (and -offsetN.exr): the tasks (maybe on other machines) read
    them from there. A copy already there with the same bytes stays; anything else at that
    name (a planted link included) is replaced or refused, never followed."""
    stem = student_slug(f"{scene_name}-{renders.model}")  # names from the scene file: made safe

    def copy(src: str, suffix: str) -> str:
        target = folder / f"{stem}{suffix}.exr"
        if not (_is_regular_file(target) and sha256_file(target) == sha256_file(src)):
            with atomic_output(target) as tmp:
                shutil.copyfile(src, tmp)
        return str(target)

    return dataclasses.replace(
        renders,
        reference=copy(renders.reference, ""),
        offsets=tuple(copy(p, f"-offset{i}") for i, p in enumerate(renders.offsets)),
    )


def _is_regular_file(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


@dataclass(frozen=True)
class GradingRun:
    """How a class is graded, besides what and where (run_grading's arguments)."""

    rubric_path: str | None = None
    executor: Executor = dataclasses.field(default_factory=Executor)
    size: tuple[int, int] | None = None
    against: TargetModel | None = None  # None: the rubric's, else classic
    diagnose: bool = True
    cache: RenderCache = dataclasses.field(default_factory=RenderCache)  # the shared one
    progress: Callable[[str], None] = print
    program: ProgramOptions | None = None
    test_encoding: str | None = None  # None: an 8-bit file judged in both encodings


def run_grading(
    submissions: Path, scene_files: list[Path], out: Path, options: GradingRun = GradingRun()
) -> list[StudentResult]:
    """Grades every submission; writes the pages, the results and the gradebook."""
    where, progress = options.executor, options.progress
    where.check()
    rubric_text, rubric, model, spec = _class_setup(
        options.rubric_path, options.against, options.program
    )
    out.mkdir(parents=True, exist_ok=True)
    cache = options.cache
    models = _model_renders(model, scene_files, options.size, cache, out, progress)
    parallel = 0 if not options.diagnose else 1 if where.side_by_side else 2
    base = _base_task(models, rubric_text, rubric, out, cache, parallel)
    base = dataclasses.replace(base, test_encoding=options.test_encoding)
    found = _entries(submissions, models, spec, options.size, out, cache.root, progress)
    tasks = [dataclasses.replace(base, **entry._asdict()) for entry in found]
    own_folder(out, "results")  # every folder a task writes, checked here: a planted link
    for t in tasks:  # stops the run before any work
        own_folder(out, "students", student_slug(t.student))
    progress(f"grading {len(tasks)} submissions against {model.name} ({where.kind} executor)")
    start = time.perf_counter()
    results: list[StudentResult] = []
    arrived = _arrived(results, len(tasks), progress)
    _run_all(tasks, arrived, where)
    results.sort(key=lambda r: r.student)
    elapsed = time.perf_counter() - start
    write_gradebook(results, out, rubric.source, elapsed)
    write_class_page(results, out, rubric.source)
    write_lms_exports(results, out)
    progress(
        f"graded {len(results)} in {elapsed:.1f} s ({sum(r.resumed for r in results)} resumed)"
    )
    return results


def _base_task(
    models: dict[str, ModelRenders],
    rubric_text: str,
    rubric: Rubric,
    out: Path,
    cache: RenderCache,
    diagnose: int,
) -> GradeTask:
    """What every student's task shares. `diagnose`: renders at once per diagnosis (one per
    worker when workers run side by side, two for a lone one; 0: no diagnosis)."""
    return GradeTask(
        student="",
        files={},
        problem=None,
        models=models,
        models_key=_models_key(models),
        rubric_text=rubric_text,
        rubric_source=rubric.source,
        out_dir=str(out),
        diagnose=diagnose,
        cache_root=str(cache.root),
    )


def _class_setup(
    rubric_path: str | None, against: TargetModel | None, program: ProgramOptions | None
) -> tuple[str, Rubric, TargetModel, ProgramSpec | None]:
    """The rubric (its text, parsed), the model and the program spec (None: a class of
    images), each checked before any work: a sandboxed class needs a sandbox."""

    rubric_text, rubric_source = read_rubric(rubric_path)
    rubric = parse_rubric(rubric_text, rubric_source)
    model = resolve_model(against, rubric, GRADE_DEFAULT)
    spec = resolve_spec(program, rubric.program)
    if spec is not None and spec.sandboxed:
        require_sandbox()  # refuse rather than run students' code bare
    return rubric_text, rubric, model, spec


def _model_renders(
    model: TargetModel,
    scene_files: list[Path],
    size: tuple[int, int] | None,
    cache: RenderCache,
    out: Path,
    progress: Callable[[str], None],
) -> dict[str, ModelRenders]:
    """scene name -> the model's renders of it, rendered (or found) in the shared cache and
    copied to OUT/references."""

    folder = own_folder(out, "references")
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
        models[scene.name] = _copy_model_renders_out(renders, scene.name, folder)
    return models


def _models_key(models: dict[str, ModelRenders]) -> str:
    """A digest of every model render (computed once, not per student)."""
    h = hashlib.sha256()
    for name in sorted(models):
        h.update(name.encode() + models[name].digest().encode())
    return h.hexdigest()[:24]


def _arrived(
    results: list[StudentResult], total: int, progress: Callable[[str], None]
) -> Callable[[StudentResult], None]:
    """Collects each result as it arrives, with a progress line (and its warnings)."""

    def arrived(r: StudentResult) -> None:
        results.append(r)
        for warning in r.warnings:
            progress(f"warning: {warning}")
        state = "resumed" if r.resumed else f"{r.seconds:.2f} s"
        progress(f"[{len(results)}/{total}] {r.student}: {r.status} {r.score:.1f} ({state})")

    return arrived
