"""A student's program as a tree of plain files: a folder copied, or a .zip / .tar.gz unpacked,
safely.

Nothing a student hands in may point or reach outside its own tree: an entry with an absolute
name or a '..' component, a symbolic or hard link, a device or a FIFO is refused with a reason,
as is a tree over the limits of total size and number of entries (a zip bomb says so before
anything is written: the sizes its directory declares are added up first, and what is really
unpacked is counted again, since a directory may lie). An archive that holds one folder and
nothing else (alice.zip -> alice/...) is unpacked as that folder's contents.

Reasons are sentences for a gradebook row; names in them are made displayable.
"""

from __future__ import annotations

import hashlib
import os
import stat
import tarfile
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from compare.sizes import human_size
from compare.student_ids import displayable_name
from safe_files.paths import describe_mode

ARCHIVE_SUFFIXES = (".zip", ".tar.gz", ".tgz", ".tar")
CHUNK = 1 << 20


class TreeError(ValueError):
    """A submission that cannot become a tree of plain files; the message is the reason."""


@dataclass(frozen=True)
class TreeLimits:
    max_bytes: int = 64 << 20  # all files of a submission together, unpacked
    max_entries: int = 10_000  # files and folders
    max_depth: int = 32  # folders inside folders
    max_built: int = 512 << 20  # what a build may leave in the folder (objects, the program)


def archive_suffix(name: str) -> str | None:
    """The archive suffix of a file name (.zip, .tar.gz, .tgz, .tar), or None."""
    low = name.lower()
    return next((s for s in ARCHIVE_SUFFIXES if low.endswith(s) and len(low) > len(s)), None)


def _shown(name: str) -> str:
    return displayable_name(name)[0][:200]


def _parts(name: str) -> list[str]:
    """The components of an archive entry's name, refused when it could leave the tree."""
    if "\x00" in name or "\\" in name:
        raise TreeError(f"archive entry {_shown(name)!r}: a name with a NUL or a backslash")
    if name.startswith("/"):
        raise TreeError(f"archive entry {_shown(name)!r} is an absolute path")
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if ".." in parts:
        raise TreeError(f"archive entry {_shown(name)!r} escapes its folder ('..')")
    if any(len(os.fsencode(p)) > 255 for p in parts):
        raise TreeError(f"archive entry {_shown(name)!r}: a name over 255 bytes")
    return parts


