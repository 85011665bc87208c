"""Physical mode converges to the Mitsuba Whitted reference; quirk fixes move the error the
way docs/paper-model.md predicts. Reduced sizes here; bench/bench_physical.py runs the full study
at 640x480 (numbers in bench/results/physical.json)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo

from compare.judge.effects import effect_masks
from compare.judge.metrics import compute_maps, compute_metrics
from mitsuba_ref.reference import ReferenceSettings, render_reference
from scene_model.scene import load_scene

pytestmark = pytest.mark.slow
SIZE = (320, 240)
# paper: the paper's own scene, lit by its background alone; lit and classic: a sphere light.
SCENE_NAMES = ("paper", "lit", "classic")


def _demo(rtdemo: str, scene: str, tmp: Path, *args: str) -> np.ndarray:
    out = tmp / f"{scene}-{'_'.join(args)}.exr"
    return render_demo(rtdemo, SCENES / f"{scene}.json", out, *args, size=SIZE).rgb


@pytest.mark.parametrize("scene", SCENE_NAMES)
@pytest.mark.parametrize("backend", ["cpu", "gl"])
def test_physical_matches_whitted_reference_with_centre_rays(
    scene: str, backend: str, rtdemo: str, tmp_path: Path
) -> None:
    s = load_scene(SCENES / f"{scene}.json")
    ref = render_reference(
        s, ReferenceSettings(integrator="whitted", light="point", centre_rays=True, size=SIZE)
    )
    demo = _demo(rtdemo, scene, tmp_path, "--mode", "physical", "--backend", backend)
    maps = compute_maps(ref.rgb, demo, hdr=False)
    assert compute_metrics(ref.rgb, demo, maps).ssim >= 0.995
    masks = effect_masks(s, ref.aovs["id"], ref.aovs["depth"])
    rel = (
        (ref.rgb.astype(np.float64) - demo) ** 2 / (ref.rgb.astype(np.float64) ** 2 + 0.01)
    ).mean(-1)
    assert rel.mean() <= 1e-3
    # Issue 7's criterion in every effect mask, no pixel left out. Measured at 320x240
    # (2026-11-22): worst mask relMSE 2.3e-5 (lit, edges), SSIM >= 0.9998; before the cap
    # mesh's ring chords followed the sagitta rule and the robust test ran in double, a few
    # shadow-edge and horizon pixels flipped and carried a relMSE of 0.25.
    for name, mask in masks.items():
        if not mask.any():
            continue
        assert rel[mask].mean() <= 1e-3, (name, rel[mask].mean())
        assert compute_metrics(ref.rgb, demo, maps, mask=mask).ssim >= 0.995, name


@pytest.fixture(scope="module")
def converged() -> dict[str, object]:
    out = {}
    for scene in SCENE_NAMES:
        s = load_scene(SCENES / f"{scene}.json")
        ref = render_reference(
            s, ReferenceSettings(integrator="whitted", light="point", spp=16, size=SIZE)
        )
        out[scene] = (ref, effect_masks(s, ref.aovs["id"], ref.aovs["depth"]))
    return out


def _flip(ref: np.ndarray, img: np.ndarray, mask: np.ndarray) -> float:
    return compute_metrics(ref, img, compute_maps(ref, img, hdr=False), mask=mask).flip_ldr


# Q11 (the lit colour starts at 1) and Q12 (no Lambert cosine) swamp every other error on
# lit surfaces, also those seen through glass: quirks there are measured with those two
# fixed first. Measured at 320x240 (2026-12-02), FLIP with Q11, Q12 fixed, then the quirk as
# well: direct, Q7: lit 0.241 -> 0.055, classic 0.560 -> 0.059; classic shadow, Q9: 0.823 ->
# 0.067; classic refraction, Q2: 0.578 -> 0.371. With Q11 present, fixing Q7 alone moves
# nothing (lit 0.713 -> 0.713), fixing Q2 alone makes refraction worse (0.456 -> 0.468).
DIRECT_FIRST = "Q11,Q12"


@pytest.mark.parametrize(
    "scene,base,quirk,effect",
    [
        ("lit", DIRECT_FIRST, "Q7", "direct"),
        ("classic", DIRECT_FIRST, "Q7", "direct"),  # falloff and 1/pi calibrated
        ("paper", "", "Q8", "reflection"),  # the sky in the mirror floor, without a light
        ("lit", "", "Q8", "reflection"),
        ("classic", "", "Q8", "reflection"),  # exact Fresnel, exact mirrors
        ("classic", DIRECT_FIRST, "Q9", "shadow"),  # glass blocks shadow rays
        ("classic", DIRECT_FIRST, "Q2", "refraction"),  # correct eta leaving glass
    ],
)
def test_quirk_fix_reduces_the_error_it_should(
    scene: str,
    base: str,
    quirk: str,
    effect: str,
    converged: dict,  # type: ignore[type-arg]
    rtdemo: str,
    tmp_path: Path,
) -> None:
    ref, masks = converged[scene]
    first = ["--fix", base] if base else []
    paper = _demo(rtdemo, scene, tmp_path, "--mode", "paper", *first)
    both = f"{base},{quirk}" if base else quirk
    fixed = _demo(rtdemo, scene, tmp_path, "--mode", "paper", "--fix", both)
    before, after = _flip(ref.rgb, paper, masks[effect]), _flip(ref.rgb, fixed, masks[effect])
    assert after < 0.8 * before, (before, after)


@pytest.mark.parametrize(
    "quirk,scenes",
    [
        # Q3 needs Q2 fixed (eta < 1 never reflects totally), Q4 two lights, Q5 an occluder
        # beyond the light: the built-in scenes have none.
        ("Q3", SCENE_NAMES),
        ("Q4", SCENE_NAMES),
        ("Q5", SCENE_NAMES),
        # Without a light, nothing casts a shadow, nothing is lit and nothing glows.
        ("Q9", ("paper",)),
        ("Q12", ("paper",)),
        ("Q13", ("paper",)),
    ],
)
def test_quirks_without_a_trigger_in_the_scene_change_nothing(
    quirk: str, scenes: tuple[str, ...], rtdemo: str, tmp_path: Path
) -> None:
    """The image is bit-identical with the quirk fixed."""
    for scene in scenes:
        a = _demo(rtdemo, scene, tmp_path, "--mode", "paper")
        b = _demo(rtdemo, scene, tmp_path, "--mode", "paper", "--fix", quirk)
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("scene", ["paper", "classic"])
def test_physical_with_spp_converges_to_the_box_filtered_reference(
    scene: str,
    converged: dict,  # type: ignore[type-arg]
    rtdemo: str,
    tmp_path: Path,
) -> None:
    ref, _masks = converged[scene]
    errors = [
        _flip(
            ref.rgb,
            _demo(rtdemo, scene, tmp_path, "--mode", "physical", "--spp", str(n)),
            np.ones(ref.rgb.shape[:2], bool),
        )
        for n in (1, 4, 16)
    ]
    assert errors[0] > errors[1] > errors[2], errors
