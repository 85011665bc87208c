"""Where the light is (compare/diagnose/light_fit.py): rtdemo's classic render of classic.json
with its one light moved is read as that light's position off the directly lit surfaces, and
the diagnosis names it as a constant; the scene's own render offers no position."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import SCENES, render_demo

from compare.diagnose.light_fit import lights_seen
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, diagnose
from compare.judge.effects import effect_masks
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 160, 120


def _moved(tmp_path: Path, centre: list[float]) -> Path:
    data = json.loads(CLASSIC.read_text())
    for s in data["spheres"]:
        if any(v > 0 for v in s.get("emission", [0])):
            s["center"] = centre
    path = tmp_path / "moved.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("centre", [[0, 30, -30], [-6, 20, -25]])
def test_a_moved_light_is_read_off_the_lit_surfaces(
    rtdemo: str, tmp_path: Path, centre: list[float]
) -> None:
    start = render_demo(rtdemo, CLASSIC, tmp_path / "start.exr", "-q", "--mode", "classic",
                        size=(W, H))  # fmt: skip
    scene = load_scene(CLASSIC)
    direct = effect_masks(scene, start.aovs["id"], start.aovs["depth"])["direct"]
    image = render_demo(rtdemo, _moved(tmp_path, centre), tmp_path / "i.ppm", "-q",
                        "--mode", "classic", size=(W, H))  # fmt: skip
    assert tuple(centre) in lights_seen(image.rgb, start, direct, scene, "linear")
    assert lights_seen(start.rgb, start, direct, scene, "float") == []


def test_the_diagnosis_names_the_lights_position(rtdemo: str, tmp_path: Path) -> None:
    image = render_demo(rtdemo, _moved(tmp_path, [0, 30, -30]), tmp_path / "student.ppm", "-q",
                        "--mode", "classic", size=(W, H))  # fmt: skip
    with CandidateRenderer(CLASSIC, W, H, threads=1) as render:
        d = diagnose(image, load_scene(CLASSIC), render, DiagnoseOptions(parallel=2))
    assert d.causes == ["light at (0, 30, -30)"] and d.exact, d.sentences
    cause = d.as_dict()["causes"][0]
    assert cause["kind"] == "constant" and set(cause["effects"]) >= {"direct", "shadow"}
    assert d.scene_changes == {"light": [0, 30, -30]}
