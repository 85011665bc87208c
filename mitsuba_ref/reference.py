"""Reference renders with Mitsuba: `whitted` (rtval_whitted) or `path` (Mitsuba's own).

The render loop is ours, so that camera rays can go through pixel centres exactly as the
demo shoots (`centre_rays`) while every other random choice still varies per sample; without
it, positions are uniform in the pixel (a box filter). Each pass is one sample per pixel;
passes stop at `spp`, at `time_budget` seconds, or when the mean standard error of the
pixel means drops below `target_stderr`. Mean and per-sample variance are both returned.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsuba_ref.drjit_env import load_mitsuba
from mitsuba_ref.export import ExportedScene, ExportOptions, export_scene
from mitsuba_ref.plugin_tree import to_dict
from scene_model.scene import Scene

INTEGRATORS = ("whitted", "path")
MAX_PIXELS = 64 * 1024 * 1024  # as rtdemo: refuse before allocating
# Rays per JIT launch. Larger launches spend their time in the kernel, not in the render:
# drjit maps each launch's gigabyte of fresh state and page-faults it in (paper 640x480,
# whitted 32 spp: 11.1 s wall of which 10.4 s system time at 4 M rays per launch; 5.8 s and
# 0.25 s at 512 K; path 64 spp 16.3 s -> 13.9 s; bench/NOTES.md).
MAX_WAVEFRONT = 1 << 19
F32 = NDArray[np.float32]


@dataclass
class ReferenceSettings:
    integrator: str = "whitted"
    spp: int = 1
    seed: int = 0
    variant: str = "llvm_ad_rgb"
    centre_rays: bool = False
    light: str = "area"
    light_units: str = "calibrated"
    mapping: str = "physical"
    keep_huge_spheres: bool = False
    shadows: bool = True
    reflection: bool = True
    refraction: bool = True
    # The camera rays' id, depth and N AOVs: one Python loop over the pixels in scalar
    # variants (4 s at 1200x800), so a render wanted for its colour and time alone skips them.
    aovs: bool = True
    time_budget: float | None = None
    target_stderr: float | None = None
    size: tuple[int, int] | None = None
    # Sample counts below spp at which the running image is also handed out: the very image
    # a render of that many samples gives (same seed, same passes), for the cost of one.
    snapshots: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {self.integrator!r}")
        if self.spp < 1:
            raise ValueError(f"spp must be >= 1, got {self.spp}")
        if self.size and self.size[0] * self.size[1] > MAX_PIXELS:
            raise ValueError(
                f"image of {self.size[0]}x{self.size[1]} pixels is too large "
                f"(at most {MAX_PIXELS} pixels)"
            )
        if self.snapshots:
            self._check_snapshots()

    def _check_snapshots(self) -> None:
        if any(not 1 <= n < self.spp for n in self.snapshots):
            raise ValueError(
                f"snapshots must be 1 .. spp - 1 (spp {self.spp}), got {self.snapshots}"
            )
        if self.time_budget is not None or self.target_stderr is not None:
            raise ValueError(
                "snapshots need a render of exactly spp samples (no time budget or target)"
            )
        if _deterministic(self):
            raise ValueError(
                "snapshots: whitted with point lights through pixel centres is one pass for any spp"
            )


@dataclass
class ReferenceImage:
    rgb: F32  # mean, H x W x 3
    variance: F32 | None  # per-sample variance, None with one sample
    aovs: dict[str, F32]
    header: dict[str, str]
    spp_done: int
    seconds: float
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _deterministic(s: ReferenceSettings) -> bool:
    """Whitted with point lights through pixel centres uses no random number at all."""
    return s.integrator == "whitted" and s.light == "point" and s.centre_rays


def render_reference(
    scene: Scene,
    settings: ReferenceSettings,
    progress: Callable[[int, int, float], None] | None = None,
    snapshot: Callable[[ReferenceImage], None] | None = None,
) -> ReferenceImage:
    """`progress(samples done, samples asked, seconds)` after each pass (or JIT batch);
    `snapshot(image)` for each of settings.snapshots: the image a render of that spp returns
    (taken on the way where the launches allow, as they do at >= MAX_WAVEFRONT / 2 pixels)."""
    mi = load_mitsuba(settings.variant)
    import drjit as dr

    from mitsuba_ref import whitted  # deferred: drjit loads after drjit_env set its LLVM path

    whitted.register()
    exported, mscene = _loaded_scene(mi, settings.variant, scene, _export_options(settings))
    integrator = _integrator(mi, scene, settings)
    width, height = settings.size or (scene.camera.width, scene.camera.height)
    sensor = _sensor(mi, scene, exported, width, height)
    jit = bool(dr.is_jit_v(mi.Float))

    tracer = _Tracer(mi, dr, mscene, sensor, integrator, width, height)
    render_pass = _pass_renderer(tracer, settings)

    # JIT variants trace several samples per pixel in one wavefront (recording the
    # recursion once per batch); scalar variants go one sample at a time.
    batch_max = max(1, MAX_WAVEFRONT // (width * height)) if jit else 1
    settings = _snapshots_apart(scene, settings, batch_max, snapshot)
    sums = _Sums.zeros(height, width)

    def image(stopped_by: str, seconds: float, at: ReferenceSettings) -> ReferenceImage:
        aovs_key = (id(mscene), width, height)
        if at.aovs and aovs_key not in _AOVS:  # the camera rays' hits: the same for every render
            _AOVS[aovs_key] = _primary_aovs(tracer, exported.shape_index)
        aovs = {k: v.copy() for k, v in _AOVS[aovs_key].items()} if at.aovs else {}
        return _image(mi, scene, at, sums, aovs, exported, (stopped_by, seconds))

    def at_snapshot(seconds: float) -> None:
        if snapshot is not None:
            # Described as the render of that many samples would be.
            alone = dataclasses.replace(settings, spp=sums.done, snapshots=())
            snapshot(image("spp", seconds, alone))

    stopped_by, seconds = _run_passes(render_pass, sums, batch_max, settings, progress, at_snapshot)
    return image(stopped_by, seconds, settings)


def _snapshots_apart(
    scene: Scene,
    settings: ReferenceSettings,
    batch_max: int,
    snapshot: Callable[[ReferenceImage], None] | None,
) -> ReferenceSettings:
    """Renders on its own each snapshot that falls inside a launch of several samples (the
    render of its spp would cut its launches differently, so its samples are not a prefix
    of these); returns the settings with the snapshots left to take on the way."""
    for n in settings.snapshots:
        if n % batch_max and snapshot is not None:
            snapshot(render_reference(scene, dataclasses.replace(settings, spp=n, snapshots=())))
    kept = tuple(n for n in settings.snapshots if n % batch_max == 0)
    return dataclasses.replace(settings, snapshots=kept)


def _image(
    mi: Any,
    scene: Scene,
    settings: ReferenceSettings,
    sums: _Sums,
    aovs: dict[str, F32],
    exported: ExportedScene,
    stop: tuple[str, float],
) -> ReferenceImage:
    """The image of the samples in `sums`, made with `settings`; `stop`: what ended the
    render (its stopped_by) and when."""
    variance = None
    if sums.done >= 2:
        full = sums.variance()
        sums.update_stderr(full)
        variance = full.astype(np.float32)
    header = _header(mi, scene, settings, sums, stop)
    seconds = stop[1]
    mean = (sums.total / sums.done).astype(np.float32)
    notes, warnings = list(exported.notes), list(exported.warnings)
    return ReferenceImage(mean, variance, aovs, header, sums.done, seconds, notes, warnings)


@dataclass(frozen=True)
class _Tracer:
    """What a pass traces with: Mitsuba, Dr.Jit, the loaded scene, its sensor and
    integrator, and the render's size."""

    mi: Any
    dr: Any
    mscene: Any
    sensor: Any
    integrator: Any
    width: int
    height: int


