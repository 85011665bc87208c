"""rtval_whitted's wavefront (JIT variants): the same image from run to run, and each front
traced once rather than once per mask test (bench/NOTES.md has the numbers)."""

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
    from mitsuba_ref.whitted import pruning

    # Lights make a ray's light unbounded (I / d^2 near a light): every ray is traced.
    assert pruning(load_scene(SCENES / "lit.json")) == {}
    assert pruning(load_scene(SCENES / "classic.json")) == {}
    paper = load_scene(SCENES / "paper.json")  # white sky, glass of ior 1.2, colours <= 1
    assert pruning(paper) == {"prune_below": 2.0**-24 / 1.44, "bounce_gain": 1.0}
    red, blue = paper.spheres[1], paper.spheres[2]

    def moved(center: tuple[float, float, float], color: Any = red.color) -> dict[str, float]:
        other = dataclasses.replace(red, center=center, color=color)
        return pruning(dataclasses.replace(paper, spheres=(other, blue)))

    # A bright specular colour may amplify every bounce left.
    assert moved(red.center, (2.0, 0.1, 0.1))["bounce_gain"] == 2.0
    # A ray may leave glass it never entered where glass touches, crosses or holds another
    # sphere (it starts inside the next one): no bound, no pruning.
    x, y, z = blue.center
    touching = (x - blue.radius - red.radius, y, z)
    assert moved(touching) == {}
    assert moved((x - 3.0, y, z)) == {}  # crossing
    assert moved(blue.center) == {}  # nested
    assert moved((x - 3.6, y, z)) != {}  # apart by 0.1
    huge = dataclasses.replace(red, radius=200.0, center=(0.0, 0.0, -400.0))
    assert pruning(dataclasses.replace(paper, spheres=(huge,))) == {}  # a cap mesh, not closed


def _rays_and_image(scene: Any, settings: Any, monkeypatch: pytest.MonkeyPatch) -> Any:
    """The wavefront's rays (every front's width) and the image of one render."""
    from mitsuba_ref import whitted_wavefront

    widths: list[int] = []
    link = whitted_wavefront._link

    def counted(children: Any, width: int) -> Any:
        widths.append(width)
        return link(children, width)

    monkeypatch.setattr(whitted_wavefront, "_link", counted)
    image = render_reference(scene, settings).rgb
    monkeypatch.setattr(whitted_wavefront, "_link", link)
    return sum(widths), image


@pytest.mark.parametrize(
    ("floor", "variant", "size"),
    [
        (1.0, "llvm_ad_rgb", (300, 200)),
        (1.5, "llvm_ad_rgb", (150, 100)),
        (1.0, "scalar_rgb", (45, 30)),
    ],
)
def test_pruned_rays_change_no_pixel_by_more_than_a_few_ulps(
    monkeypatch: pytest.MonkeyPatch, floor: float, variant: str, size: tuple[int, int]
) -> None:
    # The paper scene (sky-lit, depth 10): light inside the glass spheres splits at every
    # bounce, and most of the deep rays carry under 2^-24 of the sky. Measured at 1200x800,
    # 32 spp: 5.1 M rays per sample -> fewer than half past depth 5, max change 1.2e-7 (2
    # units of 2^-24); 2 at 300x200 (2026-12-04); 2 with the floor a 1.5 mirror (bounce_gain
    # 1.5), where min_weight multiplying by the gain instead of dividing gives 32.
    from mitsuba_ref import whitted

    paper = load_scene(SCENES / "paper.json")
    floor_sphere = dataclasses.replace(paper.spheres[0], color=(floor, floor, floor))
    scene = dataclasses.replace(paper, spheres=(floor_sphere, *paper.spheres[1:]))
    settings = ReferenceSettings(integrator="whitted", light="point", centre_rays=True,
                                 size=size, variant=variant)  # fmt: skip
    pruned_rays, pruned = _rays_and_image(scene, settings, monkeypatch)
    monkeypatch.setattr(whitted, "pruning", lambda scene: {})
    full_rays, full = _rays_and_image(scene, settings, monkeypatch)
    units = float(np.abs(pruned - full).max()) / 2.0**-24  # the sky is 1
    assert units <= 4, units
    if variant == "llvm_ad_rgb":
        assert pruned_rays < 0.8 * full_rays, (pruned_rays, full_rays)
    else:  # scalar: one ray at a time, no fronts to count; the image shows the pruning
        assert units > 0


def test_min_weight_with_colours_too_bright_to_bound_prunes_nothing() -> None:
    from mitsuba_ref.whitted import WhittedTransport

    t = WhittedTransport()
    t.configure({"max_depth": 64, "prune_below": 1e-8, "bounce_gain": 1e200})
    assert t.min_weight(0) == 0.0  # 1e200 ** 64 overflows: every ray is traced
    assert t.min_weight(64) == 1e-8
