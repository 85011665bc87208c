"""An independent float64 numpy implementation of docs/paper-model.md (`paper` and `classic`
modes: paper has every quirk Q1-Q13, classic fixes Q2, Q4, Q9, Q11, Q12 and Q13), written from
the spec rather than from demo_cpp, to check the C++ renderer.

Vectorised over rays; the recursion follows both branches for whole batches. The small
hook methods (background, offset, face_forward, eta, fresnel, occluded) are the single steps
tests/student_variants.py overrides to make one student mistake each.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from compare.judge.effects import camera_directions
from scene_model.scene import Scene

F64 = NDArray[np.float64]


def _normalize(v: F64) -> F64:
    return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


def _dot(a: F64, b: F64) -> F64:
    return np.asarray(np.einsum("ij,ij->i", a, b))


def _paper_hit(center: F64, radius: float, o: F64, d: F64) -> tuple[NDArray[np.bool_], F64]:
    """The geometric test with the tca < 0 early-out (Q1); t0, or t1 when t0 < 0."""
    L = center[None, :] - o
    tca = _dot(L, d)
    d2 = _dot(L, L) - tca * tca
    r2 = radius * radius
    ok = ~(tca < 0) & ~(d2 > r2)  # NaN passes both tests, as in C++
    thc = np.sqrt(np.where(ok, r2 - d2, 0.0))
    t0, t1 = tca - thc, tca + thc
    return ok, np.where(t0 < 0, t1, t0)


class ReferenceTracer:
    def __init__(self, scene: Scene, mode: str) -> None:
        if mode not in ("paper", "classic"):
            raise ValueError(mode)
        self.scene = scene
        self.classic = mode == "classic"
        # The paper's direct light, which the classic program fixes: the colour starts at 1
        # (Q11), no Lambert cosine (Q12), the hit sphere's emission not added (Q13).
        self.direct_start = 0.0 if self.classic else 1.0
        self.lambert = self.classic
        self.adds_emission = self.classic
        s = scene.spheres
        self.centers = np.array([x.center for x in s], dtype=np.float64).reshape(-1, 3)
        self.radii = np.array([x.radius for x in s])
        self.colors = np.array([x.color for x in s], dtype=np.float64).reshape(-1, 3)
        self.emission = np.array([x.emission for x in s], dtype=np.float64).reshape(-1, 3)
        self.transparency = np.array([x.transparency for x in s])
        self.reflection = np.array([x.reflection for x in s])
        self.ior = np.array([x.ior for x in s])
        self.lights = [i for i, x in enumerate(s) if any(e > 0 for e in x.emission)]

    def camera_rays(self, width: int, height: int) -> tuple[F64, F64]:
        d = camera_directions(self.scene, width, height).reshape(-1, 3)
        pos = np.array(self.scene.camera.position, dtype=np.float64)
        return np.broadcast_to(pos, d.shape).copy(), d

    def render(self, width: int, height: int) -> F64:
        o, d = self.camera_rays(width, height)
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.trace(o, d, 0).reshape(height, width, 3)

    def trace(self, o: F64, d: F64, depth: int) -> F64:
        n_rays = len(o)
        t_near = np.full(n_rays, np.inf)
        index = np.full(n_rays, -1)
        for i in range(len(self.radii)):
            ok, t = _paper_hit(self.centers[i], self.radii[i], o, d)
            better = ok & (t < t_near)
            t_near = np.where(better, t, t_near)
            index = np.where(better, i, index)
        out = np.tile(self.background(), (n_rays, 1))
        hit = index >= 0
        if not hit.any():
            return out
        idx = index[hit]
        oh, dh = o[hit], d[hit]
        p = oh + dh * t_near[hit][:, None]
        n = _normalize(p - self.centers[idx])
        inside = _dot(dh, n) > 0
        n = self.face_forward(n, inside)
        transp, refl = self.transparency[idx], self.reflection[idx]
        specular = ((transp > 0) | (refl > 0)) & (depth < self.scene.max_depth)
        colour = np.zeros_like(p)
        if specular.any():
            colour[specular] = self._specular(
                dh[specular], p[specular], n[specular], inside[specular], idx[specular], depth
            )
        diffuse = ~specular
        if diffuse.any():
            arriving = self._direct(p[diffuse], n[diffuse])
            colour[diffuse] = self.direct_start + arriving * self.colors[idx[diffuse]]
        out[hit] = (colour + self.emission[idx]) if self.adds_emission else colour
        return out

    # --- the hooks: one step of the algorithm each ----------------------------------------

    def background(self) -> F64:
        """The colour a ray that hits nothing returns."""
        return np.array(self.scene.background, dtype=np.float64)

    def offset(self) -> float:
        """How far secondary and shadow rays start off the surface, along the normal."""
        return self.scene.bias

    def face_forward(self, n: F64, inside: NDArray[np.bool_]) -> F64:
        """The shading normal: flipped to face the ray when the hit is inside the sphere."""
        return np.where(inside[:, None], -n, n)

    def eta(self, ior: F64, inside: NDArray[np.bool_]) -> F64:
        """The refraction ratio; paper mode always uses 1/ior (Q2), classic inverts it inside."""
        return np.where(inside, ior, 1 / ior) if self.classic else 1 / ior

    def fresnel(self, facing: F64) -> F64:
        """The reflection weight from the cosine between the ray and the normal."""
        return 0.1 + 0.9 * (1 - facing) ** 3

    def occluded(self, j: int, origin: F64, l_dir: F64) -> NDArray[np.bool_]:
        """Whether sphere j stands in the way of each shadow ray."""
        blocked, _ = _paper_hit(self.centers[j], self.radii[j], origin, l_dir)
        return blocked

    # --- the recursion ------------------------------------------------------------------------

    def _specular(
        self, d: F64, p: F64, n: F64, inside: NDArray[np.bool_], idx: NDArray[np.int_], depth: int
    ) -> F64:
        bias = self.offset()
        idotn = _dot(d, n)
        facing = np.maximum(0.0, -idotn)
        fresnel = self.fresnel(facing)
        r = _normalize(d - 2 * idotn[:, None] * n)
        reflection = self.trace(p + n * bias, r, depth + 1)
        refraction = np.zeros_like(p)
        transp = self.transparency[idx]
        glass = transp > 0
        if glass.any():
            ior = self.ior[idx][glass]
            eta = self.eta(ior, inside[glass])
            cosi = -idotn[glass]
            k = 1 - eta * eta * (1 - cosi * cosi)
            t = d[glass] * eta[:, None] + n[glass] * (eta * cosi - np.sqrt(k))[:, None]
            t = _normalize(t)
            refraction[glass] = self.trace(p[glass] - n[glass] * bias, t, depth + 1)
        mix = reflection * fresnel[:, None] + refraction * ((1 - fresnel) * transp)[:, None]
        return np.asarray(mix * self.colors[idx])

    def _direct(self, p: F64, n: F64) -> F64:
        """Light arriving at p, before the surface colour multiplies it."""
        colour = np.zeros_like(p)
        shadow = np.ones(len(p))  # shared by all lights (Q4) in paper mode
        origin = p + n * self.offset()
        for light in self.lights:
            l_dir = _normalize(self.centers[light][None, :] - p)
            transmission = np.ones(len(p))
            for j in range(len(self.radii)):
                if j == light:
                    continue
                blocked = self.occluded(j, origin, l_dir)
                if self.classic:
                    transmission = np.where(blocked, 0.0, transmission)
                else:
                    shadow = np.where(
                        blocked, np.maximum(0.0, shadow - (1 - self.transparency[j])), shadow
                    )
                    transmission = np.where(blocked, transmission * shadow, transmission)
            cos = np.maximum(0.0, _dot(n, l_dir)) if self.lambert else 1.0
            colour += (transmission * cos)[:, None] * self.emission[light][None, :]
        return colour
