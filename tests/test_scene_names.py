"""scene_model.builtin: every command names a scene the same way, a file or a built-in scene,
from any folder."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

from scene_model.builtin import BUILT_IN, built_in_names, scene_path
from scene_model.scene import SceneError, load_scene

RTVAL = [sys.executable, "-m", "compare.cli.main"]


def test_the_built_in_scenes_are_the_projects_scenes() -> None:
    assert {"paper", "classic", "lit", "stress/no_light"} <= set(built_in_names())
    assert (SCENES / "classic.json").read_bytes() == (BUILT_IN / "classic.json").read_bytes()


def test_a_name_is_a_built_in_scene_and_a_file_is_a_file(tmp_path: Path) -> None:
    assert load_scene(scene_path("classic")).name == "classic"
    assert scene_path("stress/no_light") == BUILT_IN / "stress" / "no_light.json"
    mine = tmp_path / "mine.json"
    mine.write_bytes((BUILT_IN / "lit.json").read_bytes())
    assert scene_path(str(mine)) == mine


def test_a_misspelt_name_gets_the_close_names() -> None:
    with pytest.raises(SceneError, match=r"'clasic' is neither.*did you mean 'classic'\?"):
        scene_path("clasic")


def test_a_missing_file_named_like_a_built_in_scene_says_its_name(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"no such file \(the built-in scene is named 'paper'\)"):
        scene_path(str(tmp_path / "scenes" / "paper.json"))


def test_commands_find_built_in_scenes_from_any_folder(tmp_path: Path) -> None:
    """From a folder that is not the checkout: the name resolves, the output is written."""
    out = tmp_path / "classic.xml"
    env = {**os.environ, "PYTHONPATH": ""}
    r = run([*RTVAL, "export", "classic", "-o", str(out)], cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    assert "<scene" in out.read_text()
    bad = run([*RTVAL, "export", "clasic", "-o", str(out)], cwd=tmp_path, env=env)
    assert bad.returncode == 3
    assert "did you mean 'classic'?" in bad.stderr
