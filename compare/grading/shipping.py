"""A grading task as it travels to a Dask worker that sees nothing of the teacher's machine.

The client reads everything a student's grading needs into the task itself: the
submission's bytes (a program's files), each scene's JSON text, the model's renders, the
rubric and the options. The worker writes them into folders of its own (the model's renders
under its render cache, keyed by their digest, so each worker writes them once; the
submission in a fresh folder under its TMPDIR), grades there with its own render cache
($RTVAL_CACHE, else $XDG_CACHE_HOME/rtval, else ~/.cache/rtval, as seen by the worker) and
returns the row, the stored result's text and the student's page folder as bytes. Only the
client writes OUT (grade.py); the worker's folder is removed after each task.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import stat
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare.grading.programs import ProgramJob, SceneJob
from compare.render.cache import RenderCache
from compare.sandbox.archives import TreeLimits
from compare.sandbox.trees import open_regular, remove_tree, walk
from compare.student_ids import student_slug
from compare.verdict.against import ModelRenders
from safe_files.paths import write_atomic

# The most one submitted file may carry to a worker (a 4K float EXR with its AOVs is ~0.3 GiB):
# a larger file is that student's row, never the client's memory.
MAX_SHIPPED_BYTES = 1 << 30


class ShipError(OSError):
    """A submission that cannot travel to a worker (the message names the file and why)."""


# A file's bytes with its name (the suffix says how it is read: .png is sRGB, .ppm linear).
Named = tuple[str, bytes]
_LINK, _DIR, _FILE = "link", "dir", "file"


@dataclass(frozen=True)
class Archive:
    """A submitted archive (.zip, .tar.gz): its name and bytes."""

    name: str
    data: bytes


@dataclass(frozen=True)
class TreeEntry:
    """One entry of a submitted folder: its path inside, kind, bytes (a link: its target)."""

    rel: str
    kind: str  # file | dir | link
    data: bytes = b""
    executable: bool = False


@dataclass(frozen=True)
class ShippedModel:
    """The model's renders of one scene, and the scene, as bytes."""

    model: str
    scene_text: bytes
    reference: bytes
    offsets: tuple[bytes, ...] = ()


@dataclass(frozen=True)
class ShippedModels:
    """Every scene's model renders (sent once per worker, not once per student)."""

    key: str  # grade._models_key: names the worker's copy
    scenes: dict[str, ShippedModel]


@dataclass(frozen=True)
class Shipped:
    """One student's task with every input it reads (`task` keeps the client's paths only
    as names; the worker replaces each with its own copy)."""

    task: object  # grade.GradeTask (typed as object: grade.py imports this module)
    key: str  # the client's task_key: the result is stored under it
    images: dict[str, Named | None]  # scene -> the submitted image (None: missing)
    program: Archive | tuple[TreeEntry, ...] | None  # an archive, or a folder's entries
    warnings: tuple[str, ...] = ()  # the client's, about the stored result it replaces


@dataclass(frozen=True)
class Returned:
    """What a worker sends back: the row, the result file's text (None: not to be stored,
    the machine failed) and the student's page folder, path inside it -> bytes."""

    result: object  # results.StudentResult
    stored: str | None = None
    page_files: dict[str, bytes] = dataclasses.field(default_factory=dict)


def ship_models(models: dict[str, ModelRenders], key: str) -> ShippedModels:
    return ShippedModels(
        key,
        {
            name: ShippedModel(
                r.model,
                Path(r.scene_file).read_bytes(),
                Path(r.reference).read_bytes(),
                tuple(Path(p).read_bytes() for p in r.offsets),
            )
            for name, r in models.items()
        },
    )


def ship_images(files: dict[str, str | None]) -> dict[str, Named | None]:
    """Each image's bytes; a file that cannot be read travels as its name with no bytes,
    so that the worker's reading gives the reason."""
    return {scene: None if p is None else (Path(p).name, _read(p)) for scene, p in files.items()}


def _read(path: str) -> bytes:
    try:
        st = os.lstat(path)
        if not stat.S_ISREG(st.st_mode):
            return b""
    except OSError:
        return b""
    if st.st_size > MAX_SHIPPED_BYTES:
        raise ShipError(
            f"{Path(path).name}: {st.st_size:,} bytes, over the {MAX_SHIPPED_BYTES:,} a task "
            "may carry to a Dask worker"
        )
    try:
        return Path(path).read_bytes()
    except OSError:
        return b""


