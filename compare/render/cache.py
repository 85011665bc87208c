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

Nothing in it is trusted blindly: its folders must be real folders (a symbolic link planted
as `renders/` is refused, never followed or emptied), an entry must be two regular files
whose EXR has the sha256 its sidecar recorded (else it is discarded and rendered again; an EXR
whose stamp (inode, size, times) is the one recorded when it was stored is not hashed again), and a
cache folder others may write to is named in a warning. It stays under a size cap
(MAX_SIZE_ENV, `rtval cache --max-size`, else DEFAULT_MAX_BYTES): the entries used longest ago
go first, never one used in the last GRACE_SECONDS (another process may be about to read it;
one that has it open keeps reading, as unlinking leaves open files whole).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import re
import shutil
import stat
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare.code_identity import code_identity
from compare.errors import ToolError
from compare.render.runner import rtdemo_path
from safe_files.content import sha256_file, unique_sibling
from safe_files.paths import (
    UnsafePathError,
    atomic_output,
    check_output_target,
    read_bounded,
    require_folder,
    write_atomic,
    write_text_checked,
)

ENV = "RTVAL_CACHE"
MAX_SIZE_ENV = "RTVAL_CACHE_MAX_SIZE"
DEFAULT_MAX_BYTES = 4 * 10**9  # a few cold reports of the paper scene at 1200x800
GRACE_SECONDS = 600  # an entry used this recently is never evicted
STALE_TMP_SECONDS = 24 * 3600  # a temporary file this old belongs to a process that died
SIDECAR_MAX_BYTES = 1 << 20
STATS = ("hits", "misses", "evictions", "discarded")


class CacheError(OSError):
    """The cache folder cannot be used safely; the message names the path and why."""


def default_cache_dir() -> Path:
    chosen = os.environ.get(ENV)
    if chosen:
        return Path(chosen)
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and Path(xdg).is_absolute():  # the XDG spec ignores relative values
        return Path(xdg) / "rtval"
    return Path.home() / ".cache" / "rtval"


_HASHES: dict[tuple[int, ...], str] = {}
_HASHES_LOCK = threading.Lock()


def _stamp(st: os.stat_result) -> list[int]:
    """What any change to a file changes: its device and inode, size, modification time and
    status-change time (which no process can set back, unlike the modification time)."""
    return [st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns]


def _file_hash(path: Path) -> str:
    """A file's sha256, hashed again only when its stamp changes."""
    stamp = tuple(_stamp(path.stat()))
    with _HASHES_LOCK:
        known = _HASHES.get(stamp)
    if known is None:
        known = sha256_file(path)
        with _HASHES_LOCK:
            _HASHES[stamp] = known
    return known


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


def _mitsuba_identity() -> str:
    # The renderer and the scene loader it reads with; report code changes must not re-render.
    return code_identity("mitsuba_ref.reference", distributions=("mitsuba", "drjit"))


