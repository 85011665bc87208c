"""The built-in scenes, shipped in this package, and how a command line names a scene.

Every command reads a scene the same way: a file (a path, or any name ending in .json) or the
name of a built-in scene (`paper`, `classic`, `lit`, `stress/no_light`, ...), so `--scene
classic` works in any folder.
"""

from __future__ import annotations

import difflib
from pathlib import Path

from scene_model.scene import SceneError

BUILT_IN = Path(__file__).resolve().parent / "scenes"


def built_in_names() -> list[str]:
    """'classic', 'lit', 'paper', 'stress/camera_inside_glass', ...: sorted."""
    return sorted(p.relative_to(BUILT_IN).with_suffix("").as_posix() for p in _files())


def built_in(name: str) -> Path:
    """The file of a built-in scene. Raises SceneError naming the closest names."""
    if name in built_in_names():
        return BUILT_IN / f"{name}.json"
    close = difflib.get_close_matches(name, built_in_names(), n=3)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    raise SceneError(
        f"{name!r} is neither a scene file (NAME.json) nor a built-in scene "
        f"({', '.join(n for n in built_in_names() if '/' not in n)}, stress/...){hint}"
    )


def scene_path(text: str) -> Path:
    """The scene a command line names: a path as given when it ends in .json or exists, else
    a built-in scene. A missing file whose name is a built-in scene's says so."""
    path = Path(text)
    if path.suffix == ".json" or path.exists():
        if not path.exists() and path.stem in built_in_names():
            raise SceneError(f"{text}: no such file (the built-in scene is named {path.stem!r})")
        return path
    return built_in(text)


def _files() -> list[Path]:
    return [*BUILT_IN.glob("*.json"), *BUILT_IN.glob("*/*.json")]
