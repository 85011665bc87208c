"""What a path is, before anything reads or replaces it.

Inputs are read only from regular files, with a bound on their size: a FIFO would block
forever, a device (or a symlink to /dev/zero) would feed bytes without end. Outputs only
ever replace regular files: renaming a temporary file over /dev/null or /dev/full would turn
a device into a file. An output that is also an input, or twice an output, is refused.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path


class UnsafePathError(OSError):
    """A path that is not what it must be (an OSError: rtval exits 4 on it)."""


class OutputClashError(ValueError):
    """An output equal to an input or to another output (a usage error: rtval exits 64)."""


def describe_mode(mode: int) -> str:
    """A file type in words, for error messages."""
    for test, name in (
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISREG, "a regular file"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def check_regular_input(path: str | Path, *, max_bytes: int | None = None) -> os.stat_result:
    """The stat of ``path`` (symlinks followed) if it is a regular file of at most
    ``max_bytes``; UnsafePathError naming the path otherwise."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise UnsafePathError(f"{path}: no such file") from None
    except OSError as e:
        raise UnsafePathError(f"{path}: cannot read: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise UnsafePathError(f"{path}: is {describe_mode(st.st_mode)}, not a regular file")
    if max_bytes is not None and st.st_size > max_bytes:
        raise UnsafePathError(f"{path}: {st.st_size} bytes, more than the {max_bytes} allowed")
    return st


def read_bounded(path: str | Path, max_bytes: int) -> bytes:
    """The bytes of a regular file of at most ``max_bytes``, never blocking on a FIFO (the
    file is opened non-blocking and checked again after opening, against a swap)."""
    check_regular_input(path, max_bytes=max_bytes)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise UnsafePathError(f"{path}: cannot open: {e.strerror}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise UnsafePathError(f"{path}: is {describe_mode(st.st_mode)}, not a regular file")
        chunks: list[bytes] = []
        total = 0
        while True:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > max_bytes:  # grew while we read
                raise UnsafePathError(f"{path}: more than the {max_bytes} bytes allowed")
        return b"".join(chunks)
    finally:
        os.close(fd)


def check_output_target(path: str | Path) -> None:
    """Refuses to replace anything but a regular file (a missing file is fine). A symbolic
    link is refused too: renaming over it would silently cut it, not write through it."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as e:
        raise UnsafePathError(f"{path}: cannot write: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise UnsafePathError(
            f"{path}: is {describe_mode(st.st_mode)}; outputs only ever replace regular files"
        )


def _identity(path: str | Path) -> tuple[str, object]:
    """Two paths name the same file when their (device, inode) agree, or, for files that do
    not exist yet, when their resolved paths agree."""
    p = Path(path)
    try:
        st = os.stat(p)
        return ("inode", (st.st_dev, st.st_ino))
    except OSError:
        return ("path", str(p.resolve()))


def check_outputs_distinct(
    outputs: Iterable[tuple[str, str | Path | None]],
    inputs: Iterable[tuple[str, str | Path | None]],
) -> None:
    """Each (option, path) output must differ from every input and every other output;
    OutputClashError naming both options otherwise. None entries are skipped."""
    seen: dict[tuple[str, object], str] = {}
    for option, p in inputs:
        if p is not None:
            seen.setdefault(_identity(p), option)
    for option, p in outputs:
        if p is None:
            continue
        ident = _identity(p)
        if ident in seen:
            raise OutputClashError(
                f"{p}: {option} names the same file as {seen[ident]}; "
                "refusing to overwrite an input or to write one file twice"
            )
        seen[ident] = option
        check_output_target(p)


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


def write_text_checked(path: Path, text: str) -> None:
    """Leaves `path` holding exactly `text`: what is there is read (never through a link) and
    written again when it differs, a planted link removed first (files a render is made from)."""
    data = text.encode("utf-8")
    try:
        if not path.is_symlink() and read_bounded(path, len(data) + 1) == data:
            return
    except OSError:
        pass
    if path.is_symlink():
        path.unlink()
    write_atomic(path, data)


def write_atomic(path: str | Path, data: str | bytes, *, durable: bool = True) -> None:
    """Writes to a temporary sibling, then renames: readers never see half a file. The
    sibling's name is unique (mkstemp), so two processes writing one path never share it;
    only a regular file is replaced, and the temporary file goes on every error. `durable`:
    on disk before the rename (not needed where a reader checks what it reads)."""
    raw = data.encode("utf-8") if isinstance(data, str) else data
    with atomic_output(path) as tmp, open(tmp, "wb") as f:
        f.write(raw)
        f.flush()
        if durable:
            os.fsync(f.fileno())  # a full disk shows here, before the rename


def require_folder(path: str | Path, *, missing_ok: bool = False) -> None:
    """`path` is a real folder (or absent, with missing_ok): a symbolic link, a device or a
    file where a command writes or deletes would send its work elsewhere."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        if missing_ok:
            return
        raise UnsafePathError(f"{path}: no such folder") from None
    except OSError as e:
        raise UnsafePathError(f"{path}: cannot use: {e.strerror}") from None
    if not stat.S_ISDIR(mode):
        link = ": rtval never follows links (remove it)" if stat.S_ISLNK(mode) else ""
        raise UnsafePathError(f"{path}: is {describe_mode(mode)}, not a folder{link}")


def own_folder(root: Path, *parts: str) -> Path:
    """root/parts..., each component made if missing and refused if it is a link or not a
    folder: `rtval grade --out` may lie inside the submissions, where a student can plant
    `OUT/students/bob -> /victim`. `parts` are names rtval made (slugs), never a path; `root`
    is the user's own choice, link or not."""
    path = root
    for part in parts:
        if not part or part in (".", "..") or "/" in part or "\0" in part:
            raise ValueError(f"{part!r}: not a folder name")
        path = path / part
        try:
            os.mkdir(path)
        except FileExistsError:
            pass
        except OSError as e:
            raise UnsafePathError(f"{path}: cannot make the folder: {e.strerror}") from None
        require_folder(path)
    return path
