"""Rendering a target model (compare/judge/target_model.py) for a scene at a size, through the
shared render cache (cache.py, jobs.py): the image every judgement against that model uses.

Demo models are rtdemo renders; `mitsuba` is the report plan's converged Whitted reference and
`mitsuba-path` its 64 spp path-traced render (plan.py), so a report and a grading run share
them. Exact judging also needs the demo model perturbed far below any real feature
(render_offsets): the camera turned by tiny fractions of a pixel, every sphere grown and shrunk
by two float32 ulps; where those renders move, the model itself is unstable. rtdemo has no
jitter option, so each is a copy of the scene, cached like any render (docs/metrics.md, "Exact
match").
A scene's effect masks (scene_masks) come from the classic model's id/depth AOVs and are
cached beside it, keyed by the render's key and the mask code (computing them costs more
than reading them).
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np

from compare.judge import effects
from compare.judge.effects import BOOL, EFFECTS, effect_masks
from compare.judge.images import read_image
from compare.judge.target_model import TargetModel, parse_model
from compare.render.cache import RenderCache
from compare.render.jobs import RenderJob, run_jobs
from compare.render.plan import REFERENCE_KEY, plan
from compare.render.progress import Progress
from safe_files.content import sha256_file
from safe_files.paths import atomic_output
from scene_model.scene import load_scene

# A float32 program's camera ray differs from another's by ~5e-5 px (a few ulps of its
# direction); its secondary rays, by what rounding in hit points and normals adds, which FMA
# and double-precision programs show reaching ~1e-3 px (docs/metrics.md). Both scales, far below
# any real feature (a half-pixel shift is 500 times more).
OFFSET_PIXELS = (1e-4, 1e-3)
OFFSETS = ((1, 0), (-1, 0), (0, 1), (0, -1))
# A float32 intersection is off by about an ulp of the largest number in it; two ulps either
# way covers the corpus's double-precision, FMA and -ffast-math programs (docs/metrics.md).
SPHERE_ULPS = (2, -2)
MITSUBA_JOBS = {"mitsuba": REFERENCE_KEY, "mitsuba-path": "mitsuba-path-llvm-64spp"}
MASK_MODEL = "classic"  # every demo mode gives the same camera-ray AOVs; classic is the plain one


def _size_args(size: tuple[int, int] | None) -> list[str]:
    return ["--width", str(size[0]), "--height", str(size[1])] if size else []


def model_job(model: TargetModel, scene_file: Path, size: tuple[int, int] | None) -> RenderJob:
    """The render command of `model` (its cache key follows from it). Mitsuba models are the
    plan's own commands, so a report's renders serve them and the other way round."""
    if not model.is_demo:
        jobs = plan(str(scene_file), size).jobs()
        return next(j for j in jobs if j.key == MITSUBA_JOBS[model.kind])
    return RenderJob(
        f"model-{model.name}",
        f"{model.name} model",
        "rtdemo",
        ["render", "{scene}", "-o", "{out}", "-q", *model.rtdemo_args(), *_size_args(size)],
        "model",
        scene=str(scene_file),
    )


def render_model(
    model: TargetModel,
    scene_file: Path,
    size: tuple[int, int] | None,
    cache: RenderCache,
    *,
    progress: Progress | None = None,
) -> Path:
    """Renders (or finds in the cache) `model` on the scene; returns the cached EXR's path."""
    job = model_job(model, scene_file, size)
    run_jobs([job], cache, progress=progress)
    return job.exr(cache)


