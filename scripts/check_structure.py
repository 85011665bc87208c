"""Holds the tree's shape: which package may import which, and how long a function may be.

Run by `make lint`. Layers import downwards only: compare's cli -> apps -> render -> judge, all of
them -> scene_model; mitsuba_ref (the Mitsuba renderer) -> scene_model; scene_model -> nothing of ours.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("compare", "mitsuba_ref", "scene_model")
# What each part may import of ours (a part is a top-level package or one of compare's layers).
ALLOWED = {
    "scene_model": set(),
    "mitsuba_ref": {"scene_model"},
    "compare.judge": {"scene_model"},
    "compare.render": {"compare.judge", "scene_model", "mitsuba_ref"},
    "compare.apps": {"compare.render", "compare.judge", "scene_model", "mitsuba_ref"},
    "compare.cli": {
        "compare.apps",
        "compare.render",
        "compare.judge",
        "scene_model",
        "mitsuba_ref",
    },
}
LAYERS = ("cli", "apps", "render", "judge")
MAX_FUNCTION_LINES = 60


def part_of(module: str) -> str:
    """The part a dotted module name belongs to; compare's own top-level modules are 'compare'."""
    bits = module.split(".")
    if bits[0] == "compare" and len(bits) > 1 and bits[1] in LAYERS:
        return f"compare.{bits[1]}"
    return bits[0]


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports(tree: ast.AST, module: str) -> Iterator[tuple[int, str]]:
    """(line, imported module) for every import of one of our packages, relative ones resolved."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")[: -node.level]
                yield node.lineno, ".".join([*base, node.module or ""]).rstrip(".")
            elif node.module:
                yield node.lineno, node.module


def boundary_errors(path: Path, tree: ast.AST) -> list[str]:
    module = module_name(path)
    own = part_of(module)
    allowed = ALLOWED.get(own)
    errors = []
    for line, target in imports(tree, module):
        if target.split(".")[0] not in PACKAGES:
            continue
        other = part_of(target)
        if other == own:
            continue
        # compare's top-level helper modules (escape, files, ...) serve every layer of compare.
        if other == "compare" and own.startswith("compare"):
            continue
        if allowed is not None and other not in allowed:
            errors.append(f"{path.relative_to(ROOT)}:{line}: {own} must not import {target}")
    return errors


def length_errors(path: Path, tree: ast.AST, limit: int) -> list[str]:
    errors = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            lines = (node.end_lineno or node.lineno) - node.lineno + 1
            if lines > limit:
                errors.append(
                    f"{path.relative_to(ROOT)}:{node.lineno}: {node.name} is {lines} lines "
                    f"(at most {limit}: split it into steps)"
                )
    return errors


def graph() -> dict[str, set[str]]:
    """Which part imports which: the import graph between the packages and compare's layers."""
    edges: dict[str, set[str]] = {}
    for path in sources():
        own = part_of(module_name(path))
        for _, target in imports(ast.parse(path.read_text()), module_name(path)):
            if target.split(".")[0] in PACKAGES and part_of(target) != own:
                edges.setdefault(own, set()).add(part_of(target))
    return edges


def sources() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-lines", type=int, default=MAX_FUNCTION_LINES, help="function budget")
    ap.add_argument("--graph", action="store_true", help="print the import graph and stop")
    args = ap.parse_args()
    if args.graph:
        for part, targets in sorted(graph().items()):
            print(f"{part} -> {', '.join(sorted(targets))}")
        return 0
    errors = []
    for path in sources():
        tree = ast.parse(path.read_text(), filename=str(path))
        errors += boundary_errors(path, tree) + length_errors(path, tree, args.max_lines)
    for e in errors:
        print(e, file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
