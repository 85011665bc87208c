"""Per-effect masks: which pixels show which effect, from the id/depth AOVs and the scene.

  background  camera ray missed every sphere
  emitter     camera ray hit a light
  direct      a diffuse surface with no light blocked (lit, facing away, or in a scene
              without light, where the reference shows it black)
  shadow      a diffuse surface where some light is blocked (cast shadow)
  reflection  a mirror sphere
  refraction  a glass sphere
  edges       silhouettes: the id changes within one pixel (kept out of the others)

A mask may have no pixel (no light: no shadow; no light in view: no emitter): the effect
does not occur in the scene, and evaluate.py leaves it unscored.

The shadow test is the physical one: from the camera hit point towards each light's centre,
bounded by the light, any other sphere blocks (float64 numpy, independent of both renderers).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scene_model.scene import Scene

EFFECTS = ("background", "emitter", "direct", "shadow", "reflection", "refraction", "edges")
"""The effects judged apart, each a mask of effect_masks (the module's docstring says which
pixels); per-effect results are listed in this order."""

BOOL = NDArray[np.bool_]


def camera_directions(scene: Scene, width: int, height: int) -> NDArray[np.float64]:
    """Unit directions through the pixel centres (docs/paper-model.md's camera), H x W x 3."""
    cam = scene.camera
    pos = np.array(cam.position, np.float64)
    forward = np.array(cam.look_at, np.float64) - pos
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.array(cam.up, np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    a = np.tan(np.radians(cam.fov_y) / 2)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    xx = (2 * (xs + 0.5) / width - 1) * a * width / height
    yy = (1 - 2 * (ys + 0.5) / height) * a
    d = xx[..., None] * right + yy[..., None] * up + forward
    return np.asarray(d / np.linalg.norm(d, axis=-1, keepdims=True))


def _blocked(scene: Scene, p: NDArray[np.float64], own: NDArray[np.int_], light: int) -> BOOL:
    c_l = np.array(scene.spheres[light].center)
    to_l = c_l - p
    dist = np.linalg.norm(to_l, axis=-1)
    d = to_l / np.maximum(dist, 1e-12)[..., None]
    # The scene's bias, scaled as the demo's physical mode and the Whitted reference scale it.
    origin = p + d * (scene.bias * (1 + np.abs(p).max(axis=-1)))[..., None]
    blocked = np.zeros(len(p), bool)
    for j, s in enumerate(scene.spheres):
        if j == light:
            continue
        oc = origin - np.array(s.center)
        b = (oc * d).sum(-1)
        perp = oc - d * b[..., None]
        disc = s.radius**2 - (perp * perp).sum(-1)
        ok = disc >= 0
        sq = np.sqrt(np.where(ok, disc, 0))
        c = (oc * oc).sum(-1) - s.radius**2
        q = -b - np.copysign(sq, b)
        with np.errstate(divide="ignore", invalid="ignore"):
            t0 = np.where(q != 0, c / q, 0.0)
        t1 = q
        lo, hi = np.minimum(t0, t1), np.maximum(t0, t1)
        hit = ok & (((lo > 0) & (lo < dist)) | ((hi > 0) & (hi < dist)))
        blocked |= hit & (own != j)
    return blocked


def effect_masks(
    scene: Scene, ids: NDArray[np.float32], depth: NDArray[np.float32]
) -> dict[str, BOOL]:
    """Which pixels show which effect, from the camera ray's AOVs and the scene.

    Each mask but ``edges`` leaves out the edge pixels (an id change within one pixel). The
    shadow test casts a ray from each diffuse hit towards every light's centre (float64).

    Parameters
    ----------
    scene : Scene
        The scene rendered: its camera, spheres' kinds (diffuse, mirror, glass, light) and bias.
    ids : ndarray of float32, H x W
        The ``id`` AOV: the index of the sphere hit through each pixel centre (rounded),
        negative where the ray hits nothing.
    depth : ndarray of float32, H x W
        The ``depth`` AOV: the hit's distance along the unit camera ray.

    Returns
    -------
    dict[str, ndarray of bool]
        One H x W mask per name in EFFECTS; a mask may be empty (the effect is absent).
    """
    h, w = ids.shape
    idx = np.rint(ids).astype(int)
    kinds = np.array([s.kind for s in scene.spheres] + ["none"])  # -1 -> "none"
    kind = kinds[np.where(idx >= 0, idx, len(scene.spheres))]
    edges = np.zeros((h, w), bool)
    for axis in (0, 1):
        change = np.diff(idx, axis=axis) != 0
        if axis == 0:
            edges[:-1] |= change
            edges[1:] |= change
        else:
            edges[:, :-1] |= change
            edges[:, 1:] |= change
    diffuse = kind == "diffuse"
    shadow = np.zeros((h, w), bool)
    if diffuse.any() and scene.lights:
        d = camera_directions(scene, w, h)
        p = np.array(scene.camera.position) + d * depth[..., None].astype(np.float64)
        pts, own = p[diffuse], idx[diffuse]
        blocked = np.zeros(len(pts), bool)
        for light in scene.lights:
            blocked |= _blocked(scene, pts, own, light)
        shadow[diffuse] = blocked
    keep = ~edges
    return {
        "background": (idx < 0) & keep,
        "emitter": (kind == "light") & keep,
        "direct": diffuse & ~shadow & keep,
        "shadow": shadow & keep,
        "reflection": (kind == "mirror") & keep,
        "refraction": (kind == "glass") & keep,
        "edges": edges,
    }
