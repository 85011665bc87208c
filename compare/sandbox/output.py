"""Reading back what a sandboxed program wrote: each folder on the way opened without
following a link, the file a regular one of a size bounded by the image it should hold. Used by
program grading (compare/grading/programs.py) and `check --renderer --sandbox`
(compare/render/foreign_sandboxed.py)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from compare.sizes import human_size
from compare.student_ids import displayable
from safe_files.paths import describe_mode


# How each format a program may write begins; the image is decoded only as the format its
# name says (never by what its bytes claim: a TIFF or an EPS named classic.ppm is a reason).
def output_cap(width: int, height: int) -> int:
    """The largest output a width x height image may be: 64 bytes a pixel (16 float channels:
    an EXR with its AOVs), at least 1 MiB."""
    return max(1 << 20, 64 * width * height)


def read_output(root: Path, rel: str, width: int, height: int) -> tuple[str, bytes]:
    """(problem, bytes) of the image the program wrote at root/rel. Each folder on the way is
    opened without following a link, and the file must be a regular one of a bounded size:
    a link to /etc/passwd, a FIFO or a 10 GB file are reasons, never read."""
    parts = rel.split("/")
    try:  # the folder itself may have been swapped for a link by the program
        fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError:
        return f"no output: its folder {root.name}/ is not a folder", b""
    try:
        for part in parts[:-1]:
            try:
                nfd = os.open(part, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW, dir_fd=fd)
            except FileNotFoundError:
                return f"no output: the program wrote no {rel}", b""
            except OSError:
                return f"output is not a regular file: {part}/ is not a folder", b""
            os.close(fd)
            fd = nfd
        return _read_regular(fd, parts[-1], rel, output_cap(width, height))
    finally:
        os.close(fd)


def _read_regular(dir_fd: int, name: str, rel: str, cap: int) -> tuple[str, bytes]:
    try:
        st = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except FileNotFoundError:
        return f"no output: the program wrote no {rel}", b""
    if stat.S_ISLNK(st.st_mode):
        target = os.readlink(name, dir_fd=dir_fd)
        shown = displayable(target[:200])
        return f"output is not a regular file: {rel} is a symbolic link (to {shown})", b""
    if not stat.S_ISREG(st.st_mode):
        return f"output is not a regular file: {rel} is {describe_mode(st.st_mode)}", b""
    if st.st_size > cap:
        return (
            f"output too large: {rel} is {human_size(st.st_size)}, at most {human_size(cap)} "
            "for this image size",
            b"",
        )
    fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK, dir_fd=dir_fd)
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            return f"output is not a regular file: {rel}", b""
        data = f.read(cap + 1)
    if len(data) > cap:
        return f"output too large: {rel} is over {human_size(cap)}", b""
    return "", data
