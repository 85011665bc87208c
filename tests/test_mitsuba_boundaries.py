"""mitsuba_ref is the renderer package: it depends on scene_model and safe_files only (and Mitsuba, drjit,
numpy, the standard library), never on compare, whose command line imports it."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ALLOWED = {"mitsuba_ref", "scene_model", "safe_files", "mitsuba", "drjit", "numpy"}


def _imported(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_mitsuba_ref_imports_only_scene_model_and_its_renderer() -> None:
    sources = sorted((ROOT / "mitsuba_ref").glob("*.py"))
    assert sources
    for path in sources:
        foreign = _imported(path) - ALLOWED - set(sys.stdlib_module_names) - {"__future__"}
        assert not foreign, f"{path.name} imports {sorted(foreign)}"
