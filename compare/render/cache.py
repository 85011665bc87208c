"""The render cache every command shares: renders (and results derived from them) by content.

A render is the command a person could type (`rtdemo render ...`, `rtval reference ...`).
Its key hashes the command's arguments (scene and output paths left out), the scene file's
bytes, rtdemo's RTDEMO_* environment and the renderer's identity (the rtdemo binary's bytes, or the mitsuba_ref and
scene_model sources plus the Mitsuba version): a re-run with nothing changed renders
nothing, any change re-renders, and the same render asked for by `report` and `grade` is
made once.

Where: `--cache DIR`, else $RTVAL_CACHE, else $XDG_CACHE_HOME/rtval, else ~/.cache/rtval.
Layout: renders/KEY.exr with KEY.json beside it (sha256, times, the command), derived/ for
metrics and figures keyed by their inputs' hashes, tmp/ for renders in progress.

Several processes may share a cache: every file appears by an atomic rename of a uniquely
named temporary file, so a reader sees a whole file or none, and two writers of one key
both succeed (the entry is the same render).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import os
import shutil
import time
from functools import cache
from pathlib import Path
from typing import Any

from compare.files import atomic_output, sha256_file, unique_sibling, write_atomic
from compare.render.runner import ToolError, rtdemo_path
from compare.safe_paths import check_output_target

ENV = "RTVAL_CACHE"
STALE_TMP_SECONDS = 24 * 3600  # a temporary file this old belongs to a process that died


def default_cache_dir() -> Path:
    chosen = os.environ.get(ENV)
    if chosen:
        return Path(chosen)
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and Path(xdg).is_absolute():  # the XDG spec ignores relative values
        return Path(xdg) / "rtval"
    return Path.home() / ".cache" / "rtval"


@cache
def _content_hash(path: str, mtime_ns: int, size: int) -> str:
    """A file's sha256, hashed again only when its path, time or size changes."""
    return sha256_file(Path(path))


def _file_hash(path: Path) -> str:
    st = path.stat()
    return _content_hash(str(path.resolve()), st.st_mtime_ns, st.st_size)


def renderer_identity(tool: str, executable: str | None = None) -> str:
    if tool == "rtdemo":
        binary = Path(executable or rtdemo_path())
        if not binary.is_file():
            raise ToolError(f"{binary}: no such rtdemo executable")
        # --backend gl runs rtdemo-gl beside it (the path /proc/self/exe gives rtdemo):
        # a change to the GL build alone must not serve its old renders.
        gl = binary.resolve().with_name("rtdemo-gl")
        return _file_hash(binary) + (_file_hash(gl) if gl.is_file() else "")
    return _mitsuba_identity()


@cache
def _mitsuba_identity() -> str:
    h = hashlib.sha256()
    # The renderer and the scene loader it reads with; report code changes must not re-render.
    for pkg in ("mitsuba_ref", "scene_model"):
        root = Path(__file__).resolve().parents[2] / pkg
        for p in sorted(root.glob("*.py")):
            h.update(p.read_bytes())
    for dist in ("mitsuba", "drjit"):
        h.update(importlib.metadata.version(dist).encode())
    return h.hexdigest()


def render_key(tool: str, args: list[str], scene_file: Path, executable: str | None = None) -> str:
    """`args` with the scene and output as the placeholders {scene} and {out}. rtdemo's
    RTDEMO_* environment variables (fault injection in tests) change what it renders, so
    they are part of the key too."""
    h = hashlib.sha256()
    h.update(tool.encode() + b"\0")
    h.update(json.dumps(args).encode())
    if tool == "rtdemo":
        env = sorted((k, v) for k, v in os.environ.items() if k.startswith("RTDEMO_"))
        h.update(json.dumps(env).encode())
    h.update(sha256_file(scene_file).encode())
    h.update(renderer_identity(tool, executable).encode())
    return h.hexdigest()[:24]


class RenderCache:
    def __init__(self, root: Path | str | None = None) -> None:
        self.root = Path(root) if root is not None else default_cache_dir()
        self.renders = self.root / "renders"
        self.derived_dir = self.root / "derived"
        self.tmp_dir = self.root / "tmp"

    def _ready(self) -> None:
        try:
            for d in (self.renders, self.derived_dir, self.tmp_dir):
                d.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise OSError(f"render cache {self.root}: cannot create it: {e.strerror}") from None

    def exr(self, key: str) -> Path:
        return self.renders / f"{key}.exr"

    def info(self, key: str) -> dict[str, Any] | None:
        """The entry's facts, or None when the render is not (completely) cached."""
        side = self.renders / f"{key}.json"
        if not (side.is_file() and self.exr(key).is_file()):
            return None
        try:
            return dict(json.loads(side.read_text()))
        except (OSError, ValueError):
            return None

    def tmp_path(self, key: str) -> Path:
        """Where a renderer writes a render in progress (then `store` moves it in)."""
        self._ready()
        return unique_sibling(self.tmp_dir / f"{key}.exr").with_suffix(".exr")

    def store(self, key: str, produced: Path, facts: dict[str, Any]) -> dict[str, Any]:
        """Moves a finished render into the cache; the sidecar written last marks it whole."""
        self._ready()
        info = {**facts, "sha256": sha256_file(produced), "stored": time.time()}
        check_output_target(self.exr(key))  # only ever replace a regular file
        produced.replace(self.exr(key))
        write_atomic(self.renders / f"{key}.json", json.dumps(info, indent=1))
        return info

    def derived(self, name: str) -> Path:
        """A file computed from cached inputs; `name` carries the inputs' hashes."""
        self._ready()
        return self.derived_dir / name

    def size(self) -> tuple[int, int]:
        """(files, bytes) under the cache folder."""
        files = total = 0
        if self.root.is_dir():
            for p in self.root.rglob("*"):
                if p.is_file():
                    files += 1
                    total += p.stat().st_size
        return files, total

    def clear(self) -> tuple[int, int]:
        """Removes every entry; returns what was removed. Renders in progress elsewhere
        are left alone unless stale."""
        files, total = 0, 0
        for d in (self.renders, self.derived_dir, self.tmp_dir):
            if not d.is_dir():
                continue
            for p in d.iterdir():
                if not p.is_file():
                    continue
                if d == self.tmp_dir and time.time() - p.stat().st_mtime < STALE_TMP_SECONDS:
                    continue
                size = p.stat().st_size
                p.unlink(missing_ok=True)
                files, total = files + 1, total + size
        return files, total

    def copy_out(self, key: str, target: Path) -> None:
        """A copy of a cached render elsewhere (e.g. grade's references/), atomically."""
        with atomic_output(target) as tmp:
            shutil.copyfile(self.exr(key), tmp)
