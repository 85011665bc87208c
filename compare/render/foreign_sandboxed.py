"""`rtval check --renderer ... --sandbox`: a renderer one does not trust, run in the sandbox
that grading uses (compare/sandbox/bwrap.py, docs/sandbox.md).

The renderer sees its inputs read-only at /sandbox/in ({scene}, {scene_xml}), writes {out} in
/sandbox/out and runs in /sandbox/work, a copy of every file or folder its command names (the
program, its script). Nothing else of the caller's is visible, and the image is read back
without following a link and with a bounded size.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from compare.errors import ToolError
from compare.render.placeholders import fill
from compare.sandbox.archives import TreeLimits, copy_tree
from compare.sandbox.bwrap import IN_DIR, OUT_DIR, WORK_DIR, Limits, Workspace, run_sandboxed
from compare.sandbox.output import read_output

SYSTEM_PREFIXES = ("/usr/", "/bin/", "/lib", "/etc/")  # visible read-only inside anyway


class SandboxedRenderFailed(ToolError):
    """The sandboxed renderer failed; the message gives the reason and the end of its log."""


def _copy_named(word: str, ws: Workspace, limits: TreeLimits) -> str:
    """A word that names a file or folder of the caller's: copied into work/, and the path
    the sandbox sees. Other words (options, `python3`, system paths) stay as they are."""
    p = Path(word)
    if word.startswith(SYSTEM_PREFIXES) or not (p.is_file() or p.is_dir()) or p.is_symlink():
        return word
    rel = Path(*[part for part in p.parts if part not in ("/", "..", ".")]) or Path(p.name)
    dest = ws.src / rel
    if dest.exists():
        return f"{WORK_DIR}/{rel}"
    dest.parent.mkdir(parents=True, exist_ok=True)
    if p.is_dir():
        copy_tree(p, dest, limits)
    else:
        if p.stat().st_size > limits.max_bytes:
            raise SandboxedRenderFailed(f"{word}: larger than {limits.max_bytes} bytes")
        shutil.copy2(p, dest)
    return f"{WORK_DIR}/{rel}"


def render_sandboxed(
    words: list[str],
    values: dict[str, str],
    out_name: str,
    size: tuple[int, int],
    timeout: float | None,
) -> tuple[Path, float, list[str]]:
    """Runs the command (placeholders in `words`, their values in `values`: `scene`,
    `scene_xml` are paths to copy in, `out` is replaced) and returns a private copy of the
    image it wrote, its time and the command as run. Raises SandboxedRenderFailed."""
    with Workspace() as ws:
        seen = dict(values)
        for key in ("scene", "scene_xml"):
            if values.get(key):
                shutil.copy2(values[key], ws.inputs / Path(values[key]).name)
                seen[key] = f"{IN_DIR}/{Path(values[key]).name}"
        seen["out"] = f"{OUT_DIR}/{out_name}"
        argv = []
        for w in words:
            if "{" in w:
                argv.append(fill(w, seen))
            else:
                argv.append(_copy_named(w, ws, TreeLimits()))
        read: list[tuple[str, bytes]] = []
        outcome = run_sandboxed(
            argv,
            ws,
            Limits(time=timeout or 600.0),
            collect=lambda _work, out: read.append(read_output(out, out_name, *size)),
        )
        if not outcome.ok:
            tail = f"\nrenderer output:\n{outcome.log[-2000:]}" if outcome.log.strip() else ""
            raise SandboxedRenderFailed(f"{outcome.reason} (sandboxed): {' '.join(argv)}{tail}")
        problem, data = read[-1] if read else ("no output: it could not be read back", b"")
        if problem:
            raise SandboxedRenderFailed(f"{problem} (sandboxed): {' '.join(argv)}")
        kept = Path(tempfile.mkdtemp(prefix="rtval-sandboxed-")) / out_name
        kept.write_bytes(data)
        return kept, outcome.seconds, argv