def _pass_renderer(
    t: _Tracer, settings: ReferenceSettings
) -> Callable[[int, int], NDArray[np.float64]]:
    """render_pass(seed, batch): `batch` samples per pixel, batch x H x W x 3."""
    mi, mscene, sensor, integrator = t.mi, t.mscene, t.sensor, t.integrator
    jit = bool(t.dr.is_jit_v(mi.Float))

    def render_pass(seed: int, batch: int) -> NDArray[np.float64]:
        if jit:
            return _jit_batch(t, seed, batch, settings.centre_rays)
        if settings.integrator == "path" and not settings.centre_rays:
            # Mitsuba's own render loop (C++ threads over image blocks, box filter, positions
            # uniform in the pixel): the same estimator as the loop below, at the scalar
            # variant's own speed (paper 640x480, 1 spp: 0.15 s against 1.4 s in Python).
            image = mi.render(mscene, sensor=sensor, integrator=integrator, spp=1, seed=seed)
            return np.asarray(image, np.float64)[None, :, :, :3]
        return _scalar_pass(t, seed, settings.centre_rays)[None]

    return render_pass


def _export_options(settings: ReferenceSettings) -> ExportOptions:
    return ExportOptions(
        light=settings.light,
        light_units=settings.light_units,
        mapping=settings.mapping,
        keep_huge_spheres=settings.keep_huge_spheres,
        for_path=settings.integrator == "path",
    )


