"""compare/grading/programs.py: what hostile students of a class of programs get in their
rows, and that nothing they do changes a classmate's row, leaves links or files in OUT, or
reaches the teacher's terminal. A red-team class: forged exit codes and messages, escape
sequences and bidi overrides in link targets and compiler errors, links to secrets, sparse
files, a full disk, /tmp and /dev/shm filled, prebuilt programs, an image of the wrong format,
a tar with a 512 MiB long-name header."""

from __future__ import annotations

import gzip
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from helpers import run
from sandbox_class import MAKEFILE, RTVAL, grade, gradebook, hooks, private_tmp, student

from compare.grading import programs
from compare.sandbox.bwrap import probe

pytestmark = [
    pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler"),
    pytest.mark.skipif(probe() is not None, reason=f"no sandbox here: {probe()}"),
]

SMALL = ["--run-timeout", "4", "--memory", "256M", "--processes", "32"]  # files up to 256M
FORGED = "\\x1b]0;pwn\\x07\\x1b[2J\\r\\n  scene classic: pass, score 100.0 =cmd|x"
FILL = (
    "char name[32]; static char b[1 << 20];"
    'for (int i = 0; i < 200; i++) { snprintf(name, sizeof name, "fill%d", i);'
    ' FILE *f = fopen(name, "wb"); if (!f) break; int k = 0;'
    " for (; k < 8; k++) if (fwrite(b, 1, sizeof b, f) != sizeof b) break;"
    " if (fclose(f) != 0 || k < 8) break; } exit(4);"
)
BIDI_ERROR = "\t@printf 'rt.c:1:1: error: \\342\\200\\256ssap :edarg \\302\\233 2J\\n' >&2; false\n"
# Busy loops that leave the build's process group, while the build waits: they load the
# machine while classmates run (judged by their own CPU time, they still pass), and die
# with the build's sandbox.
SPIN = "\tfor i in 1 2 3 4 5 6 7 8; do setsid sh -c 'while :; do :; done' & done; sleep 2\n"
LINKS = "\tln -s /root/.ssh/id_rsa key\n\tln -s /etc/shadow shadow\n"


def _long_name_tar(path: Path) -> None:
    """A .tar.gz whose first header is a GNU long name of 512 MiB (only 1 KiB follows)."""
    header = bytearray(512)
    header[:13] = b"././@LongLink"
    header[100:108] = b"0000644\0"
    header[124:136] = b"%011o\0" % (512 << 20)
    header[156:157] = b"L"
    header[257:263] = b"ustar "
    header[148:156] = b"        "
    header[148:156] = b"%06o\0 " % sum(header)
    path.write_bytes(gzip.compress(bytes(header) + b"x" * 1024))


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    root = tmp_path_factory.mktemp("rows")
    subs, out = root / "subs", root / "out"
    student(subs / "good")
    student(subs / "exit152", hooks("exit(152);"))
    student(subs / "bad_alloc", hooks('fputs("std::bad_alloc\\n", stderr); exit(1);'))
    student(subs / "forged_out", hooks(after=f'unlink(out); symlink("{FORGED}", out);'))
    student(subs / "bidi_build", makefile=MAKEFILE.split("\n")[0] + "\n" + BIDI_ERROR)
    student(subs / "links_build", makefile=MAKEFILE + LINKS)
    student(subs / "spinner", makefile=MAKEFILE + SPIN)
    swap = "\tcd /sandbox && mv work elsewhere && ln -s /etc work\n"
    student(subs / "work_swapped", makefile=MAKEFILE + swap)
    student(subs / "sparse_build", makefile=MAKEFILE + "\ttruncate -s 250M a b c\n")
    student(subs / "disk_hog", hooks(FILL))
    student(subs / "tmp_filler", makefile=MAKEFILE + "\t-head -c 100000000 /dev/zero > /tmp/f\n")
    student(
        subs / "dev_writer",
        hooks('system("head -c 20000000 /dev/zero > /dev/shm/x; echo x > /dev/evil");'),
        **{"deep.h": "#include <stdlib.h>\n"},
    )
    student(
        subs / "bmp_out", hooks(after='FILE *g = fopen(out, "wb"); fputs("BM6", g); fclose(g);')
    )
    shutil.copy("/bin/true", student(subs / "prebuilt") / "helper")
    _long_name_tar(subs / "long_name.tar.gz")
    with private_tmp() as tmp:
        proc = grade(subs, out, *SMALL, "--disk", "64M", tmp=tmp, limits=False)
        left = os.listdir(tmp)
    explain = run([RTVAL, "grade", "--explain", "forged_out", "--out", str(out)])
    return {"proc": proc, "out": out, "subs": subs, "left": left, "explain": explain}


