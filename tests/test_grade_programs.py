"""`rtval grade --build --run`: a class of programs built and run in the sandbox, hostile ones
included. Every hostile program gets its row and reason, changes nothing outside its copy,
leaves no process behind, and the other students are graded as if it were not there; a correct
program gets the verdict and score its image gets when graded directly.

The programs are tests/hostile_programs/rt.c (a tiny correct renderer of the classic scene)
with a student.h of hooks per student; every hostile one names its processes with this run's
marker, so a survivor would be found in /proc. Limits are small so that nothing here can hurt
the machine: 2 s a run, 256 MiB a process, files of 16 MiB, 32 processes.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import uuid
import zipfile
from pathlib import Path

import pytest
from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))
PROGRAMS = Path(__file__).resolve().parent / "hostile_programs"
RUN = "./rt {out} {width} {height} {scene}"
LIMITS = [
    "--run-timeout",
    "2",
    "--cpu",
    "10",
    "--memory",
    "256M",
    "--file-size",
    "16M",
    "--processes",
    "32",
    "--open-files",
    "64",
]
BASE = ["--size", "160x120", "--no-diagnose", "--jobs", "2"]
MAKEFILE = "rt: rt.c student.h\n\tcc -O2 -o rt rt.c -lm\n"

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")


def _hooks(start: str = "", before: str = "", after: str = "") -> str:
    return f"#define HOOK_START {{ mark(); {start} }}\n#define HOOK_BEFORE_WRITE {{ {before} }}\n#define HOOK_AFTER_WRITE {{ {after} }}\n"


# Each hostile student: (student.h hooks, expected status, a piece of the expected reason).
# fmt: off
HOSTILE = {
    "loop": (_hooks("volatile unsigned long n = 0; for (;;) n++;"), "fail", "timed out after 2 s"),
    "sleeper": (_hooks("for (;;) pause();"), "fail", "timed out after 16 s of wall time"),
    "forkbomb": (_hooks("for (;;) fork();"), "fail", "timed out after 2 s"),
    "hog": (
        _hooks(
            "for (;;) { char *p = malloc(16 << 20); if (!p) *(volatile char *)0 = 1; "
            "memset(p, 1, 16 << 20); }"
        ),
        "fail",
        "killed: memory limit 256 MiB",
    ),
    "bigfile": (
        _hooks(
            'static char b[1 << 20]; FILE *f = fopen("big.bin", "wb"); '
            "for (long i = 0; i < 10240; i++) fwrite(b, 1, sizeof b, f);"
        ),
        "fail",
        "killed: file size limit 16 MiB",
    ),
    "chatty": (
        _hooks(
            'puts("<script>alert(1)</script>"); static char l[1 << 20]; '
            "memset(l, 'x', sizeof l - 1); for (int i = 0; i < 100; i++) fputs(l, stdout); "
            'puts("the end"); fflush(stdout);'
        ),
        "pass",
        "",
    ),
    "daemon": (
        _hooks(
            "if (fork() == 0) { setsid(); if (fork() == 0) "
            'execl("/bin/sleep", MARKER, "1000", (char *)0); _exit(0); }'
        ),
        "pass",
        "",
    ),
    "snoop": (_hooks("snoop();"), "pass", ""),
    "netcat": (_hooks("netcat();"), "pass", ""),
    "litter": (_hooks("litter_all();"), "pass", ""),
    "scene_writer": (
        _hooks('FILE *s = fopen(argv[4], "w"); if (s) { fputs("{}", s); fclose(s); }'),
        "pass",
        "",
    ),
    "symlink_out": (
        _hooks(after='unlink(out); symlink("/etc/passwd", out);'),
        "fail",
        "output is not a regular file: classic.ppm is a symbolic link (to /etc/passwd)",
    ),
    "fifo_out": (
        _hooks(before="mkfifo(out, 0644); return 0;"),
        "fail",
        "output is not a regular file: classic.ppm is a FIFO",
    ),
    "exit3": (_hooks("exit(3);"), "fail", "classic: exit 3"),
    "segv": (_hooks("raise(SIGSEGV);"), "fail", "crashed: SIGSEGV"),
    "silent": (_hooks("return 0;"), "fail", "no output: the program wrote no classic.ppm"),
    "huge_out": (
        _hooks(
            after='static char j[2 << 20]; FILE *g = fopen(out, "ab"); '
            "fwrite(j, 1, sizeof j, g); fclose(g);"
        ),
        "fail",
        "output too large",
    ),
    "syntax": (
        "#define HOOK_START int x = ;\n#define HOOK_BEFORE_WRITE\n#define HOOK_AFTER_WRITE\n",
        "fail",
        "build failed: student.h:",
    ),
    "wrong": (_hooks("broken = 1;"), "fail", "differ from classic"),
}
# fmt: on
CORRECT = ["good", "good_zip", "good_tgz", "make_escape"]
REFUSED = {
    "zip_slip": "refused: archive entry '../evil.txt' escapes its folder ('..')",
    "zip_bomb": "refused: the archive unpacks to 80 MiB, more than the 64 MiB allowed (a zip bomb?)",
    "link_inside": "refused: 'peek' is a symbolic link (to ",
    "link_top": "link_top is a symbolic link (to ",
    "image": "image.ppm is not a program: hand in a folder or a .zip",
}


def _prelude(ctx: dict[str, str]) -> str:
    """What every student.h starts with: headers, the marker and the hostile helpers, with
    the paths of the teacher's side that they try to reach."""
    secrets = ", ".join(json.dumps(p) for p in ctx["secrets"].split("\n"))
    litter = ", ".join(json.dumps(p) for p in ctx["litter"].split("\n"))
    return f"""#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>
#define MARKER "{ctx["marker"]}"
static void mark(void) {{ prctl(PR_SET_NAME, MARKER); }}
static void snoop(void) {{  /* renders wrongly if any of these can be read */
    const char *paths[] = {{{secrets}, NULL}};
    for (int i = 0; paths[i]; i++) {{ int fd = open(paths[i], O_RDONLY); if (fd >= 0) broken = 1; }}
}}
static void netcat(void) {{  /* renders wrongly if it reaches the test's listener */
    int s = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {{0}};
    a.sin_family = AF_INET; a.sin_port = htons({ctx["port"]}); a.sin_addr.s_addr = htonl(0x7f000001);
    if (connect(s, (struct sockaddr *)&a, sizeof a) == 0) {{ (void)!write(s, "hi", 2); broken = 1; }}
}}
static void litter(const char *p) {{
    int fd = open(p, O_WRONLY | O_CREAT, 0644);
    if (fd >= 0) {{ (void)!write(fd, "x", 1); close(fd); }}
}}
static void litter_all(void) {{
    const char *paths[] = {{{litter}, NULL}};
    char home[4096];
    snprintf(home, sizeof home, "%s/escaped-" MARKER, getenv("HOME") ? getenv("HOME") : "/x");
    litter(home);
    for (int i = 0; paths[i]; i++) litter(paths[i]);
}}
"""


