"""rtdemo renders a check needs besides the renderer under test, cached by content hash:
the id/depth AOVs that give a scene's effect masks, and a demo model's image for
`check --against`. The masks themselves are cached too (computing them costs more than
reading them), keyed by the render's key and the mask code."""

from __future__ import annotations

import hashlib
import tempfile
from functools import cache
from pathlib import Path

import numpy as np

from compare.judge import effects
from compare.judge.effects import BOOL, EFFECTS, effect_masks
from compare.judge.images import Image, read_image
from compare.render.cache import RenderJob, cache_key, run_jobs
from scene_model.scene import load_scene

MASK_MODE = "classic"  # any mode gives the same camera-ray AOVs; classic is the plain one


def _size_args(size: tuple[int, int], spp: int) -> list[str]:
    args = ["--width", str(size[0]), "--height", str(size[1])]
    return args + (["--spp", str(spp)] if spp != 1 else [])


def cached_render(job: RenderJob, scene_file: Path, cache_dir: Path) -> Path:
    """The cached EXR of an rtdemo job, rendered first when missing."""
    path = cache_dir / f"{job.key}-{cache_key(job, scene_file)}.exr"
    if not path.is_file():
        with tempfile.TemporaryDirectory(prefix="rtval-aov-") as tmp:
            run_jobs([job], scene_file, cache_dir, Path(tmp), progress=lambda _: None)
    return path


@cache
def _mask_code() -> str:
    return hashlib.sha256(Path(effects.__file__).read_bytes()).hexdigest()[:12]


def masks_from_image(scene_file: Path, image: Image) -> dict[str, BOOL]:
    missing = [c for c in ("id", "depth") if c not in image.aovs]
    if missing:
        raise ValueError(f"{image.path}: no {' or '.join(missing)} AOV for the effect masks")
    return effect_masks(load_scene(scene_file), image.aovs["id"], image.aovs["depth"])


def scene_masks(scene_file: Path, size: tuple[int, int], cache_dir: Path) -> dict[str, BOOL]:
    """The effect masks of a scene at a size, from an rtdemo AOV render."""
    scene_file = Path(scene_file).resolve()
    job = RenderJob(
        key="masks",
        label=f"effect masks of {scene_file.name}",
        tool="rtdemo",
        args=[
            "render",
            str(scene_file),
            "-o",
            "{out}",
            "--mode",
            MASK_MODE,
            *_size_args(size, 1),
            "-q",
        ],
        family="masks",
    )
    cache_dir.mkdir(parents=True, exist_ok=True)
    stored = cache_dir / f"masks-{cache_key(job, scene_file)}-{_mask_code()}.npz"
    if stored.is_file():
        with np.load(stored) as data:
            return {name: data[name].astype(bool) for name in EFFECTS if name in data.files}
    masks = masks_from_image(scene_file, read_image(cached_render(job, scene_file, cache_dir)))
    tmp = stored.with_name(stored.stem + ".partial.npz")
    np.savez_compressed(tmp, **masks)  # type: ignore[arg-type]
    tmp.replace(stored)
    return masks


def model_render(
    scene_file: Path, model_args: list[str], size: tuple[int, int], spp: int, cache_dir: Path
) -> Image:
    """rtdemo's render of a demo model (TargetModel.rtdemo_args()), with its AOVs."""
    scene_file = Path(scene_file).resolve()
    job = RenderJob(
        key="model",
        label=f"{' '.join(model_args)} on {scene_file.name}",
        tool="rtdemo",
        args=["render", str(scene_file), "-o", "{out}", *model_args, *_size_args(size, spp), "-q"],
        family="model",
    )
    cache_dir.mkdir(parents=True, exist_ok=True)
    return read_image(cached_render(job, scene_file, cache_dir))
