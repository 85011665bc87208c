"""Small file helpers shared by every part of compare: atomic writes, content hashes, JSON."""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import tempfile
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from compare.safe_paths import check_output_target


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yields a fresh temporary sibling of ``path`` to write; on success renames it over
    ``path``. Only a regular file (or nothing) is ever replaced, and the temporary file is
    removed on every error (a full disk included): no partial file ever remains."""
    p = Path(path)
    check_output_target(p)
    fd, name = tempfile.mkstemp(prefix=f".{p.name[:100]}.", suffix=".tmp", dir=p.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        check_output_target(p)  # again: it may have changed while we wrote
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; outputs are ordinary files
        tmp.replace(p)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Writes to a temporary sibling, then renames: readers never see half a file. The
    sibling's name is unique (mkstemp), so two processes writing one path never share it;
    only a regular file is replaced, and the temporary file goes on every error."""
    raw = data.encode("utf-8") if isinstance(data, str) else data
    with atomic_output(path) as tmp, open(tmp, "wb") as f:
        f.write(raw)
        f.flush()
        os.fsync(f.fileno())  # a full disk shows here, before the rename


def unique_sibling(path: Path) -> Path:
    """A temporary name beside `path` that no other process or thread uses, for a file a
    renderer writes itself (the render cache's renders in progress)."""
    return path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")


def sha256_file(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def json_safe(x: Any) -> Any:
    """NaN and Inf are not JSON: write them as null."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    return x
