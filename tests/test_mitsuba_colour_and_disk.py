"""A colour above 1 (the scene format allows it) renders as given, with a warning naming the
sphere and field; a full disk under export or reference names the file and leaves nothing."""

from __future__ import annotations

import errno
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import SCENES

from compare.cli.main import main
from mitsuba_ref.reference import ReferenceSettings, render_reference
from scene_model.scene import load_scene


def _scene(tmp_path: Path, ball: list[float], name: str = "bright") -> Path:
    scene = {
        "format": "rtval-scene/1",
        "name": name,
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, -20], "width": 32, "height": 24},
        "spheres": [
            {"name": "ball", "center": [0, 0, -20], "radius": 4, "color": ball},
            {"name": "glass", "center": [5, 0, -20], "radius": 2, "color": ball,
             "transparency": 0.5, "ior": 1.5},
            {"name": "mirror", "center": [-5, 0, -20], "radius": 2, "color": ball,
             "reflection": 1},
            {"name": "light", "center": [0, 20, -30], "radius": 3, "color": [0, 0, 0],
             "emission": [3, 3, 3]},
        ],
    }  # fmt: skip
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(scene))
    return path


@pytest.mark.slow
def test_colour_above_one_renders_as_given_with_a_warning(tmp_path: Path) -> None:
    settings = ReferenceSettings(light="point", centre_rays=True)
    bright = render_reference(load_scene(_scene(tmp_path, [1.6, 0.4, 0.2])), settings)
    half = render_reference(load_scene(_scene(tmp_path, [0.8, 0.2, 0.1], "half")), settings)
    ball = bright.aovs["id"] == 0
    assert ball.sum() > 100
    # Direct light is linear in the colour: twice the colour, twice the light.
    assert np.allclose(bright.rgb[ball], 2 * half.rgb[ball], rtol=1e-5, atol=1e-7)
    assert bright.rgb[ball][:, 0].max() > 0
    assert [w.split(":")[0] for w in bright.warnings] == [f"spheres[{i}].color" for i in range(3)]
    assert "sphere 'ball' has a colour above 1 (1.6, 0.4, 0.2)" in bright.warnings[0]
    assert not half.warnings


@pytest.mark.slow
def test_reference_and_export_of_a_colour_above_one(tmp_path: Path, capsys: Any) -> None:
    scene = _scene(tmp_path, [1.5, 1.0, 1.0])
    out = tmp_path / "ref.exr"
    assert main(["reference", str(scene), "-o", str(out), "--integrator", "path"]) == 0
    err = capsys.readouterr().err
    assert f"rtval: warning: {scene}: spheres[0].color: sphere 'ball'" in err
    assert out.is_file()
    xml = tmp_path / "scene.xml"
    assert main(["export", str(scene), "-o", str(xml)]) == 0
    assert f"rtval: warning: {scene}: spheres[2].color: sphere 'mirror'" in capsys.readouterr().err
    # Mitsuba's own loader takes the exported file as it is.
    from mitsuba_ref.drjit_env import load_mitsuba

    mi = load_mitsuba("llvm_ad_rgb")
    image = np.asarray(mi.render(mi.load_file(str(xml)), spp=1))
    assert image.shape == (24, 32, 3) and np.isfinite(image).all() and image.max() > 0


def _full_disk(monkeypatch: Any) -> None:
    """Every atomic write fails as a full disk does: at the flush before the rename."""

    def fsync(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("safe_files.paths.os.fsync", fsync)


@pytest.mark.parametrize(("scene", "failing"), [("lit", "lit_sphere_0_cap.ply"), ("x", "x.xml")])
def test_export_on_a_full_disk_names_the_file_and_leaves_nothing(
    tmp_path: Path, monkeypatch: Any, capsys: Any, scene: str, failing: str
) -> None:
    (tmp_path / "in").mkdir()
    source = SCENES / "lit.json" if scene == "lit" else _scene(tmp_path / "in", [0.5] * 3, "x")
    folder = tmp_path / "out"
    folder.mkdir()
    _full_disk(monkeypatch)
    assert main(["export", str(source), "-o", str(folder / f"{scene}.xml")]) == 4
    err = capsys.readouterr().err
    assert f"rtval: error: {folder / failing}: cannot write: No space left on device" in err
    assert list(folder.iterdir()) == []


def test_reference_on_a_full_disk_names_the_file_and_leaves_nothing(
    tmp_path: Path, monkeypatch: Any, capsys: Any
) -> None:
    from compare.judge import images
    from mitsuba_ref import reference

    def render(scene: Any, settings: Any, progress: Any = None, snapshot: Any = None) -> Any:
        rgb = np.zeros((2, 2, 3), np.float32)
        return reference.ReferenceImage(
            rgb, None, {}, {"rtval.spp": "1", "rtval.stopped_by": "spp"}, 1, 0.0
        )

    def write_exr(path: Path, *args: Any, **kwargs: Any) -> None:
        with images.atomic_output(path) as tmp:
            tmp.write_bytes(b"half an image")
            # What OpenEXR raises when the disk fills (measured on a 64 KB tmpfs).
            raise RuntimeError(
                f'Failed to write pixel data to image file "{tmp}". No space left on device.'
            )

    monkeypatch.setattr(reference, "render_reference", render)
    monkeypatch.setattr(images, "write_exr", write_exr)
    out = tmp_path / "out" / "r.exr"
    out.parent.mkdir()
    assert main(["reference", str(SCENES / "lit.json"), "-o", str(out)]) == 4
    err = capsys.readouterr().err
    assert f"rtval: error: {out}: cannot write: No space left on device\n" in err
    assert list(out.parent.iterdir()) == []