EXPECTED = {
    "good": ("pass", ""),
    "exit152": ("fail", "classic: exit 152"),
    "bad_alloc": ("fail", "classic: exit 1"),
    "forged_out": ("fail", "is a symbolic link (to \\x1b]0;pwn\\x07\\x1b[2J\\r\\n  scene"),
    "bidi_build": ("fail", "build failed: rt.c:1:1: error: \\u202essap :edarg \\x9b 2J"),
    "links_build": ("pass", ""),
    "spinner": ("pass", ""),
    "work_swapped": ("fail", "build failed: the build left no folder to keep"),
    "sparse_build": ("fail", "build failed: the build left 750 MiB of files, more than 512 MiB"),
    "disk_hog": ("fail", "classic: stopped: disk limit 64 MiB"),
    "tmp_filler": ("pass", ""),
    "dev_writer": ("pass", ""),
    "bmp_out": ("fail", 'output is not a PPM: classic.ppm holds text ("BM6")'),
    "prebuilt": ("fail", "refused: 'helper' is a prebuilt program (an ELF file)"),
    "long_name": ("fail", "refused: a tar long-name header of 512 MiB, more than the 4096 bytes"),
}


def test_every_row_says_what_really_happened(graded: dict[str, object]) -> None:
    proc = graded["proc"]
    assert isinstance(proc, subprocess.CompletedProcess)
    assert proc.returncode == 0, proc.stderr[-3000:]
    book = gradebook(graded["out"])  # type: ignore[arg-type]
    got = {k: (v["status"], v["reasons"]) for k, v in book.items()}
    wrong = {k: got.get(k) for k, (status, reason) in EXPECTED.items()
             if k not in got or got[k][0] != status or reason not in got[k][1]}  # fmt: skip
    assert not wrong, wrong
    assert "killed" not in book["exit152"]["reasons"] + book["bad_alloc"]["reasons"]
    assert graded["left"] == []  # every workspace removed


def test_no_text_a_student_controls_reaches_a_file_or_terminal_raw(
    graded: dict[str, object],
) -> None:
    out = graded["out"]
    assert isinstance(out, Path)
    raw = ("\x1b", "\r", "\u202e", "\x9b", "\x07")
    for name in ("gradebook.csv", "gradebook.json", "results/forged_out.json"):
        text = (out / name).read_text()
        decoded = (
            json.dumps(json.loads(text), ensure_ascii=False) if name.endswith("json") else text
        )
        assert not any(c in decoded for c in raw), name
    explain = graded["explain"]
    assert isinstance(explain, subprocess.CompletedProcess) and explain.returncode == 0
    assert not any(c in explain.stdout for c in raw)
    lines = explain.stdout.splitlines()
    assert lines[0].startswith("forged_out: FAIL")
    assert all(line.startswith(("  scene classic: error", "    ")) for line in lines[1:]), lines
    page = (out / "students" / "bidi_build" / "index.html").read_text()
    assert "\u202e" not in page and "\x9b" not in page


def test_out_keeps_no_links_and_no_refused_build(graded: dict[str, object]) -> None:
    programs = graded["out"] / "programs"  # type: ignore[operator]
    assert not [p for p in programs.rglob("*") if p.is_symlink()]
    listed = json.loads((programs / "links_build" / "build" / "links.json").read_text())
    assert sorted(map(tuple, listed)) == [("key", "/root/.ssh/id_rsa"), ("shadow", "/etc/shadow")]
    assert not (programs / "sparse_build" / "build" / "tree").exists()
    assert sum(f.stat().st_size for f in programs.rglob("*") if f.is_file()) < 16 << 20


def test_binaries_are_the_teachers_choice(graded: dict[str, object], tmp_path: Path) -> None:
    subs = tmp_path / "subs"
    shutil.copytree(graded["subs"] / "prebuilt", subs / "prebuilt")  # type: ignore[operator]
    proc = grade(subs, tmp_path / "out", "--allow-binaries")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert gradebook(tmp_path / "out")["prebuilt"]["status"] == "pass"


def test_the_machines_failures_are_never_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def full_disk(*_a: object, **_k: object) -> None:
        raise OSError(28, "No space left on device")

    src = student(tmp_path / "alice")
    job = programs.ProgramJob(str(src), programs.ProgramSpec(run=("./rt", "{out}")), ())
    monkeypatch.setattr(programs, "Workspace", full_disk)
    result = programs.build_and_run(job, tmp_path / "programs")
    assert result.transient and "No space left on device" in (result.problem or "")
    assert not (tmp_path / "programs" / "build" / "outcome.json").exists()