def _integrator(mi: Any, scene: Scene, settings: ReferenceSettings) -> Any:
    from mitsuba_ref import whitted  # deferred: drjit loads after drjit_env set its LLVM path

    if settings.integrator == "whitted":
        return mi.load_dict(
            {
                "type": whitted.NAME,
                "max_depth": scene.max_depth,
                "bias": scene.bias,
                "shadows": settings.shadows,
                "reflection": settings.reflection,
                "refraction": settings.refraction,
                **whitted.pruning(scene),
            }
        )
    if not (settings.shadows and settings.reflection and settings.refraction):
        raise ValueError("effect switches apply to the whitted integrator only")
    depth = scene.max_depth + 2
    return mi.load_dict({"type": "path", "max_depth": depth, "rr_depth": depth})


@dataclass
class _Sums:
    """Per pixel, the sum of the samples and of their squares, over `done` samples."""

    total: NDArray[np.float64]
    total_sq: NDArray[np.float64]
    done: int = 0
    stderr: float = float("nan")  # the mean standard error of the pixel means, from 2 samples

    @staticmethod
    def zeros(height: int, width: int) -> _Sums:
        shape = (height, width, 3)
        return _Sums(np.zeros(shape, np.float64), np.zeros(shape, np.float64))

    def add(self, samples: NDArray[np.float64], count: int) -> None:
        self.total += samples.sum(axis=0)
        self.total_sq += (samples * samples).sum(axis=0)
        self.done += count

    def variance(self) -> NDArray[np.float64]:
        """The per-sample variance (unbiased); needs done >= 2."""
        done = self.done
        var: NDArray[np.float64] = (
            np.maximum(self.total_sq / done - (self.total / done) ** 2, 0) * done / (done - 1)
        )
        return var

    def update_stderr(self, variance: NDArray[np.float64]) -> None:
        self.stderr = float(np.mean(np.sqrt(variance / self.done)))


def _run_passes(
    render_pass: Callable[[int, int], NDArray[np.float64]],
    sums: _Sums,
    batch_max: int,
    settings: ReferenceSettings,
    progress: Callable[[int, int, float], None] | None,
    at_snapshot: Callable[[float], None],
) -> tuple[str, float]:
    """Renders passes into `sums` until spp, the time budget or the target standard error;
    returns why it stopped and the seconds spent. No pass crosses a snapshot, so the passes
    up to one are those of a render of that many samples."""
    passes = 1 if _deterministic(settings) else settings.spp
    stops = sorted({*settings.snapshots, passes})
    start = time.perf_counter()
    while sums.done < passes:
        batch = min(batch_max, next(n for n in stops if n > sums.done) - sums.done)
        seed = (settings.seed * 1_000_003 + sums.done) % 2**32  # samplers take 32 bits
        sums.add(render_pass(seed, batch), batch)
        elapsed = time.perf_counter() - start
        target = settings.target_stderr
        if target is not None and sums.done >= 2:  # per pass only when it can stop the loop
            sums.update_stderr(sums.variance())
        if sums.done in settings.snapshots:
            at_snapshot(elapsed)
        if progress:
            progress(sums.done, passes, elapsed)
        over_budget = settings.time_budget is not None and elapsed >= settings.time_budget
        if over_budget and sums.done < passes:
            return "time budget", time.perf_counter() - start
        if target is not None and sums.done >= 2 and sums.stderr <= target:
            return "target std err", time.perf_counter() - start
    return "spp", time.perf_counter() - start


