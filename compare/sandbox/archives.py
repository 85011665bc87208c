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

import bz2
import gzip
import hashlib
import io
import lzma
import os
import stat
import tarfile
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO, cast

from compare.sandbox.trees import Node, TreeError, open_regular, walk

__all__ = ["TreeError", "TreeLimits", "archive_suffix", "copy_tree", "source_digest", "unpack"]
from compare.sizes import human_size
from compare.student_ids import displayable
from safe_files.paths import describe_mode

ARCHIVE_SUFFIXES = (".zip", ".tar.gz", ".tgz", ".tar")
ELF_MAGIC = b"\x7fELF"
CHUNK = 1 << 20


@dataclass(frozen=True)
class TreeLimits:
    max_bytes: int = 64 << 20  # all files of a submission together, unpacked
    max_entries: int = 10_000  # files and folders
    max_depth: int = 32  # folders inside folders
    max_built: int = 512 << 20  # what a build may leave in the folder (objects, the program)
    max_path: int = 1024  # bytes of a path inside the tree: far below PATH_MAX wherever it lies
    max_header: int = 4096  # bytes of a tar long-name or pax header


def archive_suffix(name: str) -> str | None:
    """The archive suffix of a file name (.zip, .tar.gz, .tgz, .tar), or None."""
    low = name.lower()
    return next((s for s in ARCHIVE_SUFFIXES if low.endswith(s) and len(low) > len(s)), None)


def _shown(name: str) -> str:
    """A name for a reason: cut first (a name may be megabytes), then made displayable."""
    return displayable(name[:200])


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
        self.refuse_binaries = False
        self.links: list[tuple[str, str]] = []  # (path, target) of the links a build made
        dest.mkdir(mode=0o755)

    def _count(self, parts: list[str], name: str) -> Path:
        self.entries += 1
        if self.entries > self.limits.max_entries:
            raise TreeError(f"more than {self.limits.max_entries} files and folders")
        if len(parts) > self.limits.max_depth:
            raise TreeError(f"{_shown(name)!r} is nested over {self.limits.max_depth} folders deep")
        if sum(len(os.fsencode(p)) + 1 for p in parts) > self.limits.max_path:
            raise TreeError(f"{_shown(name)!r}: a path over {self.limits.max_path} bytes")
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
            first = True
            while chunk := data.read(CHUNK):
                if first and self.refuse_binaries and chunk.startswith(ELF_MAGIC):
                    raise TreeError(
                        f"{_shown(name)!r} is a prebuilt program (an ELF file): hand in the "
                        "source only (the teacher may pass --allow-binaries)"
                    )
                first = False
                self.bytes += len(chunk)
                if self.bytes > self.max_bytes:
                    raise TreeError(self.too_large())
                out.write(chunk)
        os.chmod(path, 0o755 if executable else 0o644)

    def link(self, parts: list[str], target: str) -> None:
        """A symbolic link made by a build: never made outside a sandbox, only listed, so
        that nothing reading OUT (zip -r, cp -L, a web server) can follow it."""
        self._count(parts, "/".join(parts))
        self.links.append(("/".join(parts), target))

    def too_large(self) -> str:
        return f"more than {human_size(self.max_bytes)} of files"


def unpack(
    archive: Path, dest: Path, limits: TreeLimits = TreeLimits(), *, binaries: bool = True
) -> None:
    """Unpacks a .zip or .tar(.gz) into the new folder dest; TreeError says why not (no ELF
    file inside unless binaries)."""
    suffix = archive_suffix(archive.name)
    staging = dest.with_name(dest.name + ".unpacking")
    writer = _Writer(staging, limits)
    writer.refuse_binaries = not binaries
    try:
        if suffix == ".zip":
            _unzip(archive, writer)
        else:
            _prescan_tar(archive, limits)
            _untar(archive, writer)
    except (
        zipfile.BadZipFile,
        tarfile.TarError,
        zlib.error,
        EOFError,
        OSError,
        lzma.LZMAError,
    ) as e:
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


def _prescan_tar(archive: Path, limits: TreeLimits) -> None:
    """Reads the tar's headers before tarfile does: a GNU long-name or pax header is read
    whole into memory by tarfile, so one declaring 512 MiB is refused here, having read 512
    bytes of it; and the whole stream, decompressed, may not be much larger than what it may
    unpack to. So any archive costs at most about max_bytes of decompression."""
    budget = limits.max_bytes + 1024 * limits.max_entries + (1 << 20)
    done = 0
    with _decompressed(archive) as f:
        while True:
            header = f.read(512)
            if len(header) < 512 or header == bytes(512):
                return  # the end (tarfile says what is wrong with a cut one)
            size, kind = _field_size(header[124:136]), header[156:157]
            if kind and kind in b"LKxgX" and size > limits.max_header:
                what = "long-name" if kind in b"LK" else "pax"
                raise TreeError(
                    f"a tar {what} header of {human_size(size)}, more than the "
                    f"{limits.max_header} bytes allowed"
                )
            done += 512 + (size + 511) // 512 * 512
            if done > budget:
                raise TreeError(
                    f"the archive unpacks to more than {human_size(limits.max_bytes)} (a bomb?)"
                )
            left = (size + 511) // 512 * 512
            while left > 0:
                chunk = f.read(min(left, CHUNK))
                if not chunk:
                    return
                left -= len(chunk)


