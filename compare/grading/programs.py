"""Program submissions: a student's source built once and run once per scene, in the sandbox
(compare/sandbox/bwrap.py), turned into the image files that grading then judges as usual.

    rtval grade SUBMISSIONS --scene classic --build 'g++ -O2 -o rt *.cpp' --run './rt {scene} {out}'

Each submission (a folder, .zip, .tar.gz) is copied or unpacked into a fresh folder
(compare/sandbox/archives.py), built there by --build, and the built folder is copied afresh for
every scene, where --run renders it: {scene}, {out}, {width}, {height}, ... are the
placeholders of `rtval check --renderer` (compare/render/foreign.py parses them), or the
program writes a fixed file named by --output. Everything ends as a reason: "build failed:
rt.cpp:3:1: error: ...", "timed out after 60 s", "killed: memory limit 2 GiB", "crashed:
SIGSEGV", "exit 3", "no output", "output is not a regular file", "output too large".

A finished build is kept under OUT/programs/SLUG/build, keyed by the submission's content
hash, the build command and its limits; each run under OUT/programs/SLUG/runs/SCENE, keyed by
the build, the run command, the scene and the size: a re-run (a changed rubric, an
interrupted class) builds and runs only what changed.
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
import re
import shlex
import shutil
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from compare.grading.submissions import IMAGE_SUFFIXES, collect_programs
from compare.judge.image_kinds import output_problem
from compare.judge.rubric import limit_value
from compare.render.foreign import PLACEHOLDERS, TemplateError, _write_xml
from compare.render.foreign import parse_command as parse_renderer
from compare.render.placeholders import PLACEHOLDER, fill
from compare.sandbox.archives import TreeError, TreeLimits, archive_suffix, copy_tree, unpack
from compare.sandbox.archives import source_digest as tree_digest
from compare.sandbox.bwrap import Collect, Limits, Outcome, Workspace, probe, run_sandboxed
from compare.sandbox.output import read_output
from compare.sandbox.trees import remove_tree
from compare.sizes import human_size
from compare.student_ids import displayable, student_slug
from safe_files.content import sha256_file
from safe_files.paths import write_atomic
from scene_model.scene import load_scene

BUILD_LIMITS = Limits(time=120.0)
RUN_LIMITS = Limits(time=60.0)
TREE_LIMITS = TreeLimits()
_FIRST_ERROR = re.compile(r": (?:fatal )?error:|undefined reference|error\[|^error:", re.I)
_ANY_ERROR = re.compile(r"\berror\b", re.I)
TRANSIENT = ("sandbox", "busy", "host_oom")  # outcomes the machine caused: never kept
_CONTROL = re.compile(r"\x1b\[[0-9;]*[A-Za-z]|[\x00-\x08\x0b-\x1f\x7f]")


@dataclass(frozen=True)
class ProgramSpec:
    """How every student's program is built and run (the same for the whole class)."""

    run: tuple[str, ...]  # words with placeholders
    build: tuple[str, ...] = ()  # none: nothing to build (a script)
    output: str | None = None  # a fixed file the program writes, instead of {out}
    output_format: str = "ppm"  # the format {out} names
    build_limits: Limits = BUILD_LIMITS
    run_limits: Limits = RUN_LIMITS
    tree: TreeLimits = TREE_LIMITS
    sandboxed: bool = True
    allow_binaries: bool = False  # prebuilt ELF files in a submission: refused unless True

    def digest(self, *parts: str) -> str:
        h = hashlib.sha256(json.dumps(asdict(self), sort_keys=True, default=str).encode())
        for p in parts:
            h.update(b"\0" + p.encode())
        return h.hexdigest()[:24]


@dataclass(frozen=True)
class ProgramOptions:
    """What the command line says; None leaves the rubric's [program] value or the default."""

    build: str | None = None
    run: str | None = None
    output: str | None = None
    output_format: str | None = None
    unsandboxed: bool = False
    allow_binaries: bool = False
    limits: Mapping[str, Any] = field(default_factory=dict)  # keys of LIMIT_KEYS


