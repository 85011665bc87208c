"""The camera fitted from the silhouettes (compare/diagnose/camera_fit.py): rtdemo's own
renders with a camera a pixel loop's slip makes are read as that slip, with its field of
view; the scene's camera is not fitted at all; and a diagnosis names the camera cause."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from helpers import SCENES, render_demo

from compare.diagnose import camera_fit
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, diagnose
from compare.judge.images import read_image
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 200, 150
T30 = math.tan(math.radians(15))


def _classic(rtdemo: str, tmp_path: Path, name: str, *args: str, scene: Path = CLASSIC):
    out = tmp_path / f"{name}.exr"
    return render_demo(rtdemo, scene, out, "-q", "--mode", "classic", *args, size=(W, H)).rgb


def _scene_with_fov(tmp_path: Path, fov: float) -> Path:
    data = json.loads(CLASSIC.read_text())
    data["camera"]["fov_y"] = fov
    path = tmp_path / f"fov{fov:g}.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("what", "camera", "words"),
    [
        ("fov 40", None, "a field of view of 40 degrees (the scene's is 30)"),
        # the 30 degrees on the width: u = tan(15) (2px/W - 1), v = tan(15) H/W (1 - 2py/H)
        ("horizontal", (T30, 0.0, T30 * H / W, 0.0),
         "the field of view (30 degrees) taken as the horizontal one"),
        ("no aspect", (T30, 0.0, T30, 0.0),
         "no aspect ratio: the field of view (30 degrees) on both axes"),
        ("rows by the width", (T30 * W / H, 0.0, T30 * H / W, T30 * (1 - H / W)),
         "the row divided by the width, not the height"),
    ],
)  # fmt: skip
def test_a_camera_slip_is_read_as_that_slip(
    rtdemo: str, tmp_path: Path, what: str, camera: tuple[float, ...] | None, words: str
) -> None:
    model = _classic(rtdemo, tmp_path, "model")
    if camera is None:
        image = _classic(rtdemo, tmp_path, "image", scene=_scene_with_fov(tmp_path, 40))
    else:
        image = _classic(rtdemo, tmp_path, "image", "--camera-map", ",".join(map(str, camera)))
    found = camera_fit.fitted(image, [model], 30.0)
    assert [f.words for f in found][:1] == [words], what
    if camera is not None:  # the story's map is the camera's, to float precision
        assert max(abs(a - b) for a, b in zip(found[0].camera, camera, strict=True)) < 1e-6


def test_the_scenes_own_camera_is_not_fitted(rtdemo: str, tmp_path: Path) -> None:
    model = _classic(rtdemo, tmp_path, "model")
    other_mode = render_demo(
        rtdemo, CLASSIC, tmp_path / "paper.exr", "-q", "--mode", "paper", size=(W, H)
    ).rgb
    assert camera_fit.fitted(model, [model], 30.0) == []
    assert camera_fit.fitted(other_mode, [model], 30.0) == []  # colours differ, edges stay


def test_the_diagnosis_names_the_fitted_camera(rtdemo: str, tmp_path: Path) -> None:
    out = tmp_path / "student.ppm"
    render_demo(rtdemo, _scene_with_fov(tmp_path, 40), out, "-q", "--mode", "classic",
                size=(W, H))  # fmt: skip
    with CandidateRenderer(CLASSIC, W, H, threads=1) as render:
        d = diagnose(read_image(out), load_scene(CLASSIC), render, DiagnoseOptions(parallel=2))
    assert d.causes == ["camera: a field of view of 40 degrees (the scene's is 30)"], d.sentences
    assert d.mode == "classic" and d.exact, d.sentences
    assert d.as_dict()["causes"][0]["kind"] == "camera"


def test_pixel_corners_are_the_second_reading(rtdemo: str, tmp_path: Path) -> None:
    # No aspect ratio and pixel corners for centres: u = tan(15) (2x/W - 1), shifted by
    # half a pixel (-tan(15)/W), v likewise (+tan(15)/H). Half a pixel is within the story's
    # tolerance, so the fit offers the story with and without corners; the renders choose.
    cornered = (T30, -T30 / W, T30, T30 / H)
    model = _classic(rtdemo, tmp_path, "model")
    image = _classic(rtdemo, tmp_path, "image", "--camera-map", ",".join(map(str, cornered)))
    found = camera_fit.fitted(image, [model], 30.0)
    story = "no aspect ratio: the field of view (30 degrees) on both axes"
    corners = ", and pixel corners (x, y) for centres (x + 0.5, y + 0.5)"
    assert [f.words for f in found] == [story, story + corners]
    assert max(abs(a - b) for a, b in zip(found[1].camera, cornered, strict=True)) < 1e-6