def render_key(tool: str, args: list[str], scene_file: Path, executable: str | None = None) -> str:
    """`args` with the scene and output as the placeholders {scene} and {out}. rtdemo's
    RTDEMO_* environment variables (RTDEMO_ISA: another kernel) may change what it renders, so
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
        if root is not None and not str(root).strip():
            raise CacheError("--cache: an empty path names no folder")
        self.root = Path(root) if root is not None else default_cache_dir()
        self.renders = self.root / "renders"
        self.derived_dir = self.root / "derived"
        self.tmp_dir = self.root / "tmp"
        self.locks_dir = self.root / "locks"  # 256 lock files, never evicted or cleared
        self._warned = False
        if os.environ.get(MAX_SIZE_ENV):
            self.max_bytes()  # a bad $RTVAL_CACHE_MAX_SIZE is refused before any render

    def check_root(self) -> None:
        """The cache folder and its subfolders are real folders, or not there yet (a device,
        a file or a link in their place is refused)."""
        for d in (self.root, self.renders, self.derived_dir, self.tmp_dir, self.locks_dir):
            if os.path.lexists(d):
                _require_folder(d)

    def entry_files(self) -> list[Path]:
        """The regular files of renders/ (nothing through a link)."""
        return _plain_files(self.renders)

    def _ready(self) -> None:
        try:
            for d in (self.root, self.renders, self.derived_dir, self.tmp_dir, self.locks_dir):
                d.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise CacheError(f"render cache {self.root}: cannot create it: {e.strerror}") from None
        for d in (self.renders, self.derived_dir, self.tmp_dir, self.locks_dir):
            _require_folder(d)
        self._warn_if_shared()

    def _warn_if_shared(self) -> None:
        st = self.root.stat()
        if not self._warned and st.st_mode & stat.S_IWOTH and not st.st_mode & stat.S_ISVTX:
            self._warned = True
            print(
                f"rtval: warning: render cache {self.root} is writable by every user: anyone "
                "could plant renders in it (use a folder of your own, e.g. --cache)",
                file=sys.stderr,
            )

    def exr(self, key: str) -> Path:
        return self.renders / f"{key}.exr"

    def _sidecar(self, key: str) -> Path:
        return self.renders / f"{key}.json"

    def info(self, key: str) -> dict[str, Any] | None:
        """The entry's facts, or None when the render is not (completely, intactly) cached.
        A damaged or replaced entry is removed, so that it is rendered again."""
        if not self.renders.is_dir():
            return None
        self._ready()
        with _locked(self._key_lock(key), shared=True):  # never halfway through a store
            return self._verified(key)

    def _key_lock(self, key: str) -> Path:
        """One of 256 lock files: an entry's EXR and sidecar change together under it."""
        return self.locks_dir / f"{key[:2]}.lock"

    def _verified(self, key: str) -> dict[str, Any] | None:
        exr, side = self.exr(key), self._sidecar(key)
        if not (_is_plain_file(exr) and _is_plain_file(side)):
            if os.path.lexists(exr) or os.path.lexists(side):
                self._discard(key, "is not two regular files")
            return None
        try:
            facts = dict(json.loads(read_bounded(side, SIDECAR_MAX_BYTES)))
        except (OSError, ValueError, TypeError):
            self._discard(key, "has an unreadable sidecar")
            return None
        # The stamp stored with the entry unchanged: the file is the one hashed when stored.
        unchanged = facts.get("stamp") == _stamp(exr.stat())
        if not unchanged and facts.get("sha256") != _file_hash(exr):
            self._discard(key, "does not match the sha256 its sidecar recorded")
            return None
        _touch(side)  # the eviction order: least recently used first
        return facts

    def _discard(self, key: str, why: str) -> None:
        print(
            f"rtval: render cache: entry {key} {why}; discarded, it will be rendered again",
            file=sys.stderr,
        )
        for p in (self.exr(key), self._sidecar(key)):
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
        self.count(discarded=1)

    def tmp_path(self, key: str) -> Path:
        """Where a renderer writes a render in progress (then `store` moves it in)."""
        self._ready()
        return unique_sibling(self.tmp_dir / f"{key}.exr").with_suffix(".exr")

    def store(self, key: str, produced: Path, facts: dict[str, Any]) -> dict[str, Any]:
        """Moves a finished render into the cache; the sidecar written last marks it whole."""
        self._ready()
        sha = sha256_file(produced)
        check_output_target(self.exr(key))  # only ever replace a regular file
        with _locked(self._key_lock(key)):  # two writers of one key: one whole entry
            produced.replace(self.exr(key))
            # Stamped after the rename, which changes the file's status-change time.
            stamp = _stamp(self.exr(key).stat())
            info = {**facts, "sha256": sha, "stamp": stamp, "stored": time.time()}
            write_atomic(self._sidecar(key), json.dumps(info, indent=1))
        return info

    def derived(self, name: str) -> Path:
        """A file computed from cached inputs; `name` carries the inputs' hashes. Anything but
        a regular file there (a planted link) is removed first: it is never followed."""
        self._ready()
        path = self.derived_dir / name
        try:
            mode = os.lstat(path).st_mode  # once: a file another thread just wrote is kept
        except OSError:
            return path
        if stat.S_ISREG(mode):
            _touch(path)
        else:
            print(f"rtval: render cache: {path} is not a regular file; removed", file=sys.stderr)
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
        return path

    def derived_text(self, name: str, text: str) -> Path:
        """derived(name) holding exactly `text` (a scene copy a render is made from): what is
        there is checked, not trusted, and written again when it differs."""
        path = self.derived(name)
        write_text_checked(path, text)
        return path

    def _entries(self) -> list[_Entry]:
        """Every evictable entry: a render (its EXR and sidecar together) or a derived file."""
        groups: dict[str, _Entry] = {}
        for d in (self.renders, self.derived_dir):
            if not _is_folder(d):
                continue
            with os.scandir(d) as it:
                for e in it:
                    if e.name.startswith(".") or not e.is_file(follow_symlinks=False):
                        continue
                    st = e.stat(follow_symlinks=False)
                    group = str(d / Path(e.name).stem) if d == self.renders else e.path
                    entry = groups.setdefault(group, _Entry([], 0, 0.0))
                    entry.paths.append(Path(e.path))
                    entry.size += st.st_size
                    entry.used = max(entry.used, st.st_mtime)
        return list(groups.values())

    def size(self) -> tuple[int, int]:
        """(files, bytes) of the cache's entries and renders in progress."""
        entries = self._entries()
        files = sum(len(e.paths) for e in entries)
        total = sum(e.size for e in entries)
        for p in _plain_files(self.tmp_dir):
            files, total = files + 1, total + p.stat().st_size
        return files, total

    def max_bytes(self) -> int:
        """The size cap: $RTVAL_CACHE_MAX_SIZE, else the cache's own setting, else the default."""
        chosen = os.environ.get(MAX_SIZE_ENV)
        if chosen:
            try:
                return parse_size(chosen)
            except ValueError as e:
                raise ValueError(f"${MAX_SIZE_ENV}: {e}") from None
        setting = self.root / "settings.json"
        if _is_plain_file(setting):
            try:
                return int(json.loads(read_bounded(setting, SIDECAR_MAX_BYTES))["max_bytes"])
            except (OSError, ValueError, KeyError, TypeError):
                raise CacheError(f'{setting}: expected {{"max_bytes": N}}') from None
        return DEFAULT_MAX_BYTES

    def set_max_bytes(self, n: int) -> None:
        self._ready()
        write_atomic(self.root / "settings.json", json.dumps({"max_bytes": n}))

    def evict(self, max_bytes: int | None = None) -> tuple[int, int]:
        """Removes the least recently used entries until the cache fits its cap; entries
        used in the last GRACE_SECONDS stay whatever the size. Returns (entries, bytes)."""
        cap = self.max_bytes() if max_bytes is None else max_bytes
        entries = sorted(self._entries(), key=lambda e: e.used)
        total = sum(e.size for e in entries)
        removed = freed = 0
        now = time.time()
        for e in entries:
            if total <= cap or now - e.used < GRACE_SECONDS:
                break
            for p in sorted(e.paths, key=lambda p: p.suffix != ".json"):  # sidecar first
                with contextlib.suppress(FileNotFoundError):
                    p.unlink()
            total, removed, freed = total - e.size, removed + 1, freed + e.size
        if removed:
            self.count(evictions=removed)
        return removed, freed

    def count(self, **events: int) -> None:
        """Adds to the cache's lifetime counts (hits, misses, evictions, discarded)."""
        if not any(events.values()) or not _is_folder(self.root):
            return
        try:
            with _locked(self.root / ".stats.lock"):
                stats = self.stats()
                for k, n in events.items():
                    stats[k] = stats.get(k, 0) + n
                write_atomic(self.root / "stats.json", json.dumps(stats))
        except OSError as e:  # the counts are a report: they never stop a verdict
            print(
                f"rtval: warning: render cache {self.root}: counts not kept: {e}", file=sys.stderr
            )

    def stats(self) -> dict[str, int]:
        path = self.root / "stats.json"
        out = dict.fromkeys(STATS, 0)
        if _is_plain_file(path):
            with contextlib.suppress(OSError, ValueError, TypeError, AttributeError):
                raw = json.loads(read_bounded(path, SIDECAR_MAX_BYTES))
                good = {k: raw[k] for k in STATS if type(raw.get(k)) is int and raw[k] >= 0}
                out.update(good)  # a bool, a negative or a float count is not one
        return out

    def clear(self) -> tuple[int, int]:
        """Removes every entry; returns what was removed. Renders in progress elsewhere
        are left alone unless stale; nothing outside the cache's own folders is touched."""
        files, total = 0, 0
        for d in (self.renders, self.derived_dir, self.tmp_dir):
            if not os.path.lexists(d):
                continue
            _require_folder(d)
            for p in _plain_files(d):
                st = p.stat(follow_symlinks=False)
                if d == self.tmp_dir and time.time() - st.st_mtime < STALE_TMP_SECONDS:
                    continue
                p.unlink(missing_ok=True)
                files, total = files + 1, total + st.st_size
        return files, total

    def copy_out(self, key: str, target: Path) -> None:
        """A copy of a cached render elsewhere (e.g. grade's references/), atomically."""
        with atomic_output(target) as tmp:
            shutil.copyfile(self.exr(key), tmp)