# [program.limits] keys (compare/judge/rubric.py checks them; the flags use the same names)
# -> (the build's limits, the run's, or both; the Limits field)
LIMIT_KEYS: dict[str, tuple[str, str]] = {
    "build_timeout": ("build", "time"),
    "run_timeout": ("run", "time"),
    "disk": ("both", "disk"),
    "cpu": ("both", "cpu"),
    "memory": ("both", "memory"),
    "file_size": ("both", "file_size"),
    "processes": ("both", "processes"),
    "open_files": ("both", "open_files"),
}


def resolve_spec(
    options: ProgramOptions | None, table: Mapping[str, Any] | None
) -> ProgramSpec | None:
    """The class's ProgramSpec from the flags over the rubric's [program] table, or None when
    neither asks for programs (an image class). TemplateError names what is wrong."""
    options = options or ProgramOptions()
    table = table or {}
    run = options.run or table.get("run")
    build = options.build or table.get("build")
    if not run:
        if build:
            raise TemplateError("--build needs --run: how is the built program run?")
        return None
    output = options.output or table.get("output")
    fmt = options.output_format or table.get("output_format") or "ppm"
    limits = {**dict(table.get("limits", {})), **dict(options.limits)}
    changes: dict[str, dict[str, Any]] = {"build": {}, "run": {}}
    for key, value in limits.items():
        which, name = LIMIT_KEYS[key]
        for side in ("build", "run"):
            if which in (side, "both"):
                changes[side][name] = limit_value(key, value)
    build_limits = replace(BUILD_LIMITS, **changes["build"])
    run_limits = replace(RUN_LIMITS, **changes["run"])
    return ProgramSpec(
        run=parse_run(run, output, fmt),
        build=parse_build(build) if build else (),
        output=check_output_name(output) if output else None,
        output_format=fmt,
        build_limits=build_limits,
        run_limits=run_limits,
        sandboxed=not options.unsandboxed,
        allow_binaries=options.allow_binaries,
    )


def parse_run(template: str, output: str | None, fmt: str) -> tuple[str, ...]:
    """--run checked by check's own parser. With --output the program writes a fixed file, so
    the template need not (and may not) name {out}: it is checked with one appended."""
    if output and "{out}" in template:
        raise TemplateError("--run names {out} and --output names a file: give one of them")
    try:
        cmd = parse_renderer(f"{template} {{out}}" if output else template, output_format=fmt)
    except TemplateError as e:
        raise TemplateError(str(e).replace("--renderer", "--run")) from None
    return cmd.words[:-1] if output else cmd.words


def parse_build(template: str) -> tuple[str, ...]:
    """--build, split like a shell would but run without one; it has no placeholders (it
    runs once, before any scene)."""
    try:
        words = tuple(shlex.split(template))
    except ValueError as e:
        raise TemplateError(f"--build {template!r}: {e}") from None
    if not words:
        raise TemplateError("--build is empty")
    used = [f for w in words for f in PLACEHOLDER.findall(w) if f in PLACEHOLDERS]
    if used:
        raise TemplateError(
            f"--build may not use {{{used[0]}}}: the build runs once, before any scene "
            "(placeholders belong in --run)"
        )
    return words


def check_output_name(name: str) -> str:
    """--output: a relative path inside the program's folder, of an image type."""
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if name.startswith("/") or ".." in parts or not parts:
        raise TemplateError(f"--output {name!r}: a file name inside the program's folder")
    if Path(parts[-1]).suffix.lower() not in IMAGE_SUFFIXES:
        raise TemplateError(f"--output {name!r}: expected one of {', '.join(IMAGE_SUFFIXES)}")
    return "/".join(parts)


@dataclass(frozen=True)
class SceneJob:
    name: str
    scene_file: str
    width: int
    height: int


@dataclass(frozen=True)
class ProgramJob:
    """One student's program, as a grading task carries it (to a worker, maybe elsewhere)."""

    source: str  # the folder or archive in SUBMISSIONS
    spec: ProgramSpec
    scenes: tuple[SceneJob, ...]
    hide: tuple[str, ...] = ()  # the teacher's paths, never visible in a sandbox

    def digest(self) -> str:
        """What the student's result depends on besides the model: its code and the class's
        commands, limits and scenes."""
        parts = [tree_digest(Path(self.source), self.spec.tree)]
        for s in self.scenes:
            parts.append(f"{s.name} {s.width}x{s.height} {sha256_file(s.scene_file)}")
        return self.spec.digest(*parts)


