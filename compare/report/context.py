"""What every step of `rtval report` shares (report.py runs the steps): the options, the
scene, the plan and its renders in the cache, the image under test, the output folder and the
timer of the steps."""

from __future__ import annotations

import contextlib
import functools
import hashlib
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare import interrupts as interrupt
from compare.judge.effects import effect_masks
from compare.judge.images import Image, ImageError, ImageSizeError, read_image
from compare.judge.target_model import TargetModel
from compare.render.cache import RenderCache
from compare.render.jobs import RenderJob
from compare.render.plan import RenderPlan
from compare.render.progress import Progress
from compare.report.derived import Evaluator, LazyImages
from compare.report.label import label_problem
from scene_model.scene import Scene

SCENE_COPY = "scene.json"  # the scene beside the page; the printed commands read it
TEST_KEY = "test-image"  # a given image under test, among the plan's renders


@dataclass(frozen=True)
class ReportOptions:
    """What `rtval report` was asked for; the defaults are the command's."""

    scene_file: Path
    reports_dir: Path = Path("reports")
    size: tuple[int, int] | None = None  # None: the scene's own
    test_image: str | None = None  # a render to grade in the demo's place
    test_label: str | None = None
    test_encoding: str | None = None
    against: TargetModel | None = None  # None: classic
    jobs: int = 1
    pdf: bool = True

    def __post_init__(self) -> None:
        why = label_problem(self.test_label) if self.test_label is not None else None
        if why:
            raise ValueError(f"--label: {why}")


class Steps:
    """Wall time per step of the report run, for the table printed at its end."""

    def __init__(self, progress: Progress) -> None:
        self.rows: list[tuple[str, float]] = []
        self.progress = progress

    @contextlib.contextmanager
    def __call__(self, name: str) -> Iterator[None]:
        interrupt.check()  # a stop signal whose exception was lost stops the report here
        start = time.perf_counter()
        yield  # a failed step raises through: no time for it
        interrupt.check()
        self.add(name, time.perf_counter() - start)

    def add(self, name: str, seconds: float) -> None:
        self.rows.append((name, seconds))
        self.progress.line(f"{name}: {seconds:.1f} s")  # one line per step in any log

    def table(self) -> str:
        total = sum(t for _, t in self.rows)
        lines = [f"{'step':<28}{'seconds':>9}"]
        lines += [f"{name:<28}{t:>9.2f}" for name, t in self.rows]
        lines.append(f"{'total':<28}{total:>9.2f}")
        return "\n".join(lines)

    def as_list(self) -> list[dict[str, Any]]:
        return [{"step": name, "seconds": round(t, 3)} for name, t in self.rows]


@dataclass(frozen=True)
class Given:
    """A --test-image as read, before any render: its pixels and its very bytes."""

    path: Path
    image: Image
    data: bytes


def read_given(opts: ReportOptions, scene: Scene) -> Given | None:
    """The image under test, read first (it may lie in the images/ folder this run rebuilds)
    and checked once against the size the plan renders at: never resampled."""
    if not opts.test_image:
        return None
    w, h = opts.size or (scene.camera.width, scene.camera.height)
    try:  # the size is checked in the header: a huge declared size costs nothing
        image = read_image(opts.test_image, encoding=opts.test_encoding, expected_size=(h, w))
    except ImageSizeError as e:
        raise ImageError(
            f"{opts.test_image}: {e.size[1]}x{e.size[0]}, the scene renders at "
            f"{w}x{h} (never resampled)"
        ) from None
    return Given(Path(opts.test_image), image, Path(opts.test_image).read_bytes())


@dataclass(frozen=True)
class Subject:
    """The image under test: the demo's paper mode, or a given image."""

    key: str
    label: str
    copy: str  # its copy in the folder, relative to the page
    given: Given | None


@dataclass
class ReportContext:
    """One report run: its options, plan, renders (read lazily) and output folder."""

    opts: ReportOptions
    scene: Scene
    cache: RenderCache
    progress: Progress
    steps: Steps
    out: Path
    plan: RenderPlan
    imgs: LazyImages
    subject: Subject
    ev: Evaluator = field(init=False)

    def __post_init__(self) -> None:
        ref = self.plan.reference.key
        self.ev = Evaluator(lambda: self.imgs[ref], self.hashes[ref], self.masks, self.cache)

    @property
    def images_dir(self) -> Path:
        return self.out / "images"

    @property
    def hashes(self) -> dict[str, str]:
        return self.imgs.hashes

    @property
    def given(self) -> bool:
        return self.subject.given is not None

    def featured(self) -> list[tuple[str, str]]:
        """(key, title) of the renders compared in full: the image under test first."""
        own = [(f.job.key, f.title) for f in self.plan.featured]
        return [(self.subject.key, self.subject.label), *own] if self.given else own

    def mapped(self) -> list[str]:
        """The renders whose difference, FLIP and SSIM maps the page shows."""
        own = [j.key for j in self.plan.mapped]
        return [self.subject.key, *own] if self.given else own

    def command(self, job: RenderJob) -> str:
        """The command that makes this render, as the page prints it (beside SCENE_COPY)."""
        return job.command_text(exr_path(job.key), SCENE_COPY)

    @functools.cached_property
    def _masks(self) -> dict[str, np.ndarray]:
        ref = self.imgs[self.plan.reference.key]
        return effect_masks(self.scene, ref.aovs["id"], ref.aovs["depth"])

    def masks(self) -> dict[str, np.ndarray]:
        """The reference's effect masks, made on first use."""
        return self._masks


def exr_path(key: str) -> str:
    """Where a render's EXR lies in the folder (the reference's and the test's), relative."""
    return f"images/{key}.exr"


def open_renders(plan: RenderPlan, cache: RenderCache) -> LazyImages:
    """The plan's renders by key, read when a result not yet derived needs them: a warm run
    reads few."""
    hashes = {j.key: str(j.info["sha256"]) for j in plan.jobs()}
    return LazyImages({j.key: j.exr(cache) for j in plan.jobs()}, hashes, cache)


def subject_of(
    opts: ReportOptions, plan: RenderPlan, imgs: LazyImages, given: Given | None
) -> Subject:
    """The demo's paper mode, or the given image added to the renders under TEST_KEY."""
    if given is None:
        label = opts.test_label or "the demo (paper mode)"
        return Subject(plan.paper.key, label, exr_path(plan.paper.key), None)
    imgs.add(TEST_KEY, given.image, hashlib.sha256(given.data).hexdigest())
    label = opts.test_label or given.path.stem
    return Subject(TEST_KEY, label, f"images/test-image{given.path.suffix.lower()}", given)
