"""Holds the tree's shape: which room may import which, no import circles, and how long a
function may be and how many parameters it may take.

Run by `make lint`. The rooms (docs/architecture.md) import downwards only:

    safe_files  <- scene_model <- mitsuba_ref
    compare's helpers (escape, errors, sizes, interrupts, student_ids, code_identity)
    judge, sandbox, pages  <- render <- diagnose, verdict <- check, report, grading, stress <- cli
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("compare", "mitsuba_ref", "scene_model", "safe_files")
BASE = {"safe_files", "scene_model", "compare.helpers"}
# What each room may import of ours besides itself.
ALLOWED: dict[str, set[str]] = {
    "safe_files": set(),
    "scene_model": {"safe_files"},
    "mitsuba_ref": {"scene_model", "safe_files"},
    "compare.helpers": {"safe_files"},
    "compare.judge": BASE,
    "compare.sandbox": BASE,
    "compare.pages": BASE,
    "compare.render": BASE | {"compare.judge", "compare.sandbox", "mitsuba_ref"},
    "compare.diagnose": BASE | {"compare.judge", "compare.render"},
    "compare.verdict": BASE | {"compare.judge", "compare.render"},
}
_UPPER = BASE | {"compare.judge", "compare.sandbox", "compare.pages", "compare.render"}
_UPPER |= {"compare.diagnose", "compare.verdict", "mitsuba_ref"}
for _room in ("check", "report", "grading", "stress"):
    ALLOWED[f"compare.{_room}"] = _UPPER
ALLOWED["compare.cli"] = _UPPER | {f"compare.{r}" for r in ("check", "report", "grading", "stress")}
# compare's public API (__init__) and its pytest plugin stand above every room.
ALLOWED["compare"] = ALLOWED["compare.cli"]
HELPERS = {"escape", "errors", "sizes", "interrupts", "student_ids", "code_identity"}
ROOMS = {part.split(".")[1] for part in ALLOWED if part.startswith("compare.")} - {"helpers"}
MAX_FUNCTION_LINES = 60
MAX_PARAMETERS = 7  # more travel together in a dataclass


def part_of(module: str) -> str:
    """The room a dotted module name belongs to."""
    bits = module.split(".")
    if bits[0] == "compare" and len(bits) > 1:
        if bits[1] in ROOMS:
            return f"compare.{bits[1]}"
        if bits[1] in HELPERS:
            return "compare.helpers"
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
                source = ".".join([*base, node.module or ""]).rstrip(".")
            else:
                source = node.module or ""
            for alias in node.names:  # `from package import module` imports the module
                sub = f"{source}.{alias.name}"
                yield node.lineno, sub if is_module(sub) else source


def is_module(dotted: str) -> bool:
    path = ROOT / Path(*dotted.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


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


def parameter_errors(path: Path, tree: ast.AST, limit: int) -> list[str]:
    errors = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
            count = len(names) - (names[:1] in (["self"], ["cls"]))
            count += (a.vararg is not None) + (a.kwarg is not None)
            if count > limit:
                errors.append(
                    f"{path.relative_to(ROOT)}:{node.lineno}: {node.name} takes {count} "
                    f"parameters (at most {limit}: gather them in a dataclass)"
                )
    return errors


def local_imports(tree: ast.Module) -> Iterator[ast.Import | ast.ImportFrom]:
    """Imports inside functions (the others run when the module loads)."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for inner in ast.walk(node):
                if isinstance(inner, (ast.Import, ast.ImportFrom)):
                    yield inner


def local_import_errors(path: Path, tree: ast.Module) -> list[str]:
    """Our own modules are imported at the top; only the CLI defers them, for start-up, and a
    line that says why (`# deferred: ...`)."""
    module = module_name(path)
    if part_of(module) == "compare.cli":
        return []
    lines = path.read_text().splitlines()
    errors = []
    for node in {id(n): n for n in local_imports(tree)}.values():
        if "# deferred:" in lines[node.lineno - 1]:
            continue
        wrapper = ast.Module(body=[node], type_ignores=[])
        for _, target in imports(wrapper, module):
            if target.split(".")[0] in PACKAGES:
                errors.append(
                    f"{path.relative_to(ROOT)}:{node.lineno}: {target} imported inside a "
                    "function (import it at the top; a circle means a module is in the wrong room)"
                )
    return errors


def module_graph() -> dict[str, set[str]]:
    """Which of our modules imports which, to the module (a package import counts as its __init__)."""
    known = {module_name(p) for p in sources()}
    edges: dict[str, set[str]] = {}
    for path in sources():
        own = module_name(path)
        for _, target in imports(ast.parse(path.read_text()), own):
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != own and not own.startswith(target + "."):
                edges.setdefault(own, set()).add(target)
    return edges


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The import circles: strongly connected groups of two or more modules (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def graph() -> dict[str, set[str]]:
    """Which room imports which: the import graph between the packages and compare's rooms."""
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
        errors += parameter_errors(path, tree, MAX_PARAMETERS) + local_import_errors(path, tree)
    errors += [f"import circle: {' <-> '.join(c)}" for c in circles(module_graph())]
    for e in errors:
        print(e, file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
