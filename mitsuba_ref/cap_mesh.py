"""A spherical-cap triangle mesh standing in for a huge sphere (the paper's floor).

Mitsuba intersects in float32: a radius-1e4 sphere gives acne and black specks, and a
flat disk moves the horizon by ~28 rows. The cap keeps the sphere's curvature: vertices
lie on the sphere, with exact radial normals, in rings graded by distance from the camera
so that the chord error (sagitta), along rings and across them, stays below
max(min_sagitta, rel_sagitta * distance). Vertex coordinates near the camera are small, so
float32 is precise there. With 512 segments per ring the azimuthal chords sagged ~4e-4 at
the paper floor's shadow edges, enough to flip shadow and horizon pixels against the demo
(bench/NOTES.md); the segment count now follows the same rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scene_model.scene import Vec3

HUGE_RADIUS = 100.0  # spheres at least this large are exported as caps


@dataclass(frozen=True)
class CapMesh:
    positions: NDArray[np.float32]  # V x 3
    normals: NDArray[np.float32]  # V x 3, unit, outward
    faces: NDArray[np.uint32]  # F x 3
    theta_max: float  # angular radius of the cap, radians


def _rings(
    radius: float, height: float, theta_max: float, min_sagitta: float, rel_sagitta: float
) -> list[float]:
    thetas = [0.0]
    while thetas[-1] < theta_max:
        arc = radius * thetas[-1]
        dist = math.hypot(arc, height)
        sagitta = max(min_sagitta, rel_sagitta * dist)
        step = math.sqrt(8.0 * sagitta / radius)
        thetas.append(min(theta_max, thetas[-1] + step))
    return thetas


def _azimuth_segments(
    radius: float, height: float, thetas: list[float], min_sagitta: float, rel_sagitta: float
) -> int:
    # A ring of radius rho cut into n chords sags rho * (1 - cos(pi / n)) ~ rho (pi/n)^2 / 2.
    need = 3
    for theta in thetas[1:]:
        rho = radius * math.sin(theta)
        sagitta = max(min_sagitta, rel_sagitta * math.hypot(radius * theta, height))
        need = max(need, math.ceil(math.pi * math.sqrt(rho / (2.0 * sagitta))))
    return -(-need // 64) * 64


def build_cap(
    center: Vec3,
    radius: float,
    eye: Vec3,
    *,
    azimuth: int | None = None,
    min_sagitta: float = 1e-5,
    rel_sagitta: float = 2e-6,
    extra_angle: float = 0.05,
) -> CapMesh:
    """Cap around the point of the sphere nearest to `eye`, reaching past its horizon.

    Raises ValueError when the eye is inside the sphere (a cap cannot stand in then).
    """
    c = np.array(center, dtype=np.float64)
    to_eye = np.array(eye, dtype=np.float64) - c
    dist = float(np.linalg.norm(to_eye))
    if dist <= radius:
        raise ValueError("the camera is inside the sphere; a cap mesh cannot replace it")
    axis = to_eye / dist
    height = dist - radius
    horizon = math.acos(radius / dist)
    theta_max = min(math.pi / 2, 2.0 * horizon + extra_angle)
    ring_list = _rings(radius, height, theta_max, min_sagitta, rel_sagitta)
    thetas = np.array(ring_list)
    if azimuth is None:
        azimuth = _azimuth_segments(radius, height, ring_list, min_sagitta, rel_sagitta)

    positions, normals = _vertices(c, radius, axis, thetas[1:], azimuth)
    return CapMesh(
        positions=positions.astype(np.float32),
        normals=normals.astype(np.float32),
        faces=_faces(len(thetas) - 1, azimuth),
        theta_max=theta_max,
    )


def _vertices(
    c: NDArray[np.float64],
    radius: float,
    axis: NDArray[np.float64],
    ring_thetas: NDArray[np.float64],
    azimuth: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions and unit normals: the pole on `axis`, then each ring's `azimuth` vertices."""
    # Orthonormal frame around the axis.
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)

    phis = np.linspace(0.0, 2.0 * math.pi, azimuth, endpoint=False)
    st, ct = np.sin(ring_thetas)[:, None], np.cos(ring_thetas)[:, None]
    dirs = ct[..., None] * axis + st[..., None] * (
        np.cos(phis)[None, :, None] * u + np.sin(phis)[None, :, None] * v
    )
    normals = np.concatenate([axis[None, :], dirs.reshape(-1, 3)])
    return c + radius * normals, normals


def _faces(n_rings: int, azimuth: int) -> NDArray[np.uint32]:
    """A fan around the pole, then two triangles per quad between successive rings."""
    faces = []
    ring0 = 1 + np.arange(azimuth)
    nxt = np.roll(np.arange(azimuth), -1)
    faces.append(np.stack([np.zeros(azimuth, dtype=np.int64), ring0, 1 + nxt], axis=1))
    for r in range(n_rings - 1):
        a = 1 + r * azimuth + np.arange(azimuth)
        b = 1 + r * azimuth + nxt
        a2 = a + azimuth
        b2 = b + azimuth
        faces.append(np.stack([a, a2, b2], axis=1))
        faces.append(np.stack([a, b2, b], axis=1))
    return np.concatenate(faces).astype(np.uint32)
