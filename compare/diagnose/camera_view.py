"""Where the camera stands and looks, read from the silhouettes: the slips a program makes with
the scene's position and look_at.

The lineage's programs (scratchapixel's, the paper's) have no camera but a pinhole at the
origin looking down -z. Given a scene whose camera stands or looks elsewhere (the lit scene
looks down from (0, 1, 4)), a program keeps that fixed camera, ignores look_at, ignores the
position, or reads look_at as a direction instead of a point. Each is a camera (position,
look_at) of its own, which a copy of the scene renders exactly.

The silhouettes choose among them: the sphere boundaries of each story's id map (its camera
rays' first hits, computed here, no render) are looked up in the image's edges. A story is
offered where the image has edges on clearly more of its boundaries than on the scene camera's
(SILHOUETTE_GAIN), and about as many as on the best story's; the render and the gates then
decide whether it is named.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from compare.diagnose import camera_fit
from compare.diagnose.candidate import Vec3, view_key
from compare.judge.arrays import F32
from compare.judge.effects import camera_directions
from scene_model.scene import Scene

# An edge: the display luminance changes by this much towards the next pixel.
EDGE_MIN = 0.02
# The image's edges cover a right story's boundaries about twice as well as a wrong camera's
# (measured on the lit scene at 320x240: 0.49-0.55 against 0.07-0.35); a story is offered at
# SILHOUETTE_GAIN times the scene camera's share and SILHOUETTE_NEAR of the best story's.
SILHOUETTE_GAIN = 1.3
SILHOUETTE_NEAR = 0.8
# Sphere-pixel tests one id map may cost (a 640x480 image of 26 spheres at every pixel).
FIRST_HIT_BUDGET = 8_000_000


@dataclass(frozen=True)
class View:
    """A camera the image shows: where it stands and looks, and the slip it is, in words."""

    position: Vec3
    look_at: Vec3
    words: str

    @property
    def key(self) -> str:
        return view_key(self.position, self.look_at, self.words)


def stories(scene: Scene) -> list[View]:
    """The views a program's slips give for the scene's camera, without those that are the
    scene's own view or repeat an earlier one."""
    camera = scene.camera
    pos, at = camera.position, camera.look_at
    down_z = (0.0, 0.0, -1.0)
    options = [
        View((0.0, 0.0, 0.0), down_z,
             "the camera at the origin looking down -z (the scene's position and look_at ignored)"),
        View(pos, _add(pos, down_z), "the camera looking down -z from its position (look_at ignored)"),
        View(pos, _add(pos, at), "look_at taken as a direction from the position, not a point"),
        View((0.0, 0.0, 0.0), at, "the camera at the origin (its position ignored), looking at look_at"),
    ]  # fmt: skip
    out: list[View] = []
    seen = [_pose(pos, at)]
    for v in options:
        pose = _pose(v.position, v.look_at)
        if pose is not None and not _parallel(v, camera.up) and all(pose != s for s in seen):
            out.append(v)
            seen.append(pose)
    return out


def fitted(edges: np.ndarray, scene: Scene) -> list[View]:
    """The stories whose sphere boundaries the image's edges (H x W, True where the image has
    an edge, grown by a pixel) cover SILHOUETTE_GAIN times as well as the scene camera's, and
    within SILHOUETTE_NEAR of the best story; best first."""
    share = _share_of(edges, scene)
    own = share(scene.camera.position, scene.camera.look_at)
    scored = [(share(v.position, v.look_at), v) for v in stories(scene)]
    best = max((s for s, _ in scored), default=0.0)
    keep = [(s, v) for s, v in scored if s >= SILHOUETTE_GAIN * own and s >= SILHOUETTE_NEAR * best]
    return [v for _, v in sorted(keep, key=lambda sv: -sv[0])]


def outline_share(rgb: F32, ids: np.ndarray) -> float:
    """The share of the sphere outlines of an id map (a render's id AOV, -1 on a miss) on
    which the image has an edge: where its spheres lie against where the model draws them."""
    return _covered(image_edges(rgb), _boundaries(ids))


