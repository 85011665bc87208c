"""rtval_whitted: a Mitsuba integrator computing the light transport of the demo's
physical mode (to a few float32 ulps where it prunes, below), noise-free with point lights and
centre rays.

- camera and specular rays see the background (the `constant` emitter) and emitters;
- diffuse surfaces get direct light from the sphere lights only (point emitters `light_i`,
  or the spheres' area emitters sampled by area), never from the environment;
- at dielectrics both lobes are followed deterministically (BSDFContext component 0 then 1:
  weights F * tint and (1 - F) * tint * eta_ti^2), mirrors follow their one lobe;
- chains stop at max_depth (a specular hit there carries nothing); a light's sphere is
  emitter-only;
- secondary rays leave from p + n * bias (1 + |p|) (the scene's bias, 1e-4 by default, scaled
  as the demo's physical mode scales it), shadow rays end before the light, so
  float32 rounding at large coordinates cannot self-intersect (docs/mitsuba-notes.md).

Switches shadows / reflection / refraction drop one effect for per-effect ablation.
Given `prune_below` and `bounce_gain` (pruning(): a scene without lights, its glass apart),
a child ray is not traced when all the light it could bring back is under 2^-24 of the
background: half a float32 ulp of a pixel near the background's value (a pixel loses the
sum over its pruned rays: 3 such units at most in the paper scene).
Works in JIT variants (one compacted wavefront per depth, each front traced once, light summed
back up the tree in a fixed order) and scalar variants (one ray, depth-first).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import drjit as dr
import mitsuba as mi

from mitsuba_ref.cap_mesh import HUGE_RADIUS
from mitsuba_ref.whitted_wavefront import trace_wavefront
from scene_model.scene import Scene, Sphere

NAME = "rtval_whitted"
DEFAULT_BIAS = 1e-4  # the scene format's default
# The light a ray may leave out, relative to the background: half a float32 ulp at 1.0.
PRUNE_TOLERANCE = 2.0**-24


def _jit() -> bool:
    return bool(dr.is_jit_v(mi.Float))


def _not(mask: Any) -> Any:
    """Logical not for JIT masks and for the plain bools of scalar variants (~True == -2)."""
    return ~mask if _jit() else not mask


def _offset_origin(p: Any, n: Any, d: Any, bias: float) -> Any:
    """p moved off the surface by bias (1 + max|p_i|), to the side `d` leaves on."""
    scale = bias * (1.0 + dr.max(dr.abs(p)))
    side = dr.select(dr.dot(d, n) >= 0, 1.0, -1.0)
    return p + n * (scale * side)


class WhittedTransport:
    """The transport of rtval_whitted, for any variant: integrator_class makes it a
    subclass of the variant's own SamplingIntegrator."""

    def configure(self, props: Any) -> None:
        """The properties of the integrator plugin (its XML or dict)."""
        self.max_depth = int(props.get("max_depth", 5))
        self.bias = float(props.get("bias", DEFAULT_BIAS))
        self.shadows = bool(props.get("shadows", True))
        self.reflection = bool(props.get("reflection", True))
        self.refraction = bool(props.get("refraction", True))
        self.light_samples = int(props.get("light_samples", 1))
        # 0 (not given, as for a scene with lights): every ray is traced to max_depth.
        self.prune_below = float(props.get("prune_below", 0.0))
        self.bounce_gain = float(props.get("bounce_gain", 1.0))
        self._prepared_for: Any = None

    def min_weight(self, depth: int) -> float:
        """The smallest weight (largest channel) worth tracing for a ray at `depth`: each
        bounce left may multiply its light by up to bounce_gain. 0: trace every ray."""
        try:
            return self.prune_below / self.bounce_gain ** max(self.max_depth - depth, 0)
        except OverflowError:  # colours so bright that no ray is negligible
            return 0.0

    def worth_tracing(self, weight: Any, depth: int) -> Any:
        """Whether a ray of path weight `weight` at `depth` is traced (a mask in JIT
        variants): every ray but those under min_weight; a NaN weight is traced, so that the
        image shows it."""
        return _not(dr.max(weight) < self.min_weight(depth))

    # -- scene analysis -------------------------------------------------------------
    def _prepare(self, scene: Any) -> None:
        if self._prepared_for is scene:
            return
        radii: dict[str, float] = {}
        for shape in scene.shapes():
            box = shape.bbox()
            radii[shape.id()] = float(box.extents()[0]) / 2.0
        self.point_lights: list[tuple[Any, float]] = []
        self.area_lights: list[Any] = []
        for e in scene.emitters():
            eid = e.id()
            if eid.startswith("light_"):
                self.point_lights.append((e, radii.get("sphere_" + eid[len("light_") :], 0.0)))
        if not self.point_lights:
            self.area_lights = [e for e in scene.emitters() if e.get_shape() is not None]
        self.environment = scene.environment()
        self._prepared_for = scene

    # -- helpers that hide scalar vs JIT ----------------------------------------------
    def _emission(self, scene: Any, si: Any, active: Any) -> Any:
        emitter = si.emitter(scene, active)
        if _jit():
            return emitter.eval(si, active)
        return emitter.eval(si) if (active and emitter is not None) else mi.Color3f(0.0)

    def _is_light(self, scene: Any, si: Any, active: Any) -> Any:
        emitter = si.emitter(scene, active)
        if _jit():
            return active & (dr.reinterpret_array(mi.UInt32, emitter) != 0)
        return bool(active) and emitter is not None

    def _background(self, ray: Any, active: Any) -> Any:
        if self.environment is None:
            return mi.Color3f(0.0)
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = -ray.d
        return self.environment.eval(si, active)

    # -- transport ------------------------------------------------------------------
    def _blocked(
        self, scene: Any, si: Any, ds: Any, shorten: float, rel_eps: float, active: Any
    ) -> Any:
        """Is the segment from the offset hit point to ds.p blocked? It ends `shorten`
        before ds.p (the light's radius for a point at a sphere's centre), minus rel_eps."""
        o = _offset_origin(si.p, si.n, ds.d, self.bias)
        to_light = ds.p - o
        dist = dr.norm(to_light)
        shadow = mi.Ray3f(o, to_light / dist)
        shadow.maxt = (dist - shorten) * (1.0 - rel_eps)
        return scene.ray_test(shadow, active)

    def _direct(self, scene: Any, draw2d: Any, si: Any, bsdf: Any, active: Any) -> Any:
        ctx = mi.BSDFContext()
        result = mi.Color3f(0.0)
        for emitter, radius in self.point_lights:
            ds, spec = emitter.sample_direction(si, mi.Point2f(0.5, 0.5), active)
            value = bsdf.eval(ctx, si, si.to_local(ds.d), active) * spec
            if self.shadows:
                # End before the light's own sphere (the point sits at its centre).
                value = dr.select(self._blocked(scene, si, ds, radius, 1e-5, active), 0.0, value)
            result += dr.select(active, value, 0.0)
        for emitter in self.area_lights:
            acc = mi.Color3f(0.0)
            for _ in range(self.light_samples):
                ds, spec = emitter.sample_direction(si, draw2d(), active)
                value = bsdf.eval(ctx, si, si.to_local(ds.d), active) * spec
                if self.shadows:
                    value = dr.select(self._blocked(scene, si, ds, 0.0, 1e-4, active), 0.0, value)
                acc += dr.select(active & (ds.pdf > 0), value, 0.0)
            result += acc / self.light_samples
        return result

    def shade(self, scene: Any, draw2d: Any, ray: Any, depth: int, active: Any) -> Any:
        """One path vertex: the radiance it adds directly (background, emission, direct
        light) and the specular children [(mask, ray, weight)] it spawns."""
        si = scene.ray_intersect(ray, active)
        hit = active & si.is_valid()
        miss = active & _not(si.is_valid())
        if not _jit() and not hit:  # scalar: a miss has no BSDF to ask for its flags
            return self._background(ray, miss) if miss else mi.Color3f(0.0), []
        light = self._is_light(scene, si, hit)
        surface = hit & _not(light)
        bsdf = si.bsdf(ray)
        flags = bsdf.flags()
        diffuse = surface & mi.has_flag(flags, mi.BSDFFlags.DiffuseReflection)
        specular = surface & mi.has_flag(flags, mi.BSDFFlags.Delta)
        lobes = []
        if self.reflection:
            lobes.append((0, specular & mi.has_flag(flags, mi.BSDFFlags.DeltaReflection)))
        if self.refraction:
            lobes.append((1, specular & mi.has_flag(flags, mi.BSDFFlags.DeltaTransmission)))
        if _jit():
            # Store the intersection and every mask in one kernel. Left lazy, each
            # dr.any below and each later kernel would trace these rays again.
            dr.eval(si, bsdf, hit, miss, light, diffuse, specular, [m for _, m in lobes])
        result = dr.select(miss, self._background(ray, miss), 0.0)
        children: list[tuple[Any, Any, Any]] = []
        if not dr.any(hit):
            return result, children
        result += dr.select(light, self._emission(scene, si, light), 0.0)
        if dr.any(diffuse):
            result += dr.select(diffuse, self._direct(scene, draw2d, si, bsdf, diffuse), 0.0)
        if depth >= self.max_depth or not dr.any(specular):
            return result, children  # a specular chain cut at max_depth carries nothing
        for component, mask in lobes:
            if not dr.any(mask):
                continue
            ctx = mi.BSDFContext()
            ctx.component = component
            bs, w = bsdf.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5), mask)
            mask = mask & dr.any(w != 0.0)
            wo = si.to_world(bs.wo)
            children.append((mask, mi.Ray3f(_offset_origin(si.p, si.n, wo, self.bias), wo), w))
        return result, children

    def _trace_recursive(
        self, scene: Any, sampler: Any, ray: Any, depth: int, active: Any, weight: Any = 1.0
    ) -> Any:
        """Scalar variants: one ray (of path weight `weight`), depth-first."""
        result, children = self.shade(scene, sampler.next_2d, ray, depth, active)
        for mask, child, w in children:
            if mask and self.worth_tracing(weight * w, depth + 1):
                light = self._trace_recursive(scene, sampler, child, depth + 1, mask, weight * w)
                result += w * light
        return result

    def sample(
        self, scene: Any, sampler: Any, ray: Any, medium: Any = None, active: Any = True
    ) -> tuple[Any, Any, list[Any]]:
        self._prepare(scene)
        ray = mi.Ray3f(ray)
        if _jit():
            L = trace_wavefront(self, scene, sampler, ray, active)
        else:
            L = self._trace_recursive(scene, sampler, ray, 0, mi.Bool(active))
        return L, mi.Bool(active), []

    def to_string(self) -> str:
        return f"WhittedIntegrator[max_depth={self.max_depth}]"