@dataclass
class ProgramResult:
    """What grading needs: an image per scene (or why not), and the evidence for the page."""

    files: dict[str, str | None]
    problem: str | None = None  # nothing can be graded (the build failed)
    scene_problems: dict[str, str] = field(default_factory=dict)  # this scene's run failed
    info: dict[str, Any] = field(default_factory=dict)
    transient: bool = False  # the machine failed, not the program: never stored as its result


def build_and_run(job: ProgramJob, folder: Path) -> ProgramResult:
    """Builds the program (or finds its build) and runs it on every scene (or finds the run).
    Never raises for what the submission does: every failure is a reason."""
    result = ProgramResult(files=dict.fromkeys(s.name for s in job.scenes))
    result.info = {"sandboxed": job.spec.sandboxed, "build": None, "runs": {}}
    if job.spec.sandboxed and (why := probe()):
        result.problem = f"not run: no sandbox on this machine ({why})"
        return result
    try:
        build = _build(job, folder)
        result.info["build"] = build
        if build["status"] != "ok":
            result.problem = build["reason"]
            return result
        for scene in job.scenes:
            run = _run(job, folder, scene, build["key"])
            result.info["runs"][scene.name] = run
            result.transient |= run["status"] in TRANSIENT
            if run["reason"]:
                result.scene_problems[scene.name] = run["reason"]
            else:
                result.files[scene.name] = str(folder / "runs" / run["image"])
    except (OSError, TreeError) as e:  # the machine's trouble (a full disk), not the student's
        result.problem = f"could not build or run the program: {displayable(str(e))[:300]}"
        result.transient = True
    if result.info["build"] is not None:
        result.transient |= result.info["build"]["status"] in TRANSIENT
    return result


def _cached(record: Path, key: str) -> dict[str, Any] | None:
    """A stored outcome with this key, or None (missing, corrupt, another key)."""
    try:
        old = json.loads(record.read_bytes())
    except (OSError, ValueError):
        return None
    return old if isinstance(old, dict) and old.get("key") == key else None


def _build(job: ProgramJob, folder: Path) -> dict[str, Any]:
    spec = job.spec
    key = spec.digest("build", tree_digest(Path(job.source), spec.tree))
    where = folder / "build"
    old = _cached(where / "outcome.json", key)
    if old is not None and (old["status"] != "ok" or (where / "tree").is_dir()):
        return {**old, "cached": True}
    remove_tree(where)
    where.mkdir(parents=True)
    with Workspace() as ws:
        record = _prepare_source(job, ws)
        built = _Built(where)
        if record is None and spec.build:
            argv = _expand(spec.build, ws.src)
            outcome = _rerun_if_busy(argv, ws, spec.build_limits, job, built.keep)
            record = _step(outcome, shlex.join(argv), build=True)
        elif record is None:  # nothing to build: the program is its source
            record = {"status": "ok", "reason": "", "command": "", "log": "", "seconds": 0.0}
            built.keep(ws.src, ws.src, spec.tree)
        if record["status"] == "ok" and built.refused:  # nothing of it stays in OUT
            record |= {
                "status": "refused",
                "reason": f"build failed: the build left {built.refused}",
            }
        if record["status"] != "ok":
            remove_tree(where / "tree")
    record |= {"key": key, "cached": False}
    _keep(where / "outcome.json", record)
    return record


class _Built:
    """What a build left, copied out of its sandbox into OUT/.../build/tree (links listed in
    links.json, never made), or why not."""

    def __init__(self, where: Path) -> None:
        self.where = where
        self.refused = ""

    def keep(self, work: Path, _out: Path, limits: TreeLimits = TREE_LIMITS) -> None:
        try:
            links = copy_tree(work, self.where / "tree", limits, built=True)
            write_atomic(self.where / "links.json", json.dumps(links))
        except TreeError as e:
            self.refused = displayable(str(e))
        except OSError as e:  # its folder replaced by a link, say
            self.refused = f"no folder to keep ({displayable(e.strerror or str(e))})"


