"""A student's program, foreign to rtval: the classic (scratchapixel) Whitted tracer in
float32 numpy, writing a binary PPM the way that program family does,
`(unsigned char)(min(1, x) * 255)` (truncation). Written from docs/paper-model.md's classic
mode, like tests/numpy_reference.py but in float32 as a C++ student's program computes.

    python tests/student_programs/classic_numpy.py SCENE.json OUT.ppm [--size WxH]

Variants (student mistakes) subclass ClassicTracer and override one method.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

F = np.float32
A = NDArray[np.float32]


def _norm(v: A) -> A:
    return (v / np.sqrt((v * v).sum(-1, keepdims=True))).astype(F)


def _dot(a: A, b: A) -> A:
    return (a * b).sum(-1).astype(F)


class ClassicTracer:
    def __init__(self, scene: object) -> None:
        s = scene.spheres  # type: ignore[attr-defined]
        self.scene = scene
        self.center = np.array([x.center for x in s], F).reshape(-1, 3)
        self.radius2 = np.array([x.radius * x.radius for x in s], F)
        self.color = np.array([x.color for x in s], F).reshape(-1, 3)
        self.emission = np.array([x.emission for x in s], F).reshape(-1, 3)
        self.transparency = np.array([x.transparency for x in s], F)
        self.reflection = np.array([x.reflection for x in s], F)
        self.ior = np.array([x.ior for x in s], F)
        self.lights = [i for i, x in enumerate(s) if any(e > 0 for e in x.emission)]
        self.background = np.array(scene.background, F)  # type: ignore[attr-defined]
        self.bias = F(scene.bias)  # type: ignore[attr-defined]
        self.max_depth = int(scene.max_depth)  # type: ignore[attr-defined]

    # -- the camera ---------------------------------------------------------------------------
    def primary(self, w: int, h: int) -> tuple[A, A]:
        cam = self.scene.camera  # type: ignore[attr-defined]
        pos = np.array(cam.position, F)
        fwd = _norm(np.array(cam.look_at, F) - pos)
        right = _norm(np.cross(fwd, np.array(cam.up, F)).astype(F))
        up = np.cross(right, fwd).astype(F)
        a = F(np.tan(np.radians(cam.fov_y) / 2))
        ys, xs = np.mgrid[0:h, 0:w].astype(F)
        xx = (F(2) * (xs + F(0.5)) / F(w) - F(1)) * a * F(w) / F(h)
        yy = (F(1) - F(2) * (ys + F(0.5)) / F(h)) * a
        d = xx[..., None] * right + yy[..., None] * up + fwd
        d = _norm(d.reshape(-1, 3).astype(F))
        return np.broadcast_to(pos, d.shape).copy(), d

    # -- intersection: the geometric test with the tca < 0 early-out --------------------------
    def hit(self, i: int, o: A, d: A) -> tuple[NDArray[np.bool_], A]:
        L = self.center[i] - o
        tca = _dot(L, d)
        d2 = _dot(L, L) - tca * tca
        ok = ~(tca < 0) & ~(d2 > self.radius2[i])
        thc = np.sqrt(np.where(ok, self.radius2[i] - d2, F(0))).astype(F)
        t0, t1 = tca - thc, tca + thc
        return ok, np.where(t0 < 0, t1, t0).astype(F)

    def trace(self, o: A, d: A, depth: int) -> A:
        n_rays = len(o)
        t_near = np.full(n_rays, np.inf, F)
        index = np.full(n_rays, -1)
        for i in range(len(self.radius2)):
            ok, t = self.hit(i, o, d)
            better = ok & (t < t_near)
            t_near = np.where(better, t, t_near)
            index = np.where(better, i, index)
        out = np.tile(self.background, (n_rays, 1))
        hit = index >= 0
        if not hit.any():
            return out
        idx, dh = index[hit], d[hit]
        p = (o[hit] + dh * t_near[hit][:, None]).astype(F)
        n = _norm(p - self.center[idx])
        inside = _dot(dh, n) > 0
        n = np.where(inside[:, None], -n, n).astype(F)
        specular = ((self.transparency[idx] > 0) | (self.reflection[idx] > 0)) & (
            depth < self.max_depth
        )
        colour = np.zeros_like(p)
        if specular.any():
            s = specular
            colour[s] = self.specular(dh[s], p[s], n[s], inside[s], idx[s], depth)
        if (~specular).any():
            s = ~specular
            colour[s] = self.direct(p[s], n[s]) * self.color[idx[s]]
        out[hit] = colour + self.emission[idx]
        return out

    def fresnel(self, facing: A) -> A:
        return (F(0.1) + F(0.9) * (F(1) - facing) ** 3).astype(F)

    def eta(self, ior: A, inside: NDArray[np.bool_]) -> A:
        return np.where(inside, ior, F(1) / ior).astype(F)

    def specular(
        self, d: A, p: A, n: A, inside: NDArray[np.bool_], idx: NDArray[np.int_], depth: int
    ) -> A:
        idotn = _dot(d, n)
        fresnel = self.fresnel(np.maximum(F(0), -idotn))
        r = _norm(d - F(2) * idotn[:, None] * n)
        reflection = self.trace((p + n * self.bias).astype(F), r, depth + 1)
        refraction = np.zeros_like(p)
        glass = self.transparency[idx] > 0
        if glass.any():
            eta = self.eta(self.ior[idx][glass], inside[glass])
            cosi = -idotn[glass]
            k = F(1) - eta * eta * (F(1) - cosi * cosi)
            t = d[glass] * eta[:, None] + n[glass] * (eta * cosi - np.sqrt(k))[:, None]
            refraction[glass] = self.trace(
                (p[glass] - n[glass] * self.bias).astype(F), _norm(t), depth + 1
            )
        mix = (
            reflection * fresnel[:, None]
            + refraction * ((F(1) - fresnel) * self.transparency[idx])[:, None]
        )
        return (mix * self.color[idx]).astype(F)

    def direct(self, p: A, n: A) -> A:
        colour = np.zeros_like(p)
        origin = (p + n * self.bias).astype(F)
        for light in self.lights:
            l_dir = _norm(self.center[light] - p)
            transmission = np.ones(len(p), F)
            for j in range(len(self.radius2)):
                if j != light:
                    blocked, _ = self.hit(j, origin, l_dir)
                    transmission = np.where(blocked, F(0), transmission)
            cos = np.maximum(F(0), _dot(n, l_dir))
            colour += (transmission * cos)[:, None] * self.emission[light]
        return colour.astype(F)

    def render(self, w: int, h: int) -> A:
        o, d = self.primary(w, h)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return self.trace(o, d, 0).reshape(h, w, 3)


def write_ppm(path: Path, rgb: A) -> None:
    """(unsigned char)(min(1, x) * 255): truncation, as the program family writes it."""
    x = np.minimum(F(1), np.nan_to_num(rgb, nan=0.0)) * F(255)
    data = np.clip(x, 0, 255).astype(np.uint8)  # the cast truncates towards zero
    h, w = data.shape[:2]
    path.write_bytes(f"P6\n{w} {h}\n255\n".encode() + data.tobytes())


def main(argv: list[str] | None = None, tracer: type[ClassicTracer] = ClassicTracer) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--size", default=None, help="WxH (default: the scene's)")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from scene_model.scene import load_scene

    scene = load_scene(args.scene)
    w, h = scene.camera.width, scene.camera.height
    if args.size:
        w, h = (int(v) for v in args.size.lower().split("x"))
    write_ppm(Path(args.out), tracer(scene).render(w, h))
    return 0


if __name__ == "__main__":
    sys.exit(main())
