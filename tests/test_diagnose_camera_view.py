"""Where the camera stands and looks (compare/diagnose/camera_view.py): on the lit scene, whose
camera looks down from (0, 1, 4), rtdemo's renders of each slip with the scene's position and
look_at are read as that slip from the silhouettes alone, the scene's own render as none; a
scene whose camera is the lineage's fixed one has no such slips; and a diagnosis names the
slip, renders it from a scene copy, and says so."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import SCENES, render_demo

from compare.diagnose import camera_view
from compare.diagnose.evidence import render_command
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, diagnose
from compare.judge.images import read_image
from scene_model.scene import load_scene

LIT = SCENES / "lit.json"
W, H = 200, 150
# (the slip's words, its position and look_at for the lit scene's (0, 1, 4) -> (0, -1.5, -18))
SLIPS = [
    ("the camera at the origin looking down -z (the scene's position and look_at ignored)",
     (0, 0, 0), (0, 0, -1)),
    ("the camera looking down -z from its position (look_at ignored)", (0, 1, 4), (0, 1, 3)),
    ("look_at taken as a direction from the position, not a point", (0, 1, 4), (0, -0.5, -14)),
    ("the camera at the origin (its position ignored), looking at look_at",
     (0, 0, 0), (0, -1.5, -18)),
]  # fmt: skip


def _lit_with_camera(tmp_path: Path, position: tuple[float, ...], look_at: tuple[float, ...]):
    data = json.loads(LIT.read_text())
    data["camera"].update(position=list(position), look_at=list(look_at))
    path = tmp_path / "slipped.json"
    path.write_text(json.dumps(data))
    return path


def test_only_a_camera_away_from_the_origin_has_slips() -> None:
    assert [v.words for v in camera_view.stories(load_scene(LIT))] == [w for w, *_ in SLIPS]
    for fixed in ("classic", "paper"):  # at the origin looking down -z: every slip is the scene's
        assert camera_view.stories(load_scene(SCENES / f"{fixed}.json")) == []


@pytest.mark.parametrize(("words", "position", "look_at"), SLIPS)
def test_each_slip_is_read_from_the_silhouettes(
    rtdemo: str, tmp_path: Path, words: str, position: tuple[float, ...], look_at: tuple[float, ...]
) -> None:
    scene = _lit_with_camera(tmp_path, position, look_at)
    image = render_demo(rtdemo, scene, tmp_path / "i.exr", "-q", "--mode", "paper", size=(W, H))
    found = camera_view.fitted(camera_view.image_edges(image.rgb), load_scene(LIT))
    assert [v.words for v in found][:1] == [words]
    assert (found[0].position, found[0].look_at) == (position, look_at)


def test_the_scenes_own_camera_is_no_slip(rtdemo: str, tmp_path: Path) -> None:
    for mode in ("paper", "classic"):
        image = render_demo(
            rtdemo, LIT, tmp_path / f"{mode}.exr", "-q", "--mode", mode, size=(W, H)
        )
        assert camera_view.fitted(camera_view.image_edges(image.rgb), load_scene(LIT)) == []


def test_a_scene_of_many_spheres_is_looked_at_on_fewer_pixels(rtdemo: str, tmp_path: Path) -> None:
    # The thousand-sphere stress scene seen from the lit camera: id maps on every 5th pixel.
    data = json.loads((SCENES / "stress" / "thousand_spheres.json").read_text())
    data["camera"].update(position=[0, 1, 4], look_at=[0, -1.5, -18])
    scene = tmp_path / "many.json"
    scene.write_text(json.dumps(data))
    data["camera"]["look_at"] = [0, 1, 3]
    (tmp_path / "slipped.json").write_text(json.dumps(data))
    loaded = load_scene(scene)
    for name, words in (("many", []), ("slipped", [SLIPS[1][0]])):
        image = render_demo(rtdemo, tmp_path / f"{name}.json", tmp_path / f"{name}.exr", "-q",
                            "--mode", "classic", size=(320, 240))  # fmt: skip
        found = camera_view.fitted(camera_view.image_edges(image.rgb), loaded)
        assert [v.words for v in found][:1] == words


def test_the_diagnosis_names_the_slip_and_renders_it_from_a_scene_copy(
    rtdemo: str, tmp_path: Path
) -> None:
    words, position, look_at = SLIPS[2]
    out = tmp_path / "student.ppm"
    render_demo(rtdemo, _lit_with_camera(tmp_path, position, look_at), out, "-q",
                "--mode", "paper", size=(W, H))  # fmt: skip
    with CandidateRenderer(LIT, W, H, threads=1) as render:
        d = diagnose(read_image(out), load_scene(LIT), render, DiagnoseOptions(parallel=2))
    assert d.causes == [f"camera: {words}"], d.sentences
    assert d.mode == "paper" and d.exact, d.sentences
    cause = d.as_dict()["causes"][0]
    assert cause["kind"] == "camera"
    assert d.scene_changes == {"camera": {"position": [0, 1, 4], "look_at": [0, -0.5, -14]}}
    assert "--camera-map" not in d.rtdemo_args
    assert "(a copy with the camera at (0, 1, 4) looking at (0, -0.5, -14))" in render_command(
        d, LIT
    )