def _decompressed(archive: Path) -> io.BufferedIOBase:
    """The archive's tar stream, as tarfile's "r:*" would find it."""
    with archive.open("rb") as f:
        magic = f.read(6)
    if magic.startswith(b"\x1f\x8b"):
        return gzip.open(archive, "rb")
    if magic.startswith(b"BZh"):
        return bz2.open(archive, "rb")
    if magic.startswith(b"\xfd7zXZ\x00"):
        return lzma.open(archive, "rb")
    return cast(io.BufferedIOBase, archive.open("rb"))


def _field_size(field: bytes) -> int:
    """A tar header's size field: octal text, or base-256 when its first bit is set."""
    if field[:1] and field[0] & 0x80:
        return int.from_bytes(field[1:], "big")
    text = field.split(b"\0", 1)[0].strip()
    try:
        return int(text or b"0", 8)
    except ValueError:
        raise TreeError("not a valid tar archive: a header's size is not a number") from None


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
    binaries: bool = True,
) -> list[tuple[str, str]]:
    """Copies a folder into the new folder dest, never following a link, at any depth
    without recursion (compare/sandbox/trees.py). A student's folder (built=False) may hold
    only folders and regular files, and no ELF file unless binaries; a built tree (what a
    build left) has its symbolic links listed, not made, and its FIFOs, sockets and devices
    dropped. Returns the links as (path, target)."""
    writer = _Writer(dest, limits, limits.max_built if built else None)
    writer.refuse_binaries = not binaries
    nodes = list(walk(src, limits.max_depth, limits.max_entries))  # at most max_entries
    declared = sum(n.st.st_size for n in nodes if stat.S_ISREG(n.st.st_mode))
    if declared > writer.max_bytes:  # said before a byte is written (sparse files too)
        raise TreeError(
            f"{human_size(declared)} of files, more than {human_size(writer.max_bytes)}"
        )
    for node in walk(src, limits.max_depth, limits.max_entries):
        _copy_node(node, writer, built)
    return writer.links


def _copy_node(node: Node, writer: _Writer, built: bool) -> None:
    mode = node.st.st_mode
    parts = list(node.parts)
    if stat.S_ISDIR(mode):
        writer.folder(parts, node.rel)
    elif stat.S_ISREG(mode):
        with os.fdopen(open_regular(node), "rb") as data:
            writer.file(parts, node.rel, data, bool(mode & 0o111))
    elif stat.S_ISLNK(mode) and built:
        writer.link(parts, os.readlink(node.name, dir_fd=node.dir_fd))
    elif not built:
        what = describe_mode(mode)
        if stat.S_ISLNK(mode):
            what += f" (to {_shown(os.readlink(node.name, dir_fd=node.dir_fd))})"
        raise TreeError(f"{_shown(node.rel)!r} is {what}; hand in plain files only")


def source_digest(path: Path, limits: TreeLimits = TreeLimits()) -> str:
    """A content hash of a submission (an archive's bytes, a folder's names, kinds, modes and
    contents), read within the limits: what keys a build, so that an unchanged program is
    never rebuilt."""
    h = hashlib.sha256()
    try:
        st = os.lstat(path)
        if stat.S_ISDIR(st.st_mode):
            _digest_folder(path, h, limits)
        elif stat.S_ISREG(st.st_mode) and st.st_size <= 4 * limits.max_bytes:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
            with os.fdopen(fd, "rb") as f:
                while chunk := f.read(CHUNK):
                    h.update(chunk)
        else:  # unpacking will refuse it; its size and time still tell a change
            h.update(f"{st.st_mode} {st.st_size} {st.st_mtime_ns}".encode())
    except (OSError, TreeError) as e:  # copying will say why; the key just has to differ
        h.update(f"unreadable: {e}".encode())
    return h.hexdigest()[:24]


def _digest_folder(folder: Path, h: hashlib._Hash, limits: TreeLimits) -> None:
    """Names, kinds, modes and contents, within the depth and entry limits (TreeError past
    them: the digest then says so) and reading at most max_bytes of contents."""
    budget = limits.max_bytes + 1
    for node in walk(folder, limits.max_depth + 1, limits.max_entries + 1):
        mode = node.st.st_mode
        h.update(f"{len(node.parts)} ".encode() + os.fsencode(node.name) + b"\0")
        h.update(f"{stat.S_IFMT(mode)} {mode & 0o111}".encode())
        if stat.S_ISREG(mode) and budget > 0:
            budget -= node.st.st_size
            with os.fdopen(open_regular(node), "rb") as f:
                while chunk := f.read(CHUNK):
                    h.update(chunk)
        elif stat.S_ISLNK(mode):
            h.update(os.fsencode(os.readlink(node.name, dir_fd=node.dir_fd)))