def _rerun_if_busy(
    argv: list[str], ws: Workspace, limits: Limits, job: ProgramJob, collect: Collect
) -> Outcome:
    """A run that the machine starved (it waited for a CPU most of its wall time) is not the
    program's fault: it is tried once more; still starved, it is marked busy (never kept)."""
    outcome = run_sandboxed(
        argv, ws, limits, sandboxed=job.spec.sandboxed, hide=job.hide, collect=collect
    )
    if outcome.status == "busy":
        outcome = run_sandboxed(
            argv, ws, limits, sandboxed=job.spec.sandboxed, hide=job.hide, collect=collect
        )
    return outcome


def _prepare_source(job: ProgramJob, ws: Workspace) -> dict[str, Any] | None:
    """The student's files in ws.src; a record of the refusal when they cannot be."""
    source = Path(job.source)
    staged = ws.root / "source"
    try:
        if archive_suffix(source.name) and not source.is_dir():
            unpack(source, staged, job.spec.tree, binaries=job.spec.allow_binaries)
        else:
            copy_tree(source, staged, job.spec.tree, binaries=job.spec.allow_binaries)
    except TreeError as e:
        return {
            "status": "refused",
            "reason": f"refused: {e}",
            "command": "",
            "log": "",
            "seconds": 0.0,
        }
    ws.src.rmdir()
    staged.rename(ws.src)  # the supervisor copies it into the sandbox's own folder
    return None


def _expand(words: tuple[str, ...], work: Path) -> list[str]:
    """Shell-like globs (g++ -o rt *.cpp) matched inside the program's folder only; a pattern
    that matches nothing stays as it is, as in sh."""
    out: list[str] = []
    for w in words[1:]:
        if any(c in w for c in "*?[") and not w.startswith("/") and ".." not in w.split("/"):
            hits = sorted(glob.glob(w, root_dir=work))
            out.extend(hits or [w])
        else:
            out.append(w)
    return [words[0], *out]


def _step(outcome: Outcome, command: str, *, build: bool) -> dict[str, Any]:
    """An outcome as the record the page and the cache keep."""
    reason = outcome.reason
    if build and not outcome.ok:
        detail = first_error(outcome.log) if outcome.status == "exit" else ""
        reason = f"build failed: {detail or reason}"
    return {
        "status": outcome.status,
        "reason": reason,
        "command": command,
        "seconds": round(outcome.seconds, 3),
        "cpu_seconds": round(outcome.cpu_seconds, 3),
        "peak_memory": outcome.peak_memory,
        "peak_memory_text": human_size(outcome.peak_memory),
        "log": outcome.log,
        "log_bytes": outcome.log_bytes,
        "limits": asdict(outcome.limits),
        "sandboxed": outcome.sandboxed,
    }


def first_error(log: str) -> str:
    """The compiler's first error line (gcc, clang, ld, rustc), else the first line saying
    error, else the last line: the reason a build failed, for the gradebook."""
    lines = [_CONTROL.sub("", line).strip() for line in log.splitlines()]
    lines = [line for line in lines if line]
    for pattern in (_FIRST_ERROR, _ANY_ERROR):
        hit = next((line for line in lines if pattern.search(line)), None)
        if hit:
            return displayable(hit[:300])
    return displayable(lines[-1][:300]) if lines else ""


def _run(job: ProgramJob, folder: Path, scene: SceneJob, build_key: str) -> dict[str, Any]:
    spec = job.spec
    slug = student_slug(scene.name)
    key = spec.digest(
        "run", build_key, slug, sha256_file(scene.scene_file), f"{scene.width}x{scene.height}"
    )
    where = folder / "runs" / slug
    old = _cached(where / "outcome.json", key)
    if old is not None and (old["reason"] or (folder / "runs" / old["image"]).is_file()):
        return {**old, "cached": True}
    remove_tree(where)
    where.mkdir(parents=True)
    with Workspace() as ws:
        copy_tree(folder / "build" / "tree", ws.root / "copy", spec.tree, built=True)
        ws.src.rmdir()
        (ws.root / "copy").rename(ws.src)
        ws.links = _links(folder / "build" / "links.json")
        argv, out_name = _run_argv(spec, scene, ws)
        rel = spec.output or out_name
        read: list[tuple[str, bytes]] = []

        def grab(work: Path, out: Path) -> None:
            read.append(read_output(work if spec.output else out, rel, scene.width, scene.height))

        outcome = _rerun_if_busy(argv, ws, spec.run_limits, job, grab)
        record = _step(outcome, shlex.join(argv), build=False)
        if outcome.ok:
            problem, data = read[-1] if read else ("no output: it could not be read back", b"")
            problem = problem or output_problem(data, rel)
            if problem:
                record |= {"status": "output", "reason": problem}
            else:
                image = f"{slug}/{slug}{Path(rel).suffix.lower()}"
                write_atomic(folder / "runs" / image, data)
                record["image"] = image
    record |= {"key": key, "cached": False}
    _keep(where / "outcome.json", record)
    return record