def _header(
    mi: Any, scene: Scene, settings: ReferenceSettings, sums: _Sums, stop: tuple[str, float]
) -> dict[str, str]:
    """The EXR's rtval.* attributes: how the image was made."""
    stopped_by, seconds = stop
    effects = [
        n
        for n, on in (
            ("shadows", settings.shadows),
            ("reflection", settings.reflection),
            ("refraction", settings.refraction),
        )
        if not on
    ]
    deterministic = _deterministic(settings)
    return {
        "rtval.renderer": "mitsuba",
        "rtval.scene": scene.name,
        "rtval.integrator": settings.integrator,
        "rtval.variant": settings.variant,
        "rtval.spp": str(settings.spp if deterministic else sums.done),
        "rtval.spp_requested": str(settings.spp),
        "rtval.stopped_by": "deterministic (1 pass = any spp)" if deterministic else stopped_by,
        "rtval.seed": str(settings.seed),
        "rtval.centre_rays": str(settings.centre_rays).lower(),
        "rtval.light": settings.light,
        "rtval.light_units": settings.light_units,
        "rtval.mapping": settings.mapping,
        "rtval.keep_huge_spheres": str(settings.keep_huge_spheres).lower(),
        "rtval.effects_off": " ".join(effects) or "none",
        "rtval.mean_stderr": f"{sums.stderr:.6g}",
        "rtval.render_seconds": f"{seconds:.4g}",
        "rtval.mitsuba_version": str(getattr(mi, "__version__", "?")),
    }


# A batch renders one scene several times: Mitsuba builds the paper scene in ~0.4 s, so the
# loaded scene is kept for the next render of the same scene, export and variant (rendering
# does not change it).
_LOADED: dict[tuple[str, Scene, ExportOptions], tuple[ExportedScene, Any]] = {}
_LOADED_MAX = 4
_AOVS: dict[tuple[int, int, int], dict[str, F32]] = {}  # (id of a loaded scene, width, height)


def _loaded_scene(
    mi: Any, variant: str, scene: Scene, options: ExportOptions
) -> tuple[ExportedScene, Any]:
    key = (variant, scene, options)
    if key not in _LOADED:
        if len(_LOADED) >= _LOADED_MAX:
            del _LOADED[next(iter(_LOADED))]
            _AOVS.clear()
        exported = export_scene(scene, options)
        _LOADED[key] = (exported, exported.load(mi))
    return _LOADED[key]


def _sensor(mi: Any, scene: Scene, exported: Any, width: int, height: int) -> Any:
    """The exported camera, with the film resized to the render size."""
    d = to_dict(exported.tree.props["sensor"], mi)
    d["film"]["width"], d["film"]["height"] = width, height
    return mi.load_dict(d)


def _film_positions(
    dr: Any, mi: Any, sampler: Any, width: int, height: int, centre: bool, batch: int = 1
) -> Any:
    """Film positions in [0, 1]^2, `batch` samples per pixel: centres or uniform in the pixel."""
    idx = dr.arange(mi.UInt32, width * height * batch) % (width * height)
    x = mi.Float(idx % width)
    y = mi.Float(idx // width)
    if centre:
        return mi.Point2f((x + 0.5) / width, (y + 0.5) / height)
    offset = sampler.next_2d()
    return mi.Point2f((x + offset.x) / width, (y + offset.y) / height)


def _jit_batch(t: _Tracer, seed: int, batch: int, centre: bool) -> NDArray[np.float64]:
    """`batch` samples per pixel in one wavefront: batch x H x W x 3."""
    mi, dr, width, height = t.mi, t.dr, t.width, t.height
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, width * height * batch)
    pos = _film_positions(dr, mi, sampler, width, height, centre, batch)
    ray, weight = t.sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    L, _, _ = t.integrator.sample(t.mscene, sampler, ray, None, True)
    L = L * weight
    out = np.stack([np.asarray(L.x), np.asarray(L.y), np.asarray(L.z)], axis=-1)
    return out.reshape(batch, height, width, 3).astype(np.float64)