def _student(folder: Path, hooks: str, ctx: dict[str, str], makefile: str = MAKEFILE) -> None:
    folder.mkdir(parents=True)
    shutil.copy(PROGRAMS / "rt.c", folder / "rt.c")
    (folder / "student.h").write_text(_prelude(ctx) + hooks)
    (folder / "Makefile").write_text(makefile)


def _escape_makefile(ctx: dict[str, str]) -> str:
    """A build that tries to write outside its folder (each line may fail: '-')."""
    lines = "".join(f"\t-echo pwned > {p}\n" for p in ctx["litter"].split("\n"))
    return f"rt: rt.c student.h\n{lines}\t-echo pwned > $(HOME)/escaped\n\tcc -O2 -o rt rt.c -lm\n"


def _archives(subs: Path, scratch: Path, ctx: dict[str, str]) -> None:
    good = scratch / "good_src"
    _student(good, _hooks(), ctx)
    with zipfile.ZipFile(subs / "good_zip.zip", "w") as z:  # one top folder, as students zip
        for f in sorted(good.iterdir()):
            z.write(f, f"good_zip/{f.name}")
    with tarfile.open(subs / "good_tgz.tar.gz", "w:gz") as t:
        t.add(good, "good_tgz")
    with zipfile.ZipFile(subs / "zip_slip.zip", "w") as z:
        for f in sorted(good.iterdir()):
            z.write(f, f.name)
        z.writestr("../evil.txt", "pwned")
    bomb = zipfile.ZipFile(subs / "zip_bomb.zip", "w", zipfile.ZIP_DEFLATED)
    with bomb, bomb.open("zeros.bin", "w") as f:
        for _ in range(80):
            f.write(bytes(1 << 20))
    link = subs / "link_inside"
    _student(link, _hooks(), ctx)
    (link / "peek").symlink_to(ctx["secret"])
    (subs / "link_top").symlink_to(good, target_is_directory=True)  # a link is never followed
    (subs / "image.ppm").write_bytes(b"P6\n1 1\n255\n\0\0\0")  # an image, not a program