def pruning(scene: Scene) -> dict[str, float]:
    """The integrator's pruning properties for a scene lit by its background alone whose glass
    spheres stand apart, where the light along any ray is bounded: at most the background's
    brightest channel, times ior^2 inside glass (radiance scales with eta^2 across a boundary
    crossed in and out), times the brightest specular colour above 1 per bounce left. Each
    pruned ray then leaves out under PRUNE_TOLERANCE of the background; a pixel, the sum over
    its pruned rays. With lights (I/d^2 near one) or glass that a ray could leave without
    having entered, there is no such bound: none (every ray is traced)."""
    glass = [s for s in scene.spheres if s.kind == "glass"]
    if (
        scene.lights
        or max(scene.background) <= 0.0
        or not all(_stands_apart(g, scene) for g in glass)
    ):
        return {}
    specular = [s for s in scene.spheres if s.kind in ("glass", "mirror")]
    gain = max([1.0, *(c for s in specular for c in s.color)])
    deepest = max((g.ior**2 for g in glass), default=1.0)
    return {"prune_below": PRUNE_TOLERANCE / deepest, "bounce_gain": gain}


def _stands_apart(g: Sphere, scene: Scene) -> bool:
    """Whether every ray crosses glass sphere g's boundary in and out: g is a sphere (not a
    cap mesh), larger than the offset rays leave surfaces by, and no other sphere's surface
    comes within that offset of g's, nor holds it or lies in it (a ray would start inside g,
    or be inside two spheres' glass at once)."""
    if g.radius >= HUGE_RADIUS:
        return False
    for other in scene.spheres:
        if other is g:
            continue
        small = g if g.radius <= other.radius else other
        reach = 2.0 * scene.bias * (1.0 + max(abs(c) for c in small.center) + small.radius)
        d = math.dist(g.center, other.center)
        if g.radius <= reach or d - g.radius - other.radius <= reach:  # nested: negative
            return False
    return True


_NOT_COPIED = ("__dict__", "__weakref__")


@functools.cache
def integrator_class(variant: str) -> type:
    """The integrator class for one Mitsuba variant (each variant has its own base class).
    Precondition: `variant` is the active one (mitsuba_ref.drjit_env.load_mitsuba)."""
    assert mi.variant() == variant, (mi.variant(), variant)

    def __init__(self: Any, props: Any) -> None:
        mi.SamplingIntegrator.__init__(self, props)
        self.configure(props)

    # nanobind classes take one base: the transport's methods are copied into the class.
    members = {k: v for k, v in vars(WhittedTransport).items() if k not in _NOT_COPIED}
    return type("WhittedIntegrator", (mi.SamplingIntegrator,), {**members, "__init__": __init__})


def register() -> None:
    """Makes `rtval_whitted` loadable by name (dicts and XML) in the current variant."""
    cls = integrator_class(mi.variant())
    mi.register_integrator(NAME, lambda props: cls(props))
