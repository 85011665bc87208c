"""rtval_whitted's wavefront (JIT variants): the same image from run to run, and each front
traced once rather than once per mask test (issue 18; bench/NOTES.md has the numbers)."""

from __future__ import annotations

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
