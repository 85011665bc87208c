"""Small file helpers shared by the judge: atomic writes and content hashes."""

from __future__ import annotations

import hashlib
from pathlib import Path


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Writes to a temporary sibling, then renames: readers never see half a file."""
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    if isinstance(data, str):
        tmp.write_text(data, encoding="utf-8")
    else:
        tmp.write_bytes(data)
    tmp.replace(p)


def sha256_file(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