def offset_scene(scene_file: Path, size: tuple[int, int] | None, dx: float, dy: float) -> str:
    """The scene's JSON with the camera turned by (dx, dy) pixels: look_at moves across the
    view by that many pixel footprints at its distance (at least 4 float32 ulps of it)."""
    scene = load_scene(scene_file)  # validates; the copy keeps every other byte's meaning
    raw = json.loads(Path(scene_file).read_text(encoding="utf-8-sig"))
    cam = scene.camera
    pos, at = np.array(cam.position, np.float64), np.array(cam.look_at, np.float64)
    forward = at - pos
    dist = float(np.linalg.norm(forward))
    forward /= dist
    right = np.cross(forward, np.array(cam.up, np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    height = size[1] if size else cam.height
    footprint = 2 * math.tan(math.radians(cam.fov_y) / 2) * dist / height
    floor = 4 * float(np.spacing(np.float32(np.abs(at).max())))

    def step(pixels: float) -> float:
        return math.copysign(max(abs(pixels) * footprint, floor), pixels) if pixels else 0.0

    # Image y grows downwards, the camera's up upwards.
    nudged = at + step(dx) * right - step(dy) * up
    raw["camera"]["look_at"] = [float(v) for v in nudged]
    return json.dumps(raw, indent=1)


def grown_scene(scene_file: Path, ulps: int) -> str:
    """The scene's JSON with every sphere's radius grown by `ulps` float32 ulps of its largest
    coordinate (shrunk when negative): what rounding in a float32 intersection moves a hit by
    (on the radius-1e4 floor, ~1e-3: a shadow ray from there grazing a sphere may go either
    way)."""
    load_scene(scene_file)  # validates
    raw = json.loads(Path(scene_file).read_text(encoding="utf-8-sig"))
    for s in raw["spheres"]:
        largest = max(max(abs(float(c)) for c in s["center"]), float(s["radius"]))
        r = float(s["radius"])
        s["radius"] = max(r / 2, r + ulps * float(np.spacing(np.float32(largest))))  # stays > 0
    return json.dumps(raw, indent=1)


def _perturbed_scenes(scene_file: Path, size: tuple[int, int] | None) -> list[tuple[str, str, str]]:
    """(key suffix, label suffix, scene text) of every perturbation exact judging uses."""
    out = []
    for magnitude, (dx, dy) in ((m, d) for m in OFFSET_PIXELS for d in OFFSETS):
        scale = "" if magnitude == OFFSET_PIXELS[0] else f"x{magnitude:g}"
        out.append(
            (
                f"-offset{dx:+d}{dy:+d}{scale}",
                f", camera turned ({dx:+d}, {dy:+d}) x {magnitude:g} px",
                offset_scene(scene_file, size, dx * magnitude, dy * magnitude),
            )
        )
    for ulps in SPHERE_ULPS:
        out.append(
            (f"-spheres{ulps:+d}", f", spheres {ulps:+d} ulps", grown_scene(scene_file, ulps))
        )
    return out


def render_offsets(
    model: TargetModel,
    scene_file: Path,
    size: tuple[int, int] | None,
    cache: RenderCache,
    *,
    jobs_in_parallel: int = 1,
    progress: Progress | None = None,
) -> list[Path]:
    """The demo model's perturbed renders: the camera turned by each OFFSET_PIXELS along +x,
    -x, +y, -y, and every sphere grown and shrunk by SPHERE_ULPS (docs/metrics.md)."""
    if not model.is_demo:
        raise ValueError(f"{model.name}: perturbed renders are for demo models only")
    jobs = []
    for key, label, text in _perturbed_scenes(scene_file, size):
        digest = hashlib.sha256(text.encode()).hexdigest()[:16]
        # The scene copy is named by its content, so it is derived data like a figure.
        copy = cache.derived_text(f"scene-{digest}-perturbed.json", text)
        job = model_job(model, copy, size)
        job.key += key
        job.label += label
        jobs.append(job)
    run_jobs(jobs, cache, jobs_in_parallel=jobs_in_parallel, progress=progress)
    return [j.exr(cache) for j in jobs]


def scene_masks(
    scene_file: Path,
    size: tuple[int, int] | None,
    cache: RenderCache,
) -> dict[str, BOOL]:
    """The effect masks of a scene at a size (docs/metrics.md), from the classic model's AOVs;
    stored in the cache beside the render they come from, keyed by it and the mask code."""
    model = parse_model(MASK_MODEL)
    exr = render_model(model, scene_file, size, cache)
    code = sha256_file(effects.__file__)[:12]
    stored = cache.derived(f"masks-{exr.stem}-{code}.npz")
    if stored.is_file():
        with np.load(stored) as data:
            return {name: data[name].astype(bool) for name in EFFECTS if name in data.files}
    image = read_image(exr)
    missing = [c for c in ("id", "depth") if c not in image.aovs]
    if missing:
        raise ValueError(f"{image.path}: no {' or '.join(missing)} AOV for the effect masks")
    masks = effect_masks(load_scene(scene_file), image.aovs["id"], image.aovs["depth"])
    with atomic_output(stored) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **masks)  # type: ignore[arg-type]
    return masks
