"""Walking trees that a student made, without recursion and without following a link.

A build or a run may leave a folder 2,500 levels deep, names of 255 bytes at every level, a
folder it made unreadable (chmod 0) or a million files. Every walk here is iterative (no
RecursionError), works from open folders (no path grows past PATH_MAX, no link is followed on
the way) and keeps a bounded number of descriptors open:

- walk() lists a tree within a depth and an entry budget (copying, digesting, size checks),
  holding one descriptor per level it is in, at most max_depth + 1;
- remove_tree() removes any tree, however deep, with two descriptors at a time: it climbs back
  through '..', checking that it arrives where it came from.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from compare.student_ids import displayable

_DIR_FLAGS = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC


class TreeError(ValueError):
    """A tree that cannot be taken as it is; the message is the reason, for a gradebook row."""


@dataclass(frozen=True)
class Node:
    """One entry met by walk(): its path parts below the root, its lstat, and its folder's
    descriptor (valid only until the walk moves on) to open it by name."""

    parts: tuple[str, ...]
    st: os.stat_result
    dir_fd: int

    @property
    def name(self) -> str:
        return self.parts[-1]

    @property
    def rel(self) -> str:
        return "/".join(self.parts)


def _open_dir(name: str, dir_fd: int | None) -> int:
    """A folder's descriptor; a folder made unreadable is given back its permissions first
    (only its owner, or root, gets that far)."""
    try:
        return os.open(name, _DIR_FLAGS, dir_fd=dir_fd)
    except PermissionError:
        with contextlib.suppress(OSError):
            os.chmod(name, 0o700, dir_fd=dir_fd)
        return os.open(name, _DIR_FLAGS, dir_fd=dir_fd)


def _listing(fd: int) -> list[str]:
    with os.scandir(fd) as it:
        return sorted(e.name for e in it)


def walk(root: Path, max_depth: int, max_entries: int) -> Iterator[Node]:
    """Every entry below root, parents before children, names sorted, never following a link.
    TreeError past max_depth folders deep or max_entries entries."""
    fd = _open_dir(str(root), None)
    stack: list[tuple[int, tuple[str, ...], Iterator[str]]] = [(fd, (), iter(_listing(fd)))]
    seen = 0
    try:
        while stack:
            dir_fd, parts, names = stack[-1]
            name = next(names, None)
            if name is None:
                os.close(dir_fd)
                stack.pop()
                continue
            seen += 1
            if seen > max_entries:
                raise TreeError(f"more than {max_entries} files and folders")
            here = (*parts, name)
            st = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
            yield Node(here, st, dir_fd)
            if stat.S_ISDIR(st.st_mode):
                if len(here) >= max_depth:
                    raise TreeError(f"folders nested over {max_depth} deep")
                child = _open_dir(name, dir_fd)
                stack.append((child, here, iter(_listing(child))))
    finally:
        for dir_fd, _, _ in stack:
            os.close(dir_fd)


def open_regular(node: Node) -> int:
    """A descriptor of a regular file met by walk(), refusing one swapped for a link, a FIFO
    or a device since the listing (never blocking on a FIFO)."""
    fd = os.open(node.name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK, dir_fd=node.dir_fd)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise TreeError(f"'{displayable(node.rel[:200])}' changed while it was read")
    return fd


def remove_tree(path: Path) -> None:
    """Removes path and everything below it, at any depth, never following a link out. Only
    what cannot be removed at all (another user's files) raises OSError."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    if not stat.S_ISDIR(st.st_mode):
        os.unlink(path)
        return
    parent = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        _empty(parent, path.name)
        os.rmdir(path.name, dir_fd=parent)
    finally:
        os.close(parent)


def _empty(parent: int, name: str) -> None:
    """Empties the folder `name` of `parent`: down into the first subfolder left, up through
    '..' once a folder is empty, so two descriptors are open however deep it goes."""
    fd = _open_dir(name, parent)
    path: list[tuple[str, tuple[int, int]]] = []  # (name, identity of its parent) going down
    try:
        while True:
            sub = _clear_files(fd)
            if sub is not None:
                me = os.fstat(fd)
                child = _open_dir(sub, fd)
                path.append((sub, (me.st_dev, me.st_ino)))
                os.close(fd)
                fd = child
                continue
            if not path:
                return
            sub, identity = path.pop()
            up = os.open("..", os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC, dir_fd=fd)
            os.close(fd)
            fd = up
            st = os.fstat(fd)
            if (st.st_dev, st.st_ino) != identity:  # moved under us: stop rather than guess
                raise OSError(f"{name}: a folder moved while it was removed")
            os.rmdir(sub, dir_fd=fd)
    finally:
        os.close(fd)


def _clear_files(fd: int) -> str | None:
    """Unlinks every non-folder in the folder; returns one subfolder to go into, or None."""
    if os.geteuid() != 0:  # an owner may need its own write permission back
        with contextlib.suppress(OSError):
            os.fchmod(fd, 0o700)
    with os.scandir(fd) as it:
        for e in it:
            if e.is_dir(follow_symlinks=False):
                return e.name
            with contextlib.suppress(FileNotFoundError):
                os.unlink(e.name, dir_fd=fd)
    return None