def _keep(path: Path, record: dict[str, Any]) -> None:
    """Stores a finished step, last (the mark that it is done). A sandbox that could not
    start, or a run the machine starved, is the machine's trouble, not the program's outcome:
    it is tried again next time."""
    if record["status"] not in TRANSIENT:
        write_atomic(path, json.dumps(record, indent=1))


def _run_argv(spec: ProgramSpec, scene: SceneJob, ws: Workspace) -> tuple[list[str], str]:
    """The run command for one scene, placeholders filled with the paths the program sees;
    also the name {out} has in the out folder."""
    _, inputs, out = ws.seen(spec.sandboxed)
    scene_name = f"{student_slug(scene.name)}.json"
    shutil.copyfile(scene.scene_file, ws.inputs / scene_name)
    out_name = f"{student_slug(scene.name)}.{spec.output_format}"
    values = {
        "scene": f"{inputs}/{scene_name}",
        "out": f"{out}/{out_name}",
        "width": str(scene.width),
        "height": str(scene.height),
        "spp": "1",
        "mode": "default",
        "scene_xml": "",
    }
    if any("{scene_xml}" in w for w in spec.run):
        loaded = load_scene(scene.scene_file)
        sized = replace(
            loaded, camera=replace(loaded.camera, width=scene.width, height=scene.height)
        )
        _write_xml(sized, ws.inputs, 1)
        values["scene_xml"] = f"{inputs}/scene.xml"
    for f in ws.inputs.iterdir():  # readable by the sandbox user, writable by nobody there
        os.chmod(f, 0o644)
    return [fill(w, values) for w in spec.run], out_name


def _links(listing: Path) -> list[tuple[str, str]]:
    """The links a build made (links.json), to be made again inside a run's sandbox only."""
    try:
        links = json.loads(listing.read_text())
    except (OSError, ValueError):
        return []
    return [
        (rel, target)
        for rel, target in (e for e in links if isinstance(e, list) and len(e) == 2)
        if isinstance(rel, str) and isinstance(target, str) and ".." not in rel.split("/")
    ]


def program_entries(
    submissions: Path,
    models: Mapping[str, Any],  # scene name -> ModelRenders
    spec: ProgramSpec,
    size: tuple[int, int] | None,
    out: Path,
    cache_root: Path,
    progress: Any,
) -> list[tuple[str, dict[str, str | None], str | None, ProgramJob | None]]:
    """(student, scene -> file, problem, program) for every program in SUBMISSIONS: each
    renders every scene at the model's size (--size, else the scene's)."""
    scenes = []
    for name, renders in models.items():
        camera = load_scene(renders.scene_file).camera
        w, h = size or (camera.width, camera.height)
        scenes.append(SceneJob(name, str(renders.scene_file), w, h))
    # Never visible in a sandbox anyway (only the system is mounted); named so that a copy
    # of them inside a system folder is covered too.
    # rtval's environment and its programs too (rtdemo is a renderer a student could call).
    tools = [Path(p) for p in map(shutil.which, ("rtval", "rtdemo")) if p]
    hide: tuple[Path, ...] = (
        submissions,
        out,
        cache_root,
        Path.home(),
        Path(__file__).resolve().parents[2],
    )
    hide += (Path(sys.prefix), *tools)
    rows = []
    for e in collect_programs(submissions, exclude=[out], notice=progress):
        job = None
        if e.source and not e.problems:
            job = ProgramJob(e.source, spec, tuple(scenes), tuple(str(p) for p in hide))
        rows.append((e.student, dict.fromkeys(models), "; ".join(e.problems) or None, job))
    return rows
