"""compare/sandbox/archives.py: a submission's archive is refused with a short, displayable
reason before any large header or stream is read: GNU long names and pax headers over 4 KiB,
streams that decompress past the unpack limit, names of any length or content, prebuilt
programs."""

from __future__ import annotations

import gzip
import io
import shutil
import tarfile
import zipfile
from pathlib import Path

import pytest

from compare.sandbox.archives import TreeError, TreeLimits, unpack


def _header(name: bytes, size: int, kind: bytes) -> bytes:
    h = bytearray(512)
    h[: len(name)] = name
    h[100:108] = b"0000644\0"
    h[124:136] = b"%011o\0" % size
    h[156:157] = kind
    h[257:263] = b"ustar "
    h[148:156] = b"        "
    h[148:156] = b"%06o\0 " % sum(h)
    return bytes(h)


@pytest.mark.parametrize(
    ("kind", "what"), [(b"L", "long-name"), (b"K", "long-name"), (b"x", "pax"), (b"g", "pax")]
)
def test_big_name_headers_are_refused_before_they_are_read(
    tmp_path: Path, kind: bytes, what: str
) -> None:
    archive = tmp_path / "s.tar.gz"
    archive.write_bytes(gzip.compress(_header(b"././@LongLink", 512 << 20, kind) + bytes(4096)))
    with pytest.raises(TreeError, match=f"a tar {what} header of 512 MiB"):
        unpack(archive, tmp_path / "dest")
    assert not (tmp_path / "dest").exists()


def test_a_stream_that_decompresses_past_the_limit_is_refused(tmp_path: Path) -> None:
    archive = tmp_path / "bomb.tar.gz"
    with gzip.open(archive, "wb") as f:  # one member declaring 3 MiB, in a 1 MiB limit
        f.write(_header(b"zeros", 3 << 20, b"0") + bytes(3 << 20))
    with pytest.raises(TreeError, match="unpacks to more than 1 MiB"):
        unpack(archive, tmp_path / "dest", TreeLimits(max_bytes=1 << 20, max_entries=10))


def test_names_are_cut_before_they_are_shown(tmp_path: Path) -> None:
    archive = tmp_path / "s.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("\x1b[2J" + "../" * 20_000 + "evil", "x")
    with pytest.raises(TreeError) as e:
        unpack(archive, tmp_path / "dest")
    assert len(str(e.value)) < 400 and "\x1b" not in str(e.value) and "\\x1b" in str(e.value)


def test_prebuilt_programs_only_when_allowed(tmp_path: Path) -> None:
    archive = tmp_path / "s.tar"
    with tarfile.open(archive, "w") as t:
        t.add("/bin/true", "bin/helper")
        info = tarfile.TarInfo("main.c")
        info.size = 3
        t.addfile(info, io.BytesIO(b"x;\n"))
    with pytest.raises(TreeError, match="'bin/helper' is a prebuilt program"):
        unpack(archive, tmp_path / "refused", binaries=False)
    unpack(archive, tmp_path / "allowed", binaries=True)
    assert (tmp_path / "allowed" / "bin" / "helper").stat().st_size > 0
    shutil.rmtree(tmp_path / "allowed")
