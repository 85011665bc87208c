"""One code identity for every result kept between runs: a hash of the code it came from.

A result (a diagnosis, a kept mask, a FLIP mean, a report metric, a Mitsuba render) is keyed by
the identity of the module that computes it: the source of that module and of every module of
ours it imports, directly or not, at the top or inside a function; the data files beside each of
them (mistakes.json, templates); and the versions of the outside libraries named. The import
graph decides what is covered, so a new module is covered as soon as it is imported.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib.metadata
from collections.abc import Iterator
from pathlib import Path

OURS = ("compare", "scene_model", "mitsuba_ref", "safe_files")
DATA_SUFFIXES = (".json", ".j2")
ROOT = Path(__file__).resolve().parents[1]  # the folder that holds our packages


def code_identity(*modules: str, distributions: tuple[str, ...] = ()) -> str:
    """Hex sha256 of the modules' code (see the module's docstring) and the distributions'
    versions, e.g. code_identity("compare.diagnose.flip", distributions=("flip-evaluator",))."""
    return _identity(ROOT, tuple(sorted(modules)), tuple(sorted(distributions)))


@functools.cache
def _identity(root: Path, modules: tuple[str, ...], distributions: tuple[str, ...]) -> str:
    h = hashlib.sha256()
    for path in covered_files(root, modules):
        h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    for dist in distributions:
        h.update(f"{dist}=={importlib.metadata.version(dist)}\0".encode())
    return h.hexdigest()


def covered_files(root: Path, modules: tuple[str, ...]) -> list[Path]:
    """The source files the modules import from our packages, transitively, and the data
    files of the folders they sit in, sorted."""
    seen: set[Path] = set()
    todo = [p for m in modules if (p := module_file(root, m)) is not None]
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        for dotted in _imports(root, path):
            found = module_file(root, dotted)
            if found is not None:
                todo.append(found)
    data = {d for p in seen for d in p.parent.iterdir() if d.suffix in DATA_SUFFIXES}
    return sorted(seen | data)


def module_file(root: Path, dotted: str) -> Path | None:
    """The file of one of our modules (a package is its __init__.py), or None."""
    if dotted.split(".")[0] not in OURS:
        return None
    base = root.joinpath(*dotted.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@functools.cache
def _imports(root: Path, path: Path) -> tuple[str, ...]:
    """imported(), once per file and process (every identity covers most of the same files)."""
    return tuple(imported(root, path))


def imported(root: Path, path: Path) -> Iterator[str]:
    """The modules the file's import statements name: `from a import b` is a.b where b is a
    module, else a (a package's __init__ is not implied by importing one of its modules)."""
    module = _module_name(root, path)
    for node in _statements(ast.parse(path.read_bytes(), filename=str(path))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            source = node.module or ""
            if node.level:
                package = module.split(".")[: len(module.split(".")) - node.level + _is_init(path)]
                source = ".".join([*package, *([source] if source else [])])
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                yield sub if module_file(root, sub) is not None else source


def _statements(node: ast.AST) -> Iterator[ast.AST]:
    """Every node under `node` but inside expressions: an import is a statement, and
    expressions are most of a module's nodes."""
    for child in ast.iter_child_nodes(node):
        if not isinstance(child, ast.expr):
            yield child
            yield from _statements(child)


def _is_init(path: Path) -> int:
    return int(path.name == "__init__.py")


def _module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