def _snapshot(folder: Path) -> dict[str, tuple[int, str]]:
    """Every entry under folder: its kind and size, and a regular file's bytes' hash."""
    import hashlib

    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        digest = (
            hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() and not p.is_symlink() else ""
        )
        out[str(p.relative_to(folder))] = (st.st_mode, digest)
    return out


def _marked_processes(marker: str) -> list[str]:
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            text = (d / "comm").read_text() + (d / "cmdline").read_bytes().decode(
                "utf-8", "replace"
            )
        except OSError:
            continue
        if marker in text:
            found.append(f"{d.name}: {text!r}")
    return found


def _grade(
    subs: Path, out: Path, *extra: str, env: dict[str, str] | None = None, limits: bool = True
) -> subprocess.CompletedProcess[str]:
    cmd = [RTVAL, "grade", str(subs), "--scene", str(SCENES / "classic.json"), "--out", str(out)]
    options = [*BASE, *LIMITS] if limits else BASE
    return run([*cmd, *options, *extra], env={**os.environ, **(env or {})})


def _gradebook(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        return {row["student"]: row for row in csv.DictReader(f)}


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    root = tmp_path_factory.mktemp("programs")
    marker = "rtvm" + uuid.uuid4().hex[:8]
    subs, out, scratch = root / "subs", root / "grades", root / "scratch"
    subs.mkdir()
    scratch.mkdir()
    secret = root / "secret.txt"
    secret.write_text("the answers\n")
    secret.chmod(0o644)  # readable by anyone: only the sandbox keeps it out of reach
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    listener.setblocking(False)
    home = Path(os.environ.get("HOME", "/root"))
    cache = Path(os.environ["RTVAL_CACHE"])
    litter = [
        f"/tmp/escaped-{marker}",
        f"../other_student/escaped-{marker}",
        f"../escaped-{marker}",
        f"{home}/escaped-{marker}",
        f"{subs}/good/escaped-{marker}",
        f"{out}/escaped-{marker}",
        f"{root}/escaped-{marker}",
        f"/etc/escaped-{marker}",
    ]
    ctx = {
        "marker": marker,
        "port": str(listener.getsockname()[1]),
        "secret": str(secret),
        "secrets": "\n".join(
            [
                str(secret),
                f"{subs}/good/rt.c",
                str(cache),
                str(home),
                f"{out}/references",
                "/etc/shadow",
            ]
        ),
        "litter": "\n".join(litter),
    }
    _student(subs / "good", _hooks(), ctx)
    _student(subs / "make_escape", _hooks(), ctx, _escape_makefile(ctx))
    for name, (hooks, _, _) in HOSTILE.items():
        _student(subs / name, hooks, ctx)
    _archives(subs, scratch, ctx)
    scene_sum = (SCENES / "classic.json").read_bytes()
    before = _snapshot(root)
    proc = _grade(subs, out, "--build", "make", "--run", RUN)
    after = {k: v for k, v in _snapshot(root).items() if not k.startswith("grades")}
    yield {
        "proc": proc,
        "out": out,
        "subs": subs,
        "root": root,
        "marker": marker,
        "ctx": ctx,
        "listener": listener,
        "before": before,
        "after": after,
        "litter": litter,
        "scene_unchanged": (SCENES / "classic.json").read_bytes() == scene_sum,
    }
    listener.close()


def test_every_row_has_the_expected_verdict_and_reason(graded: dict[str, object]) -> None:
    proc = graded["proc"]
    assert isinstance(proc, subprocess.CompletedProcess)
    assert proc.returncode == 0, proc.stderr[-3000:]
    book = _gradebook(graded["out"])  # type: ignore[arg-type]
    expected = {n: (s, r) for n, (_, s, r) in HOSTILE.items()}
    expected |= dict.fromkeys(CORRECT, ("pass", "")) | {n: ("fail", r) for n, r in REFUSED.items()}
    assert set(book) == set(expected)
    wrong = {
        n: (book[n]["status"], book[n]["reasons"])
        for n, (status, reason) in expected.items()
        if book[n]["status"] != status or reason not in book[n]["reasons"]
    }
    assert not wrong, wrong
    for n, (status, _) in expected.items():  # the correct ones as if the others were absent
        if status == "pass":
            assert book[n]["score"] == "100.00" and book[n]["reasons"] == "", (n, book[n])
    assert "error:" in book["syntax"]["reasons"]


def test_nothing_outside_changed_and_no_process_is_left(graded: dict[str, object]) -> None:
    assert graded["after"] == graded["before"]  # the submissions, the secret, the scratch
    for p in graded["litter"]:  # type: ignore[attr-defined]
        if p.startswith("/"):
            assert not Path(p).exists(), p
    assert not list(Path("/tmp").glob(f"*{graded['marker']}*"))
    assert graded["scene_unchanged"]
    assert not (graded["root"] / "evil.txt").exists()  # type: ignore[operator]
    assert not _marked_processes(str(graded["marker"]))
    listener = graded["listener"]
    assert isinstance(listener, socket.socket)
    with pytest.raises(BlockingIOError):  # no program ever connected
        listener.accept()
    assert not list(Path("/tmp").glob("rtval-sandbox-*/work/rt")), "workspaces are removed"


def test_pages_show_logs_time_and_memory_escaped(graded: dict[str, object]) -> None:
    out = graded["out"]
    assert isinstance(out, Path)
    page = (out / "students" / "chatty" / "index.html").read_text()
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page and "<script>alert" not in page
    assert "the end" in page and "bytes not kept" in page and "peak memory" in page
    result = json.loads((out / "results" / "chatty.json").read_text())
    run_ = result["program"]["runs"]["classic"]
    assert run_["log_bytes"] > 100_000_000 and len(run_["log"]) < 70_000
    assert result["program"]["sandboxed"] and run_["sandboxed"]
    hog = json.loads((out / "results" / "hog.json").read_text())["program"]["runs"]["classic"]
    assert hog["peak_memory"] > 128 << 20  # it reached the limit: the peak says so
    build = json.loads((out / "results" / "syntax.json").read_text())["program"]["build"]
    assert "error" in build["log"] and build["status"] == "exit"


def test_a_correct_program_grades_as_its_image_does(
    graded: dict[str, object], tmp_path: Path
) -> None:
    out = graded["out"]
    assert isinstance(out, Path)
    images = tmp_path / "images"
    images.mkdir()
    shutil.copy(out / "programs" / "good" / "runs" / "classic" / "classic.ppm", images / "good.ppm")
    proc = _grade(images, tmp_path / "grades")
    assert proc.returncode == 0, proc.stderr[-2000:]
    direct = json.loads((tmp_path / "grades" / "results" / "good.json").read_text())
    program = json.loads((out / "results" / "good.json").read_text())
    assert (direct["status"], direct["score"]) == (program["status"], program["score"])
    assert direct["scenes"][0]["verdict"] == program["scenes"][0]["verdict"]


def test_a_rerun_resumes_and_a_new_rubric_rebuilds_nothing(
    graded: dict[str, object], tmp_path: Path
) -> None:
    out, subs = graded["out"], graded["subs"]
    assert isinstance(out, Path) and isinstance(subs, Path)
    stamp = (out / "programs" / "good" / "build" / "outcome.json").stat().st_mtime_ns
    again = _grade(subs, out, "--build", "make", "--run", RUN)
    assert again.returncode == 0 and f"({len(_gradebook(out))} resumed)" in again.stderr
    rubric = tmp_path / "r.toml"
    rubric.write_text("[rubric]\npass_score = 50\n")
    regrade = _grade(subs, out, "--build", "make", "--run", RUN, "--rubric", str(rubric))
    assert regrade.returncode == 0, regrade.stderr[-2000:]
    result = json.loads((out / "results" / "good.json").read_text())
    assert result["rubric"] == str(rubric) and result["status"] == "pass"
    assert result["program"]["build"]["cached"] and result["program"]["runs"]["classic"]["cached"]
    assert (out / "programs" / "good" / "build" / "outcome.json").stat().st_mtime_ns == stamp


def test_dask_workers_build_and_run_in_their_sandbox(
    graded: dict[str, object], tmp_path: Path
) -> None:
    from dask.distributed import LocalCluster

    subs, out = tmp_path / "subs", graded["out"]
    assert isinstance(out, Path)
    for name in ("good", "daemon", "exit3", "segv", "zip_slip.zip"):
        src = graded["subs"] / name  # type: ignore[operator]
        (shutil.copytree if src.is_dir() else shutil.copy)(src, subs / name)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        proc = _grade(
            subs, tmp_path / "grades", "--build", "make", "--run", RUN,
            "--executor", "dask", "--scheduler", cluster.scheduler_address,
        )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    local, dask = _gradebook(out), _gradebook(tmp_path / "grades")
    assert {k: (v["status"], v["reasons"]) for k, v in dask.items()} == {
        k: (local[k]["status"], local[k]["reasons"]) for k in dask
    }
    assert not _marked_processes(str(graded["marker"]))


def test_a_fixed_output_file_from_the_rubric(tmp_path: Path) -> None:
    """scratchapixel's program writes untitled.ppm: [program] output names it."""
    ctx = {"marker": "rtvmfixed", "port": "9", "secret": "/x", "secrets": "/x", "litter": "/x"}
    subs = tmp_path / "subs"
    _student(subs / "fixed", _hooks(), ctx)
    _student(subs / "nothing", _hooks("return 0;"), ctx)
    rubric = tmp_path / "rubric.toml"
    rubric.write_text(
        '[program]\nbuild = "cc -O1 -o rt *.c -lm"\nrun = "./rt - {width} {height}"\n'
        'output = "untitled.ppm"\n[program.limits]\nrun_timeout = 20\nmemory = "512M"\n'
    )
    proc = _grade(subs, tmp_path / "grades", "--rubric", str(rubric), limits=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    book = _gradebook(tmp_path / "grades")
    assert book["fixed"]["status"] == "pass", book["fixed"]
    assert "no output: the program wrote no untitled.ppm" in book["nothing"]["reasons"]
    result = json.loads((tmp_path / "grades" / "results" / "fixed.json").read_text())
    assert result["program"]["build"]["command"] == "cc -O1 -o rt rt.c -lm"  # *.c, as sh does
    assert result["program"]["runs"]["classic"]["limits"]["memory"] == 512 << 20


def test_without_a_sandbox_run_refuses_unless_unsandboxed(tmp_path: Path) -> None:
    ctx = {"marker": "rtvmbare", "port": "9", "secret": "/x", "secrets": "/x", "litter": "/x"}
    subs = tmp_path / "subs"
    _student(subs / "good", _hooks(), ctx)
    no_bwrap = {"RTVAL_BWRAP": str(tmp_path / "no-bwrap")}
    refused = _grade(subs, tmp_path / "grades", "--build", "make", "--run", RUN, env=no_bwrap)
    assert refused.returncode == 1
    assert "no sandbox" in refused.stderr and "--unsandboxed" in refused.stderr
    assert not (tmp_path / "grades" / "programs").exists()  # nothing was run
    bare = _grade(
        subs, tmp_path / "grades", "--build", "make", "--run", RUN, "--unsandboxed", env=no_bwrap
    )
    assert bare.returncode == 0, bare.stderr[-2000:]
    result = json.loads((tmp_path / "grades" / "results" / "good.json").read_text())
    assert result["status"] == "pass" and not result["program"]["sandboxed"]


def test_bad_program_options_are_usage_errors(tmp_path: Path) -> None:
    (tmp_path / "subs").mkdir()
    for extra, words in (
        (["--build", "make"], "--build needs --run"),
        (["--run", "./rt {frame} {out}"], "unknown placeholder {frame}"),
        (["--run", "./rt"], "must write the image {out}"),
        (["--run", "./rt", "--output", "../x.ppm"], "inside the program's folder"),
        (["--run", "./rt {out}", "--build", "make {scene}"], "--build may not use {scene}"),
        (["--run", "./rt {out}", "--memory", "lots"], "expected a size"),
    ):
        proc = _grade(tmp_path / "subs", tmp_path / "grades", *extra)
        assert proc.returncode == 64 and words in proc.stderr, (extra, proc.stderr[-500:])


# -- the sandbox and the archives, directly ---------------------------------------------------


def test_sandbox_cpu_limit_and_exit_words() -> None:
    from compare.sandbox.bwrap import Limits, Workspace, run_sandboxed

    with Workspace() as ws:
        spin = run_sandboxed(["sh", "-c", "while :; do :; done"], ws, Limits(wall=30, cpu=1))
        assert spin.status == "cpu" and spin.reason == "killed: CPU time limit 1 s"
        assert spin.cpu_seconds > 0.5 and spin.seconds < 30  # tick-accounted
        who = run_sandboxed(["sh", "-c", "id -u; ls /; exit 5"], ws, Limits(wall=30))
        assert who.reason == "exit 5" and who.log.split()[0] == "65534"
        assert "home" not in who.log.split() and "root" not in who.log.split()


@pytest.mark.parametrize(
    ("make", "reason"),
    [
        (lambda t: t.addfile(tarfile.TarInfo("/etc/evil"), io.BytesIO()), "is an absolute path"),
        (lambda t: t.addfile(tarfile.TarInfo("a/../../evil"), io.BytesIO()), "escapes its folder"),
        (lambda t: t.addfile(_link("x", "/etc/passwd")), "is a link"),
        (lambda t: t.addfile(_sized("big", 70 << 20), io.BytesIO(bytes(70 << 20))), "a bomb"),
    ],
)
def test_tar_entries_that_leave_the_tree_are_refused(
    tmp_path: Path, make: object, reason: str
) -> None:
    from compare.sandbox.archives import TreeError, unpack

    archive = tmp_path / "s.tar.gz"
    with tarfile.open(archive, "w:gz") as t:
        make(t)  # type: ignore[operator]
    with pytest.raises(TreeError, match=reason):
        unpack(archive, tmp_path / "dest")
    assert not (tmp_path / "dest").exists() and not Path("/etc/evil").exists()


def _link(name: str, target: str) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.linkname = tarfile.SYMTYPE, target
    return info


def _sized(name: str, size: int) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.size = size
    return info
