"""Stress scenes: physical mode and the references stay finite everywhere; the atlas flags
failures instead of crashing. Small sizes here; `rtval stress` runs 160x120."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo, run

from compare.judge.effects import EFFECTS
from mitsuba_ref.reference import ReferenceSettings, render_reference
from scene_model.scene import load_scene

pytestmark = pytest.mark.slow
STRESS = sorted((SCENES / "stress").glob("*.json"))


def test_there_is_a_scene_for_every_listed_failure() -> None:
    names = {p.stem for p in STRESS}
    assert {
        "tir_grazing",
        "camera_inside_glass",
        "intersecting_spheres",
        "nested_spheres",
        "huge_floor_tiny_sphere",
        "far_objects",
        "facing_mirrors",
        "light_inside_glass",
        "coloured_lights",
        "grazing_floor",
        "no_light",
        "thousand_spheres",
    } <= names
    assert len(load_scene(SCENES / "stress" / "thousand_spheres.json").spheres) == 1000


@pytest.mark.parametrize("scene", STRESS, ids=[p.stem for p in STRESS])
def test_physical_and_references_are_finite(scene: Path, rtdemo: str, tmp_path: Path) -> None:
    for backend in ("cpu", "gl"):
        out = tmp_path / f"{backend}.exr"
        image = render_demo(
            rtdemo, scene, out, "--mode", "physical", "--backend", backend, size=(48, 36)
        )
        assert np.isfinite(image.rgb).all()
    s = load_scene(scene)
    for integrator in ("whitted", "path"):
        r = render_reference(
            s,
            ReferenceSettings(
                integrator=integrator, light="point", centre_rays=True, spp=2, size=(48, 36)
            ),
        )
        assert np.isfinite(r.rgb).all(), integrator


def test_stress_command_writes_an_atlas(tmp_path: Path) -> None:
    rtval = str(Path(sys.executable).with_name("rtval"))
    picks = [
        str(SCENES / "stress" / f"{n}.json") for n in ("camera_inside_glass", "coloured_lights")
    ]
    picks.append(str(SCENES / "paper.json"))  # the paper's own scene: no light either
    proc = run([rtval, "stress", *picks, "--out", str(tmp_path), "--size", "48x36"])
    assert proc.returncode == 0, proc.stderr

    def refuse(name: str) -> None:
        raise AssertionError(f"stress.json holds {name}")

    data = json.loads((tmp_path / "stress.json").read_text(), parse_constant=refuse)
    names = ["camera_inside_glass", "coloured_lights", "paper"]
    assert [s["scene"] for s in data["scenes"]] == names
    methods = {m["method"] for m in data["scenes"][0]["methods"]}
    assert {
        "demo paper cpu",
        "demo classic gl",
        "demo physical cpu",
        "mitsuba whitted",
        "mitsuba path",
    } <= methods
    for m in data["scenes"][0]["methods"]:
        assert {"bias x10", "bias /10", "camera +1e-4"} <= set(m["stability"])
        assert (tmp_path / m["thumbnail"]).is_file()
    # Q4 shows in coloured_lights: paper mode darkens the later lights.
    coloured = {m["method"]: m for m in data["scenes"][1]["methods"]}
    assert (
        coloured["demo paper cpu"]["flip_vs_reference"]
        > coloured["demo physical cpu"]["flip_vs_reference"]
    )
    # The atlas says what each scene does not show: the camera inside glass sees only glass;
    # the paper scene has no light (no shadow, no emitter) and no diffuse surface.
    absent = {s["scene"]: set(s["absent_effects"]) for s in data["scenes"]}
    assert absent["camera_inside_glass"] == set(EFFECTS) - {"refraction"}
    assert absent["coloured_lights"] == {"emitter", "reflection"}
    assert absent["paper"] == {"emitter", "direct", "shadow"}
    paper = data["scenes"][2]
    assert set(paper["effects"]) == {"background", "reflection", "refraction", "edges"}
    assert {m["nan"] for m in paper["methods"]} == {0}
    html = (tmp_path / "index.html").read_text()
    assert "camera_inside_glass" in html
    assert "Not in this scene: emitter, direct, shadow (does not occur in this scene)" in html


def test_an_out_folder_that_is_a_link_is_refused_before_any_render(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.mkdir()
    (tmp_path / "out").symlink_to(victim)
    rtval = str(Path(sys.executable).with_name("rtval"))
    proc = run([rtval, "stress", "--out", str(tmp_path / "out"), "--size", "16x12"])
    assert proc.returncode == 4, proc.stderr
    assert "rtval never follows links" in proc.stderr
    assert list(victim.iterdir()) == []