def ship_program(source: str) -> Archive | tuple[TreeEntry, ...]:
    """An archive's bytes, or a folder's entries within a submitted folder's bounds (links
    travel as links, for grading to refuse by name; FIFOs and devices stay behind)."""
    if not Path(source).is_dir():
        return Archive(Path(source).name, Path(source).read_bytes())
    limits = TreeLimits()
    entries = []
    for node in walk(Path(source), limits.max_depth, limits.max_entries):
        mode = node.st.st_mode
        if stat.S_ISLNK(mode):
            target = os.readlink(node.name, dir_fd=node.dir_fd)
            entries.append(TreeEntry(node.rel, _LINK, os.fsencode(target)))
        elif stat.S_ISDIR(mode):
            entries.append(TreeEntry(node.rel, _DIR))
        elif stat.S_ISREG(mode):
            if node.st.st_size > MAX_SHIPPED_BYTES:
                raise ShipError(f"{node.rel}: over {MAX_SHIPPED_BYTES:,} bytes, not sent")
            with os.fdopen(open_regular(node), "rb") as f:
                entries.append(TreeEntry(node.rel, _FILE, f.read(), bool(mode & 0o111)))
    return tuple(entries)


def unpack_program(program: Archive | tuple[TreeEntry, ...], folder: Path) -> Path:
    if isinstance(program, Archive):
        target = folder / program.name
        target.write_bytes(program.data)
        return target
    root = folder / "program"
    root.mkdir()
    for e in program:
        path = root / e.rel
        if e.kind == _DIR:
            path.mkdir()
        elif e.kind == _LINK:
            os.symlink(os.fsdecode(e.data), path)
        else:
            path.write_bytes(e.data)
            path.chmod(0o755 if e.executable else 0o644)
    return root


def worker_models(shipped: ShippedModels, cache: RenderCache) -> dict[str, ModelRenders]:
    """The model's renders written once per worker under its cache's shipped/<digest>/."""
    folder = cache.root / "shipped" / shipped.key
    folder.mkdir(parents=True, exist_ok=True)
    models = {}
    for scene, m in shipped.scenes.items():
        stem = student_slug(f"{scene}-{m.model}")

        def put(suffix: str, data: bytes, stem: str = stem) -> str:
            path = folder / f"{stem}{suffix}"
            if not path.is_file():
                write_atomic(path, data, durable=False)
            return str(path)

        models[scene] = ModelRenders(
            m.model,
            put(".json", m.scene_text),
            put(".exr", m.reference),
            tuple(put(f"-offset{i}.exr", b) for i, b in enumerate(m.offsets)),
        )
    return models


def _images_here(images: dict[str, Named | None], folder: Path) -> dict[str, str | None]:
    files: dict[str, str | None] = {}
    for scene, named in images.items():
        if named is None:
            files[scene] = None
            continue
        sub = folder / "images" / student_slug(scene)
        sub.mkdir(parents=True)
        (sub / named[0]).write_bytes(named[1])
        files[scene] = str(sub / named[0])
    return files


def worker_paths(
    shipped: Shipped, shared: ShippedModels, folder: Path, cache: RenderCache
) -> dict[str, Any]:
    """The task's fields that name files, as this worker's own paths."""
    models = worker_models(shared, cache)
    fields: dict[str, Any] = {
        "files": _images_here(shipped.images, folder),
        "models": models,
        "out_dir": str(_made(folder / "out")),
        "cache_root": str(cache.root),
    }
    job = getattr(shipped.task, "program", None)
    if isinstance(job, ProgramJob) and shipped.program is not None:
        scenes = tuple(
            SceneJob(s.name, models[s.name].scene_file, s.width, s.height) for s in job.scenes
        )
        hide = (str(folder), str(cache.root), str(Path.home()), *_own_tools())
        source = unpack_program(shipped.program, folder)
        fields["program"] = dataclasses.replace(job, source=str(source), scenes=scenes, hide=hide)
    return fields


def _made(folder: Path) -> Path:
    folder.mkdir()
    return folder


def client_names(here: dict[str, str | None], there: dict[str, str | None]) -> dict[str, str]:
    """Each file's path on the worker -> its path on the client (messages name the latter)."""
    return {p: there[s] or p for s, p in here.items() if p is not None and there.get(s)}


def renamed(text: str, names: dict[str, str]) -> str:
    """A result's JSON text with the worker's paths written as the client's."""
    for mine, theirs in sorted(names.items(), key=lambda kv: -len(kv[0])):
        text = text.replace(json.dumps(mine)[1:-1], json.dumps(theirs)[1:-1])
    return text


def _own_tools() -> tuple[str, ...]:
    """This worker's rtval: its environment and checkout (never visible in a sandbox)."""
    import sys

    return (sys.prefix, str(Path(__file__).resolve().parents[2]))


def task_folder() -> Path:
    """A fresh folder under the worker's TMPDIR for one task."""
    return Path(tempfile.mkdtemp(prefix="rtval-task-"))


def page_files(out: Path, slug: str) -> dict[str, bytes]:
    """The student's page folder under the worker's OUT, path inside it -> bytes."""
    root = out / "students" / slug
    found = {}
    for dirpath, _dirs, names in os.walk(root):
        for name in names:
            path = Path(dirpath) / name
            if path.is_file() and not path.is_symlink():
                found[path.relative_to(root).as_posix()] = path.read_bytes()
    return found


def cleanup(folder: Path) -> None:
    # Another user's files left by a program stay for the TMPDIR's cleaner.
    with contextlib.suppress(OSError):
        remove_tree(folder)