class _Writer:
    """Creates the tree in a fresh folder, counting what it writes against the limits. Only
    real folders and files are made there, so no later entry can follow a link out."""

    def __init__(self, dest: Path, limits: TreeLimits, max_bytes: int | None = None) -> None:
        self.dest = dest
        self.limits = limits
        self.max_bytes = max_bytes or limits.max_bytes
        self.bytes = 0
        self.entries = 0
        dest.mkdir(mode=0o755)

    def _count(self, parts: list[str], name: str) -> Path:
        self.entries += 1
        if self.entries > self.limits.max_entries:
            raise TreeError(f"more than {self.limits.max_entries} files and folders")
        if len(parts) > self.limits.max_depth:
            raise TreeError(f"{_shown(name)!r} is nested over {self.limits.max_depth} folders deep")
        return self.dest.joinpath(*parts)

    def folder(self, parts: list[str], name: str) -> None:
        if not parts:
            return
        path = self._count(parts, name)
        try:
            path.mkdir(mode=0o755, parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise TreeError(f"{_shown(name)!r} is both a file and a folder") from None

    def file(self, parts: list[str], name: str, data: IO[bytes], executable: bool) -> None:
        if not parts:
            raise TreeError(f"entry {_shown(name)!r} has no name")
        path = self._count(parts, name)
        try:
            path.parent.mkdir(mode=0o755, parents=True, exist_ok=True)
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        except FileExistsError:
            raise TreeError(f"{_shown(name)!r} appears twice") from None
        except NotADirectoryError:
            raise TreeError(f"{_shown(name)!r} is inside a file") from None
        with os.fdopen(fd, "wb") as out:
            while chunk := data.read(CHUNK):
                self.bytes += len(chunk)
                if self.bytes > self.max_bytes:
                    raise TreeError(self.too_large())
                out.write(chunk)
        os.chmod(path, 0o755 if executable else 0o644)

    def link(self, parts: list[str], target: str) -> None:
        """A symbolic link made by a build (kept as a link: it only resolves in a sandbox)."""
        os.symlink(target, self._count(parts, target))

    def too_large(self) -> str:
        return f"more than {human_size(self.max_bytes)} of files"


def unpack(archive: Path, dest: Path, limits: TreeLimits = TreeLimits()) -> None:
    """Unpacks a .zip or .tar(.gz) into the new folder dest; TreeError says why not."""
    suffix = archive_suffix(archive.name)
    staging = dest.with_name(dest.name + ".unpacking")
    writer = _Writer(staging, limits)
    try:
        if suffix == ".zip":
            _unzip(archive, writer)
        else:
            _untar(archive, writer)
    except (zipfile.BadZipFile, tarfile.TarError, zlib.error, EOFError) as e:
        raise TreeError(f"not a valid {suffix} archive: {e}") from None
    except (RuntimeError, NotImplementedError) as e:  # encrypted, unknown compression
        raise TreeError(f"cannot unpack this {suffix} archive: {e}") from None
    _move_contents(staging, dest)


def _unzip(archive: Path, writer: _Writer) -> None:
    with zipfile.ZipFile(archive) as zf:
        infos = zf.infolist()
        if len(infos) > writer.limits.max_entries:
            raise TreeError(f"{len(infos)} entries, more than {writer.limits.max_entries}")
        declared = sum(i.file_size for i in infos)
        if declared > writer.max_bytes:
            raise TreeError(
                f"the archive unpacks to {human_size(declared)}, more than the "
                f"{human_size(writer.max_bytes)} allowed (a zip bomb?)"
            )
        for info in infos:
            parts = _parts(info.filename)
            mode = info.external_attr >> 16
            kind = stat.S_IFMT(mode)
            if info.is_dir():
                writer.folder(parts, info.filename)
            elif kind in (0, stat.S_IFREG):  # 0: made on a system without Unix modes
                with zf.open(info) as data:
                    writer.file(parts, info.filename, data, bool(mode & 0o111))
            else:
                raise TreeError(f"archive entry {_shown(info.filename)!r} is {describe_mode(mode)}")


def _untar(archive: Path, writer: _Writer) -> None:
    with tarfile.open(archive, "r:*") as tar:
        for n, member in enumerate(tar):  # lazily: stops at the limit
            if n >= writer.limits.max_entries:
                raise TreeError(f"more than {writer.limits.max_entries} entries")
            parts = _parts(member.name)
            if member.isdir():
                writer.folder(parts, member.name)
            elif member.isreg():
                if writer.bytes + member.size > writer.max_bytes:
                    raise TreeError(
                        f"the archive unpacks to more than {human_size(writer.max_bytes)} (a bomb?)"
                    )
                data = tar.extractfile(member)
                assert data is not None  # a regular member always has data
                writer.file(parts, member.name, data, bool(member.mode & 0o111))
            else:
                what = "a link" if member.issym() or member.islnk() else "a device or a FIFO"
                raise TreeError(f"archive entry {_shown(member.name)!r} is {what}")


def _move_contents(staging: Path, dest: Path) -> None:
    """staging becomes dest; a lone folder inside (alice.zip -> alice/) becomes dest itself."""
    entries = os.listdir(staging)
    inner = staging / entries[0] if len(entries) == 1 else None
    if inner is not None and inner.is_dir() and not inner.is_symlink():
        inner.rename(dest)
        staging.rmdir()
    else:
        staging.rename(dest)


def copy_tree(
    src: Path,
    dest: Path,
    limits: TreeLimits = TreeLimits(),
    *,
    built: bool = False,
) -> None:
    """Copies a folder into the new folder dest, never following a link. A student's folder
    (built=False) may hold only folders and regular files; a built tree (what a build left in
    its sandbox) keeps its symbolic links as links and drops FIFOs, sockets and devices."""
    writer = _Writer(dest, limits, limits.max_built if built else None)
    _copy_into(src, [], writer, built)


def _copy_into(folder: Path, parts: list[str], writer: _Writer, built: bool) -> None:
    try:
        with os.scandir(folder) as it:
            entries = sorted(it, key=lambda e: e.name)
    except OSError as err:
        raise TreeError(f"cannot list {_shown('/'.join(parts) or '.')}: {err.strerror}") from None
    for e in entries:
        here = [*parts, e.name]
        name = "/".join(here)
        mode = e.stat(follow_symlinks=False).st_mode
        if stat.S_ISDIR(mode):
            writer.folder(here, name)
            _copy_into(Path(e.path), here, writer, built)
        elif stat.S_ISREG(mode):
            with _open_regular(Path(e.path), name) as data:
                writer.file(here, name, data, bool(mode & 0o111))
        elif stat.S_ISLNK(mode) and built:
            writer.link(here, os.readlink(e.path))
        elif not built:
            what = describe_mode(mode)
            if stat.S_ISLNK(mode):
                what += f" (to {_shown(os.readlink(e.path))})"
            raise TreeError(f"{_shown(name)!r} is {what}; hand in plain files only")


def _open_regular(path: Path, name: str) -> IO[bytes]:
    """Opens a file that must be regular, without following a link or blocking on a FIFO
    swapped in since the listing."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise TreeError(f"{_shown(name)!r} changed while it was copied")
    return os.fdopen(fd, "rb")


def source_digest(path: Path, limits: TreeLimits = TreeLimits()) -> str:
    """A content hash of a submission (an archive's bytes, a folder's names, kinds, modes and
    contents), read within the limits: what keys a build, so that an unchanged program is
    never rebuilt."""
    h = hashlib.sha256()
    try:
        st = os.lstat(path)
        if stat.S_ISDIR(st.st_mode):
            _digest_folder(path, h, [limits.max_bytes + 1, limits.max_entries + 1])
        elif stat.S_ISREG(st.st_mode) and st.st_size <= 4 * limits.max_bytes:
            with _open_regular(path, path.name) as f:
                while chunk := f.read(CHUNK):
                    h.update(chunk)
        else:  # unpacking will refuse it; its size and time still tell a change
            h.update(f"{st.st_mode} {st.st_size} {st.st_mtime_ns}".encode())
    except (OSError, TreeError) as e:  # copying will say why; the key just has to differ
        h.update(f"unreadable: {e}".encode())
    return h.hexdigest()[:24]


def _digest_folder(folder: Path, h: hashlib._Hash, budget: list[int]) -> None:
    with os.scandir(folder) as it:
        entries = sorted(it, key=lambda e: e.name)
    for e in entries:
        budget[1] -= 1
        if budget[1] < 0:
            return
        st = e.stat(follow_symlinks=False)
        h.update(
            os.fsencode(e.name) + b"\0" + f"{stat.S_IFMT(st.st_mode)} {st.st_mode & 0o111}".encode()
        )
        if stat.S_ISDIR(st.st_mode):
            h.update(b"{")
            _digest_folder(Path(e.path), h, budget)
            h.update(b"}")
        elif stat.S_ISREG(st.st_mode) and budget[0] > 0:
            budget[0] -= st.st_size
            with _open_regular(Path(e.path), e.name) as f:
                while chunk := f.read(CHUNK):
                    h.update(chunk)
        elif stat.S_ISLNK(st.st_mode):
            h.update(os.fsencode(os.readlink(e.path)))
