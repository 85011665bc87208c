"""Student-style variants of the classic program, for `rtval diagnose`'s tests: the
independent numpy tracer of tests/numpy_reference.py (classic mode) with one mistake each,
written as the classic program writes its output (a binary PPM, each channel
`(unsigned char)(min(1, x) * 255)`: clamped and truncated, NaN as 0).

Each variant names the cause `diagnose` should find, in the words of its Diagnosis:
a quirk present ("+Q2"), an effect off ("shadows") or a named mistake (mistakes.json).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from numpy_reference import ReferenceTracer, _dot, _normalize

from scene_model.scene import Scene

F64 = NDArray[np.float64]

# variant -> what diagnose should name
VARIANTS: dict[str, str] = {
    "wrong_eta_leaving": "+Q2",
    "no_offset": "no_offset",
    "no_shadows": "shadows",
    "no_inside_flip": "no_inside_flip",
    "constant_fresnel": "fresnel_constant",
    "black_background": "black_background",
}


class StudentTracer(ReferenceTracer):
    """The classic program with one of VARIANTS (or none: "exact")."""

    def __init__(self, scene: Scene, variant: str = "exact") -> None:
        if variant != "exact" and variant not in VARIANTS:
            raise ValueError(variant)
        if variant == "no_offset":  # every secondary and shadow ray starts on the surface
            scene = dataclasses.replace(scene, bias=0.0)
        if variant == "black_background":  # a miss returns black, not the scene's colour
            scene = dataclasses.replace(scene, background=(0.0, 0.0, 0.0))
        super().__init__(scene, "classic")
        self.variant = variant

    def trace(self, o: F64, d: F64, depth: int) -> F64:
        n_rays = len(o)
        t_near = np.full(n_rays, np.inf)
        index = np.full(n_rays, -1)
        for i in range(len(self.radii)):
            ok, t = _hit(self.centers[i], self.radii[i], o, d)
            better = ok & (t < t_near)
            t_near = np.where(better, t, t_near)
            index = np.where(better, i, index)
        out = np.tile(np.array(self.scene.background, dtype=np.float64), (n_rays, 1))
        hit = index >= 0
        if not hit.any():
            return out
        idx = index[hit]
        p = o[hit] + d[hit] * t_near[hit][:, None]
        n = _normalize(p - self.centers[idx])
        inside = _dot(d[hit], n) > 0
        if self.variant != "no_inside_flip":  # the mistake: inside is known, n stays outward
            n = np.where(inside[:, None], -n, n)
        specular = ((self.transparency[idx] > 0) | (self.reflection[idx] > 0)) & (
            depth < self.scene.max_depth
        )
        colour = np.zeros_like(p)
        if specular.any():
            colour[specular] = self._specular(
                d[hit][specular], p[specular], n[specular], inside[specular], idx[specular], depth
            )
        diffuse = ~specular
        if diffuse.any():
            colour[diffuse] = self._lit(p[diffuse], n[diffuse]) * self.colors[idx[diffuse]]
        out[hit] = colour + self.emission[idx]
        return out

    def _specular(
        self, d: F64, p: F64, n: F64, inside: NDArray[np.bool_], idx: NDArray[np.int_], depth: int
    ) -> F64:
        bias = self.scene.bias
        idotn = _dot(d, n)
        facing = np.maximum(0.0, -idotn)
        if self.variant == "constant_fresnel":
            fresnel = np.full(len(d), 0.5)
        else:
            fresnel = 0.1 + 0.9 * (1 - facing) ** 3
        reflected = self.trace(p + n * bias, _normalize(d - 2 * idotn[:, None] * n), depth + 1)
        refracted = np.zeros_like(p)
        glass = self.transparency[idx] > 0
        if glass.any():
            ior = self.ior[idx][glass]
            eta = (
                1 / ior
                if self.variant == "wrong_eta_leaving"
                else np.where(inside[glass], ior, 1 / ior)
            )
            cosi = -idotn[glass]
            k = 1 - eta * eta * (1 - cosi * cosi)
            t = _normalize(d[glass] * eta[:, None] + n[glass] * (eta * cosi - np.sqrt(k))[:, None])
            refracted[glass] = self.trace(p[glass] - n[glass] * bias, t, depth + 1)
        weight = (1 - fresnel) * self.transparency[idx]
        return np.asarray(
            (reflected * fresnel[:, None] + refracted * weight[:, None]) * self.colors[idx]
        )

    def _lit(self, p: F64, n: F64) -> F64:
        """Binary shadows per light (classic), or none at all in the no_shadows variant."""
        colour = np.zeros_like(p)
        origin = p + n * self.scene.bias
        for light in self.lights:
            l_dir = _normalize(self.centers[light][None, :] - p)
            lit = np.ones(len(p))
            if self.variant != "no_shadows":
                for j in range(len(self.radii)):
                    if j != light:
                        blocked, _ = _hit(self.centers[j], self.radii[j], origin, l_dir)
                        lit = np.where(blocked, 0.0, lit)
            colour += (lit * np.maximum(0.0, _dot(n, l_dir)))[:, None] * self.emission[light]
        return colour


def _hit(center: F64, radius: float, o: F64, d: F64) -> tuple[NDArray[np.bool_], F64]:
    from numpy_reference import _paper_hit

    return _paper_hit(center, radius, o, d)


def write_truncating_ppm(path: Path, rgb: F64) -> None:
    """P6 as the classic program writes it: (unsigned char)(min(1, x) * 255), NaN -> 0."""
    c = np.minimum(1.0, np.nan_to_num(rgb, nan=0.0))
    data = (np.maximum(c, 0.0) * 255).astype(np.uint8)
    h, w = data.shape[:2]
    path.write_bytes(f"P6\n{w} {h}\n255\n".encode() + data.tobytes())


def render_variant(scene: Scene, variant: str, width: int, height: int, path: Path) -> Path:
    tracer = StudentTracer(scene, variant)
    o, d = tracer.camera_rays(width, height)
    with np.errstate(invalid="ignore", divide="ignore"):
        rgb = tracer.trace(o, d, 0).reshape(height, width, 3)
    write_truncating_ppm(path, rgb)
    return path
