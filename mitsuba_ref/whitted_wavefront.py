"""rtval_whitted's wavefront for JIT variants: per depth one compacted front holding every
live ray of every lobe, each front traced once. Each ray's weighted light is kept per front;
after the last depth the fronts are summed back up the tree (a ray's own light, then its lobe
0 child's total, then its lobe 1 child's) by gathers in a fixed order, so the image is the
same from run to run (atomic adds from several threads are not)."""

from __future__ import annotations

import functools
from typing import Any

import drjit as dr
import mitsuba as mi

# Per lobe: (the lobe's mask over the front, each ray's child's position in the next front).
Links = list[tuple[Any, Any]]
# One depth: the front's own weighted light and its links to the next front.
Front = tuple[Any, Links]


def _concat(parts: list[Any]) -> Any:
    """Arrays of one drjit type laid end to end. The offsets are opaque so that the scatter
    kernels do not bake them in as literals (a new kernel to compile for every width)."""
    if len(parts) == 1:
        return parts[0]
    total = sum(dr.width(p) for p in parts)
    out = dr.zeros(type(parts[0]), total)
    offset = 0
    for p in parts:
        w = dr.width(p)
        dr.scatter(out, p, dr.arange(mi.UInt32, w) + dr.opaque(mi.UInt32, offset))
        offset += w
    return out


def _draw_for_front(sampler: Any, idx: Any) -> Any:
    """The sampler's next 2D sample of each front ray's camera ray. The sampler draws for the
    whole wavefront (the same stream whatever the front), evaluated in one kernel before the
    gather (which would otherwise evaluate x and y in a kernel each)."""
    sample = sampler.next_2d()
    dr.eval(sample)
    return dr.gather(mi.Point2f, sample, idx)


def trace_wavefront(integrator: Any, scene: Any, sampler: Any, ray: Any, active: Any) -> Any:
    """The light along each camera ray of `ray` (active ones; the others get zero).
    `integrator` is a WhittedTransport: its shade() gives each front's light and children."""
    n = dr.width(ray.o)
    root: Any = dr.compress(mi.Bool(active) | dr.zeros(mi.Bool, n))
    fronts = _trace_fronts(integrator, scene, sampler, ray, root)
    result = dr.zeros(mi.Color3f, n)
    if not fronts:
        return result
    dr.scatter(result, _sum_up(fronts), root)  # one root per camera ray: no two writes collide
    return result


def _trace_fronts(integrator: Any, scene: Any, sampler: Any, ray: Any, root: Any) -> list[Front]:
    idx = root
    origins = dr.gather(mi.Point3f, ray.o, idx)
    dirs = dr.gather(mi.Vector3f, ray.d, idx)
    weight = dr.full(mi.Color3f, 1.0, dr.width(idx))
    fronts: list[Front] = []
    for depth in range(integrator.max_depth + 1):
        width = dr.width(idx)
        if width == 0:
            break
        draw2d = functools.partial(_draw_for_front, sampler, idx)
        contrib, children = integrator.shade(
            scene, draw2d, mi.Ray3f(origins, dirs), depth, dr.full(mi.Bool, True, width)
        )
        own = weight * contrib
        if not children:
            dr.eval(own)
            fronts.append((own, []))
            break
        weights = [weight * w for _, _, w in children]
        if integrator.min_weight(depth + 1) > 0.0:  # rays below float32's resolution: dropped
            children = [
                (mask & integrator.worth_tracing(wc, depth + 1), c, w)
                for (mask, c, w), wc in zip(children, weights, strict=True)
            ]
        # One kernel shades the front (direct light, shadow rays) and stores its light and
        # every child ray.
        dr.eval(
            own,
            [mask for mask, _, _ in children],
            [c.o for _, c, _ in children],
            [c.d for _, c, _ in children],
            weights,
        )
        keep, links, wide = _link(children, width)
        fronts.append((own, links))
        if dr.width(keep) == 0:
            break
        origins, dirs, weight, idx = _next_front(children, weights, keep, wide, idx)
    return fronts


def _link(children: list[tuple[Any, Any, Any]], width: int) -> tuple[Any, Links, Any]:
    """Compacts all lobes at once: lobe k's rays sit at [k * width, (k+1) * width) of the
    concatenated mask, so the order is lobe 0's rays, then lobe 1's. Returns the kept
    positions, the links, and the width as an opaque value."""
    masks = [mask for mask, _, _ in children]
    keep: Any = dr.compress(_concat(masks))
    kept = dr.width(keep)
    position = dr.zeros(mi.UInt32, len(children) * width)
    if kept > 0:
        dr.scatter(position, dr.arange(mi.UInt32, kept), keep)
    wide = dr.opaque(mi.UInt32, width)
    links = [
        (mask, dr.gather(mi.UInt32, position, dr.arange(mi.UInt32, width) + wide * k))
        for k, mask in enumerate(masks)
    ]
    dr.eval(links)
    return keep, links, wide


def _next_front(
    children: list[tuple[Any, Any, Any]], weights: list[Any], keep: Any, wide: Any, idx: Any
) -> tuple[Any, Any, Any, Any]:
    """The next front's origins, directions, weights and camera-ray indices."""
    lobe = keep // wide
    j = keep - lobe * wide
    o_parts = [dr.gather(mi.Point3f, c.o, j) for _, c, _ in children]
    d_parts = [dr.gather(mi.Vector3f, c.d, j) for _, c, _ in children]
    w_parts = [dr.gather(mi.Color3f, w, j) for w in weights]
    origins, dirs, weight = o_parts[0], d_parts[0], w_parts[0]
    for k in range(1, len(children)):
        at_k = lobe == k
        origins = dr.select(at_k, o_parts[k], origins)
        dirs = dr.select(at_k, d_parts[k], dirs)
        weight = dr.select(at_k, w_parts[k], weight)
    idx = dr.gather(mi.UInt32, idx, j)
    dr.eval(origins, dirs, weight, idx)
    return origins, dirs, weight, idx


def _sum_up(fronts: list[Front]) -> Any:
    """Each camera ray's total: the fronts summed from the deepest up, in a fixed order."""
    below: Any = None  # totals of the front one depth deeper
    for own, links in reversed(fronts):
        total = own
        if below is not None:
            for mask, at in links:
                total = total + dr.gather(mi.Color3f, below, at, mask)
        dr.eval(total)
        below = total
    return below
