"""Judging an image against a target model, as compare, check, report and grade do: the model's
renders (render/models.py) are made once, loaded once per process, and every image goes
through evaluate_pair with the model's effect masks.

Demo models are judged by exact match (the verdict says "differ from classic beyond 8-bit
linear quantisation"); Mitsuba models by the rubric's per-effect FLIP and SSIM rules.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from compare.judge.arrays import F32
from compare.judge.effects import effect_masks
from compare.judge.evaluate import Evaluation, ExactInputs, evaluate_pair
from compare.judge.exact_match import Bounds
from compare.judge.images import Image, ImageError, read_image
from compare.judge.metrics import BOOL
from compare.judge.rubric import Rubric
from compare.judge.scoring import FLIP_AT_ZERO_SCORE
from compare.judge.target_model import TargetModel, parse_model
from compare.judge.tolerances import Tolerances
from compare.render.cache import RenderCache
from compare.render.models import render_model, render_offsets
from compare.render.progress import Progress
from safe_files.content import sha256_file
from scene_model.scene import load_scene

GRADE_DEFAULT = "classic"  # README, "Grading a class": why classic


@dataclass(frozen=True)
class ModelRenders:
    """Where a model's renders of one scene are (paths travel to worker processes)."""

    model: str  # canonical name
    scene_file: str
    reference: str  # the pixel-centre render (Mitsuba: the converged render)
    offsets: tuple[str, ...] = ()  # demo models: the camera turned by a sub-pixel offset

    def digest(self) -> str:
        h = hashlib.sha256(self.model.encode())
        for p in (self.scene_file, self.reference, *self.offsets):
            h.update(sha256_file(Path(p)).encode())
        return h.hexdigest()[:24]


@dataclass
class LoadedModel:
    renders: ModelRenders
    target: TargetModel
    reference: Image
    offsets: list[F32] = field(default_factory=list)
    masks: dict[str, BOOL] = field(default_factory=dict)
    bounds: dict[str, tuple[Bounds, Bounds]] = field(default_factory=dict)  # per encoding, on use


def resolve_model(cli: TargetModel | None, rubric: Rubric | None, default: str) -> TargetModel:
    """--against wins over the rubric's `against`, which wins over the command's default."""
    return cli or parse_model((rubric.against if rubric else None) or default)


def prepare(
    model: TargetModel,
    scene_file: Path,
    size: tuple[int, int] | None,
    cache: RenderCache,
    *,
    progress: Progress | None = None,
) -> ModelRenders:
    """Renders (or finds in the shared cache) everything judging against `model` needs."""
    ref = render_model(model, scene_file, size, cache, progress=progress)
    offsets = (
        render_offsets(model, scene_file, size, cache, progress=progress) if model.is_demo else []
    )
    return ModelRenders(model.name, str(scene_file), str(ref), tuple(str(p) for p in offsets))


# A few models at once: `grade --scene classic --scene paper` judges every student against
# both, and each load computes the model's effect masks.
_LOADED_MAX = 4
_LOADED: dict[tuple[ModelRenders, tuple[tuple[int, ...], ...]], LoadedModel] = {}


def _files_identity(renders: ModelRenders) -> tuple[tuple[int, ...], ...]:
    """Which files the paths name now: a render replaced at the same path (atomically: a new
    inode) is another model, never the cached one."""
    out = []
    for p in (renders.scene_file, renders.reference, *renders.offsets):
        st = os.stat(p)
        out.append((st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns))
    return tuple(out)


def load(renders: ModelRenders) -> LoadedModel:
    """The model's images and effect masks, read once per process (grade workers reuse them)."""
    key = (renders, _files_identity(renders))
    if key not in _LOADED:
        ref = read_image(renders.reference)
        if "id" not in ref.aovs or "depth" not in ref.aovs:
            raise ImageError(f"{renders.reference}: the model render has no id/depth AOVs")
        masks = effect_masks(load_scene(renders.scene_file), ref.aovs["id"], ref.aovs["depth"])
        offsets = [read_image(p).rgb for p in renders.offsets]
        while len(_LOADED) >= _LOADED_MAX:  # the oldest goes
            del _LOADED[next(iter(_LOADED))]
        _LOADED[key] = LoadedModel(renders, parse_model(renders.model), ref, offsets, masks)
    return _LOADED[key]


def judge_against_model(
    test: Image,
    model: LoadedModel,
    rubric: Rubric | None = None,
    *,
    region: BOOL | None = None,
    tolerances: Tolerances = Tolerances(),
    scored: bool = True,
) -> Evaluation:
    """`test` against the model, per effect (the model's masks). Raises SizeMismatch.
    `scored` False: against a demo model, the exact match only (no score, no FLIP)."""
    rules = rubric.effects if rubric else None
    pass_score = rubric.pass_score if rubric else None
    if model.target.is_demo:
        return evaluate_pair(
            model.reference.rgb,
            test.rgb,
            tolerances=tolerances,
            region=region,
            masks=model.masks,
            rules=rules,
            pass_score=pass_score,
            exact=ExactInputs(model.renders.model, model.offsets, test.encoding, model.bounds),
            scored=scored,
        )
    return evaluate_pair(
        model.reference.rgb,
        test.rgb,
        hdr=test.encoding == "float",
        tolerances=tolerances,
        region=region,
        masks=model.masks,
        rules=rules,
        flip_at_zero=rubric.flip_at_zero if rubric else FLIP_AT_ZERO_SCORE,
        pass_score=pass_score,
    )


def nan_pixels(img: Image) -> int:
    return int((~np.isfinite(img.rgb)).any(-1).sum())