@dataclass
class _Entry:
    paths: list[Path]
    size: int
    used: float  # the newest mtime of its files: info() and derived() touch them on use


def parse_size(text: str) -> int:
    """'2GB', '500 MB', '1e9' -> bytes (decimal units, as `rtval cache` prints them)."""
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?(?:[eE][0-9]+)?)\s*([kKmMgGtT]?)[bB]?\s*", text)
    if not m:
        raise ValueError(f"expected a size such as 2GB or 500MB, got {text!r}")
    n = float(m.group(1)) * 1000 ** " kmgt".index(m.group(2).lower() or " ")
    if not math.isfinite(n) or n < 0 or n > 1e18:
        raise ValueError(f"expected a size from 0 to 1000 PB, got {text!r}")
    return int(n)


def _is_plain_file(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def _is_folder(path: Path) -> bool:
    try:
        return stat.S_ISDIR(os.lstat(path).st_mode)
    except OSError:
        return False


def _require_folder(path: Path) -> None:
    """A cache folder is a real folder (safe_paths.require_folder), named as the cache's."""
    try:
        require_folder(path)
    except UnsafePathError as e:
        raise CacheError(f"render cache {e} (remove it, or use another --cache)") from None


def _plain_files(folder: Path) -> list[Path]:
    if not _is_folder(folder):
        return []
    with os.scandir(folder) as it:
        return [Path(e.path) for e in it if e.is_file(follow_symlinks=False)]


def _touch(path: Path) -> None:
    with contextlib.suppress(OSError):
        os.utime(path, follow_symlinks=False)


@contextlib.contextmanager
def _locked(path: Path, *, shared: bool = False) -> Iterator[None]:
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH if shared else fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)
