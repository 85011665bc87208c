"""A generated hostile class for `rtval grade`: every kind of entry a submissions folder
can hold that is not a plain image, plus names that attack the CSV, the HTML and the disk.
Returns, per gradebook id, what the row must say."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from compare.judge.images import read_image
from compare.judge.png import write_png

LONG_STEM = "a" * 251  # + ".exr": a 255-byte name, the longest most file systems allow
NON_UTF8 = b"caf\xe9.exr"  # Latin-1 e-acute: not UTF-8
HTML_NAME = "<img src=x onerror=alert(1)>"  # no '/': it must be a legal file name


@dataclass(frozen=True)
class Expect:
    reason: str | None  # a substring of the row's reasons; None: graded normally (no reason)
    status: str | None = None  # the row's status when it is pinned
    csv_cell: str | None = None  # what a CSV reader must read back as the student cell


@contextlib.contextmanager
def _cwd(folder: Path) -> Iterator[None]:
    old = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(old)


def make_hostile_class(reference: Path, folder: Path) -> dict[str, Expect]:
    """Writes the class into ``folder`` (which must exist, empty); returns id -> Expect.
    Hidden entries and the output folder get no row: they are not in the result."""
    ref = read_image(reference).rgb
    expected: dict[str, Expect] = {}

    shutil.copyfile(reference, folder / "good.exr")
    expected["good"] = Expect(None, "pass")

    os.mkfifo(folder / "fifo.ppm")
    expected["fifo"] = Expect("is a FIFO, not a regular file", "fail")
    with _cwd(folder):  # AF_UNIX paths are limited to ~108 bytes: bind a relative name
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.bind("sock.png")
        sock.close()  # the socket file stays
    expected["sock"] = Expect("is a socket, not a regular file", "fail")

    os.symlink(reference, folder / "linkref.exr")  # would pass, 100, if followed
    expected["linkref"] = Expect("is a symbolic link", "fail")
    os.symlink("/etc", folder / "etcdir")
    expected["etcdir"] = Expect("is a symbolic link (to /etc)", "fail")
    os.symlink("/dev/zero", folder / "zero.ppm")
    expected["zero"] = Expect("is a symbolic link (to /dev/zero)", "fail")
    os.symlink(folder / "nowhere.png", folder / "dangling.png")
    expected["dangling"] = Expect("is a symbolic link", "fail")

    shutil.copyfile(reference, folder / f"{LONG_STEM}.exr")
    expected[LONG_STEM] = Expect(None, "pass")
    shutil.copyfile(reference, os.path.join(os.fsencode(folder), NON_UTF8))
    expected["caf\\xe9"] = Expect("is not UTF-8", "fail")

    dim = np.clip(ref, 0, 1).astype(np.float32)
    for stem in ("=1+2", "+cmd", "@SUM(1+1)", "-2+3", "\tTAB"):
        write_png(folder / f"{stem}.png", dim)
        expected[stem] = Expect(None, csv_cell="'" + stem)
    write_png(folder / f"{HTML_NAME}.png", dim)
    expected[HTML_NAME] = Expect(None)

    shutil.copyfile(reference, folder / "alice.exr")
    write_png(folder / "alice.png", dim)
    expected["alice"] = Expect("2 submissions for one id (alice.exr, alice.png)", "fail")

    shutil.copyfile(reference, folder / ".hidden.exr")  # a notice, no row
    return expected