def scene_outline_share(rgb: F32, scene: Scene) -> float:
    """outline_share for the scene's own camera, its id map computed here (no render)."""
    return _share_of(image_edges(rgb), scene)(scene.camera.position, scene.camera.look_at)


def _share_of(edges: np.ndarray, scene: Scene) -> Callable[[Vec3, Vec3], float]:
    """The share of a pinhole's sphere boundaries (position, look_at) that `edges` cover. A
    scene of many spheres is looked at on every step-th pixel (FIRST_HIT_BUDGET), the edges
    grown by the step."""
    h, w = edges.shape
    step = max(1, math.ceil(math.sqrt(len(scene.spheres) * w * h / FIRST_HIT_BUDGET)))
    sampled = _grown(edges, step - 1)[::step, ::step]

    def share(position: Vec3, look_at: Vec3) -> float:
        ids = _first_hits(scene, position, look_at, (w, h), step)
        return _covered(sampled, _boundaries(ids))

    return share


def image_edges(rgb: F32) -> np.ndarray:
    """H x W: where the image's display luminance changes by EDGE_MIN towards the next pixel
    right or down, grown by a pixel (a silhouette's edge lies on either side of it)."""
    strong = camera_fit.edges(rgb) > EDGE_MIN
    return _grown(strong)


def _first_hits(
    scene: Scene, position: Vec3, look_at: Vec3, size: tuple[int, int], step: int
) -> np.ndarray:
    """The index of the sphere each camera ray of that pinhole hits first (-1: none), on every
    step-th pixel of each row and column."""
    w, h = size
    cam = dataclasses.replace(scene.camera, position=position, look_at=look_at)
    grid = camera_directions(dataclasses.replace(scene, camera=cam), w, h)[::step, ::step]
    d = grid.reshape(-1, 3)
    origin = np.array(position, np.float64)
    nearest = np.full(len(d), np.inf)
    ids = np.full(len(d), -1)
    for k, s in enumerate(scene.spheres):
        oc = origin - np.array(s.center, np.float64)
        b = d @ oc
        disc = b * b - (oc @ oc - s.radius**2)
        root = np.sqrt(np.maximum(disc, 0.0))
        t = np.where(-b - root > 0, -b - root, -b + root)
        hit = (disc >= 0) & (t > 0) & (t < nearest)
        nearest[hit], ids[hit] = t[hit], k
    return ids.reshape(grid.shape[:2])


def _boundaries(ids: np.ndarray) -> np.ndarray:
    """H x W: pixels whose right or lower neighbour's first hit is another sphere's."""
    out = np.zeros(ids.shape, bool)
    out[:, :-1] |= ids[:, :-1] != ids[:, 1:]
    out[:-1, :] |= ids[:-1, :] != ids[1:, :]
    return out


def _covered(edges: np.ndarray, boundaries: np.ndarray) -> float:
    """The share of the boundary pixels where the image has an edge (0 without boundaries)."""
    return float(edges[boundaries].mean()) if boundaries.any() else 0.0


def _grown(mask: np.ndarray, pixels: int = 1) -> np.ndarray:
    """mask grown by `pixels` in each of the four directions, in turn."""
    out = mask.copy()
    for _ in range(pixels):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def _add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _pose(position: Vec3, look_at: Vec3) -> tuple[Vec3, Vec3] | None:
    """(position, unit direction) rounded to compare views; None for no direction."""
    d = np.subtract(look_at, position)
    n = float(np.linalg.norm(d))
    if n == 0 or not math.isfinite(n):
        return None
    u = d / n
    return tuple(round(float(v), 9) for v in position), tuple(round(float(v), 9) for v in u)  # type: ignore[return-value]


def _parallel(v: View, up: Vec3) -> bool:
    """Whether v looks along the scene's up (a camera without a right-hand axis)."""
    d = np.subtract(v.look_at, v.position)
    c = np.cross(d, up)
    return bool(np.linalg.norm(c) <= 1e-9 * np.linalg.norm(d))
