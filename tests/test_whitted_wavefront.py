"""rtval_whitted's wavefront (JIT variants): the same image from run to run, and each front
traced once rather than once per mask test (issue 18; bench/NOTES.md has the numbers)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from helpers import SCENES

from mitsuba_ref.reference import ReferenceSettings, render_reference
from scene_model.scene import load_scene

pytestmark = pytest.mark.slow


def test_whitted_llvm_is_bit_identical_from_run_to_run() -> None:
    # Summing each front's light into its camera ray by atomic adds from 2 threads changed
    # 5 078 of 921 600 values between two such renders (max 7.6e-6); the sum up the tree
    # of fronts is in a fixed order.
    scene = load_scene(SCENES / "lit.json")
    settings = ReferenceSettings(integrator="whitted", light="point", centre_rays=True)
    first = render_reference(scene, settings).rgb
    second = render_reference(scene, settings).rgb
    assert np.array_equal(first, second), int((first != second).sum())


def test_whitted_llvm_traces_each_front_once() -> None:
    import drjit as dr

    scene = load_scene(SCENES / "lit.json")
    settings = ReferenceSettings(integrator="whitted", spp=1, size=(64, 48))
    render_reference(scene, settings)  # loads Mitsuba; its kernels are not counted
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        dr.kernel_history()
        render_reference(scene, settings)
        kernels = sum(1 for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT)
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    # Measured 51 for the lit scene (max depth 5: 6 fronts; per front trace + classify,
    # shade, the sampler's draw, the next front's gather, the links and one gather back up),
    # 187 (at 640x480) when every mask test and gather traced the front again.
    assert kernels <= 10 * (scene.max_depth + 1), kernels


def test_pruning_only_where_the_light_along_a_ray_is_bounded() -> None:
    from mitsuba_ref.whitted import PRUNE_TOLERANCE, pruning

    # Lights make a ray's light unbounded (I / d^2 near a light): every ray is traced.
    assert pruning(load_scene(SCENES / "lit.json")) == {}
    assert pruning(load_scene(SCENES / "classic.json")) == {}
    paper = load_scene(SCENES / "paper.json")  # white sky, glass of ior 1.2, colours <= 1
    assert pruning(paper) == {"prune_below": PRUNE_TOLERANCE / 1.2**2, "bounce_gain": 1.0}
    # Overlapping glass: a ray may be inside both, so both ior^2 count; a bright colour
    # may amplify each bounce.
    red, blue = paper.spheres[1], paper.spheres[2]
    overlapping = dataclasses.replace(
        paper,
        spheres=(
            dataclasses.replace(red, center=blue.center, color=(2.0, 0.1, 0.1)),
            blue,
        ),
    )
    bounds = pruning(overlapping)
    assert bounds["prune_below"] == pytest.approx(PRUNE_TOLERANCE / (1.2**2 * 1.2**2))
    assert bounds["bounce_gain"] == 2.0


def test_pruned_rays_change_no_pixel_by_more_than_float_resolution(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The paper scene (sky-lit, depth 10): light inside the glass spheres splits at every
    # bounce, and most of the deep rays carry under 2^-24 of the sky. Measured at 1200x800,
    # 32 spp: 5.1 M rays per sample -> fewer than half past depth 5, max change 1.2e-7.
    from mitsuba_ref import whitted, whitted_wavefront

    scene = load_scene(SCENES / "paper.json")
    settings = ReferenceSettings(integrator="whitted", light="point", centre_rays=True,
                                 size=(300, 200))  # fmt: skip
    widths: list[int] = []
    link = whitted_wavefront._link

    def counted(children: Any, width: int) -> Any:
        widths.append(width)
        return link(children, width)

    monkeypatch.setattr(whitted_wavefront, "_link", counted)
    pruned = render_reference(scene, settings).rgb
    pruned_rays, widths[:] = sum(widths), []
    monkeypatch.setattr(whitted, "pruning", lambda scene: {})
    full = render_reference(scene, settings).rgb
    assert pruned_rays < 0.8 * sum(widths), (pruned_rays, sum(widths))
    assert float(np.abs(pruned - full).max()) <= 4 * whitted.PRUNE_TOLERANCE