def _scalar_pass(t: _Tracer, seed: int, centre: bool) -> NDArray[np.float64]:
    mi, width, height = t.mi, t.width, t.height
    out = np.zeros((height, width, 3), np.float64)
    sampler = mi.load_dict({"type": "independent"})
    for y in range(height):
        for x in range(width):
            sampler.seed(seed * 7_919 + y * width + x)
            if centre:
                pos = mi.Point2f((x + 0.5) / width, (y + 0.5) / height)
            else:
                o = sampler.next_2d()
                pos = mi.Point2f((x + o.x) / width, (y + o.y) / height)
            ray, weight = t.sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
            L, _, _ = t.integrator.sample(t.mscene, sampler, ray, None, True)
            out[y, x] = [L[0] * weight[0], L[1] * weight[1], L[2] * weight[2]]
    return out


def _primary_aovs(t: _Tracer, shape_index: dict[str, int]) -> dict[str, F32]:
    """id, depth and N of the camera ray through each pixel centre (same meaning as the demo's)."""
    ids = np.full((t.height, t.width), -1.0, np.float32)
    depth = np.zeros((t.height, t.width), np.float32)
    normal = np.zeros((t.height, t.width, 3), np.float32)
    fill = _primary_hits_jit if t.dr.is_jit_v(t.mi.Float) else _primary_hits_scalar
    fill(t, shape_index, ids, depth, normal)
    return {
        "id": ids,
        "depth": depth,
        "N.X": normal[..., 0],
        "N.Y": normal[..., 1],
        "N.Z": normal[..., 2],
    }


def _primary_hits_jit(
    t: _Tracer, shape_index: dict[str, int], ids: F32, depth: F32, normal: F32
) -> None:
    """Fills ids, depth and normal (H x W arrays) from one wavefront of centre rays."""
    mi, dr, mscene, sensor = t.mi, t.dr, t.mscene, t.sensor
    height, width = ids.shape
    pos = _film_positions(dr, mi, None, width, height, True)
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    si = mscene.ray_intersect(ray)
    hit_shape = dr.reinterpret_array(mi.UInt32, si.shape)
    # One kernel for every field read below; each lazy read would trace the rays again.
    dr.eval(si.is_valid(), hit_shape, si.t, si.sh_frame.n, ray.d)
    valid = np.asarray(si.is_valid()).reshape(height, width)
    registry = np.asarray(hit_shape).reshape(height, width)
    lookup = {}
    for shape in mscene.shapes():
        rid = int(np.asarray(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape)))[0])
        lookup[rid] = shape_index.get(shape.id(), -1)
    for rid, index in lookup.items():
        ids[(registry == rid) & valid] = index
    hit_t = np.asarray(si.t).reshape(height, width)
    n = np.stack([np.asarray(c) for c in (si.sh_frame.n.x, si.sh_frame.n.y, si.sh_frame.n.z)], -1)
    d = np.stack([np.asarray(c) for c in (ray.d.x, ray.d.y, ray.d.z)], -1)
    n = n.reshape(height, width, 3)
    d = d.reshape(height, width, 3)
    flip = np.where((n * d).sum(-1, keepdims=True) > 0, -1.0, 1.0)
    depth[valid] = hit_t[valid]
    normal[valid] = (n * flip)[valid]


def _primary_hits_scalar(
    t: _Tracer, shape_index: dict[str, int], ids: F32, depth: F32, normal: F32
) -> None:
    """Fills ids, depth and normal (H x W arrays) one centre ray at a time."""
    mi, mscene, sensor = t.mi, t.mscene, t.sensor
    height, width = ids.shape
    for y in range(height):
        for x in range(width):
            centre = mi.Point2f((x + 0.5) / width, (y + 0.5) / height)
            ray, _ = sensor.sample_ray(0.0, 0.5, centre, mi.Point2f(0.5, 0.5))
            si = mscene.ray_intersect(ray)
            if not si.is_valid():
                continue
            ids[y, x] = shape_index.get(si.shape.id(), -1)
            depth[y, x] = si.t
            n = np.array([si.sh_frame.n[0], si.sh_frame.n[1], si.sh_frame.n[2]])
            dd = np.array([ray.d[0], ray.d[1], ray.d[2]])
            normal[y, x] = -n if n @ dd > 0 else n
