"""Where the light is, read off the directly lit surfaces: a program that puts the scene's one
light elsewhere (CAPBenchmarks' RT kernel has scratchapixel's light at y = 30, not 20) lights
every diffuse surface at other angles.

Where the start's shading has the cosine (no Q11, no Q12), a directly lit pixel is its albedo
times the light's emission times n . l, with n the surface normal and l the unit direction to
the light's centre. At the pixels both the image and the start light, the image's value over
the start's is therefore n . l_new over n . l_old: a target for n . l_new at known points and
normals (the start's id and depth AOVs). The light's centre is fitted to those targets by
robust least squares, from the scene's, and snapped to round numbers; only that position is
rendered (a copy of the scene), and the gates decide whether it is named.

An 8-bit value stands for a range: a truncating writer's code c holds [c, c + 1) / 255, a
rounding one's [c - 0.5, c + 0.5) / 255. The fit is made for both readings; each gives a
position.
"""

from __future__ import annotations

import math

import numpy as np

from compare.diagnose.candidate import Vec3
from compare.diagnose.refine import code_readings
from compare.judge.arrays import F32
from compare.judge.effects import BOOL, camera_directions
from compare.judge.images import Image
from scene_model.scene import Scene

# The pixels used: lit in both images, by at least this much, and not clipped.
DARKEST = 8 / 255
BRIGHTEST = 254 / 255
MIN_PIXELS = 64
# The fit must explain the targets this well (RMS of n . l), and move the light this far
# (scene units) from the scene's, but no farther than the scene's light is from the camera
# (a light fitted far off is a direction, not a position a program types: serifagir's
# light direction taken from the normal, not the hit point, fits one 2,000 units away).
MAX_RMS = 0.01
MIN_MOVE = 0.25
# A coordinate is snapped to a whole number within this, else to one decimal.
WHOLE = 0.2


def lights_seen(test: F32, start: Image, direct: BOOL, scene: Scene, encoding: str) -> list[Vec3]:
    """The light centres the image's directly lit pixels (`direct`, the start's mask) show
    against `start` (the start's render with its id and depth AOVs): one per reading of the
    8-bit codes, snapped, without repeats and without the scene's own; [] where the scene has
    not one light or the fit explains too little."""
    lights = [s for s in scene.spheres if s.kind == "light"]
    if len(lights) != 1 or "id" not in start.aovs or "depth" not in start.aovs:
        return []
    own = np.array(lights[0].center, np.float64)
    reach = float(np.linalg.norm(own - np.array(scene.camera.position, np.float64)))
    points, normals, before = _surfaces(start, direct, scene)
    out: list[Vec3] = []
    for reading in code_readings(test, encoding):
        after = reading.mean(axis=-1)[direct]
        fitted = _fitted(points, normals, before, after, own)
        if fitted is None:
            continue
        snapped = tuple(_snapped(v) for v in fitted)
        centre = (snapped[0], snapped[1], snapped[2])
        moved = float(np.linalg.norm(np.subtract(centre, own)))
        if centre not in out and MIN_MOVE <= moved <= reach:
            out.append(centre)
    return out


def _surfaces(start: Image, direct: BOOL, scene: Scene) -> tuple[np.ndarray, ...]:
    """Points, unit normals and the start's values (channel means) at the `direct` pixels."""
    h, w = direct.shape
    d = camera_directions(scene, w, h)[direct]
    depth = start.aovs["depth"][direct].astype(np.float64)
    points = np.array(scene.camera.position, np.float64) + d * depth[:, None]
    ids = np.rint(start.aovs["id"][direct]).astype(int)
    centres = np.array([s.center for s in scene.spheres], np.float64)[np.clip(ids, 0, None)]
    normals = points - centres
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return points, normals, start.rgb[direct].mean(axis=-1).astype(np.float64)


def _fitted(
    points: np.ndarray, normals: np.ndarray, before: np.ndarray, after: np.ndarray, own: np.ndarray
) -> np.ndarray | None:
    """The light centre whose n . l best matches (after / before) n . l_own, or None."""
    lit = (before > DARKEST) & (after > DARKEST) & (before < BRIGHTEST) & (after < BRIGHTEST)
    if lit.sum() < MIN_PIXELS:
        return None
    p, n = points[lit], normals[lit]
    target = after[lit] / before[lit] * _cosines(own, p, n)

    from scipy.optimize import least_squares  # 0.4 s to import: only where a light is fitted

    def residual(centre: np.ndarray) -> np.ndarray:
        return np.asarray(_cosines(centre, p, n) - target)

    fit = least_squares(residual, own, loss="soft_l1", f_scale=0.02)
    rms = float(np.sqrt(np.mean(fit.fun**2)))
    if not fit.success or not np.isfinite(fit.x).all() or rms > MAX_RMS:
        return None
    return np.asarray(fit.x)


def _cosines(centre: np.ndarray, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    to_light = centre - points
    return np.asarray((normals * to_light).sum(axis=1) / np.linalg.norm(to_light, axis=1))


def _snapped(v: float) -> float:
    whole = round(v)
    return float(whole) if abs(v - whole) <= WHOLE else float(math.floor(v * 10 + 0.5) / 10)
