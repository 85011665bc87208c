"""Folders a command makes inside its output folder, never through a planted link.

`rtval grade --out` may lie inside the submissions folder, where a student can plant
`OUT/students/bob -> /victim` or `OUT/references -> ~`. Every folder below the output
folder is made here, one component at a time, and checked without following links: an
existing link, or anything that is not a folder, is refused with an error naming it (an
OSError: rtval exits 4). The output folder itself is named on the command line and is the
user's choice, link or not.
"""

from __future__ import annotations

import contextlib
import os
import stat
from pathlib import Path

from scene_model.safe_paths import UnsafePathError, describe_mode


def own_folder(root: Path, *parts: str) -> Path:
    """root/parts..., each component made if missing and refused if it is a symbolic link
    or not a folder. `parts` are names made by rtval (slugs), never a path."""
    path = root
    for part in parts:
        if not part or part in (".", "..") or "/" in part or "\0" in part:
            raise ValueError(f"{part!r}: not a folder name")
        path = path / part
        with contextlib.suppress(FileExistsError):
            os.mkdir(path)
        try:
            mode = os.lstat(path).st_mode
        except OSError as e:
            raise UnsafePathError(f"{path}: cannot make the folder: {e.strerror}") from None
        if stat.S_ISLNK(mode):
            raise UnsafePathError(
                f"{path}: is a symbolic link; rtval writes only into folders it made itself "
                "(remove the link)"
            )
        if not stat.S_ISDIR(mode):
            raise UnsafePathError(f"{path}: is {describe_mode(mode)}, not a folder")
    return path
