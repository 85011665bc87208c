"""`rtval report` against a hostile folder, label and image, and stopped by signals: it never
writes or deletes through a link, refuses a label it cannot draw, reports an image with no
finite pixel, and an interrupted run exits 128 + the signal leaving nothing that looks
complete, no temporary file and no browser. Every wait is on an event (a line, a file, a
process's end), never on the clock."""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import weakref
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, run

from compare import interrupts as interrupt
from compare.judge.images import write_exr

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SIZE = ("--size", "64x48")
FINISHED = ("index.html", "report.json", "report.pdf")


def _report(out: Path, *options: str, **kw: object) -> subprocess.CompletedProcess[str]:
    cmd = [RTVAL, "report", str(SCENES / "classic.json"), "--reports-dir", str(out), *SIZE]
    return run([*cmd, *options], **kw)


def _leftovers(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*") if p.name.startswith(".") or ".tmp" in p.name]


@pytest.mark.parametrize("linked", ["classic", "classic/images"])
def test_a_linked_report_folder_is_refused_and_its_target_untouched(
    tmp_path: Path, render_cache: Path, linked: str
) -> None:
    victim = tmp_path / "victim"
    (victim / "cache").mkdir(parents=True)  # what the old layout's cleanup would remove
    (victim / "keep.txt").write_text("mine")
    (victim / "cache" / "keep.txt").write_text("mine too")
    out = tmp_path / "reports"
    (out / linked).parent.mkdir(parents=True, exist_ok=True)
    (out / linked).symlink_to(victim)
    proc = _report(out, "--no-pdf")
    assert proc.returncode == 4, proc.stderr
    assert f"{out / linked}: is a symbolic link, not a folder" in proc.stderr
    assert sorted(p.relative_to(victim).as_posix() for p in victim.rglob("*")) == [
        "cache",
        "cache/keep.txt",
        "keep.txt",
    ]


@pytest.mark.parametrize(
    ("label", "why"),
    [
        ("x" * 120_000, "120000 characters; a label has at most 200"),
        ("two\nlines", "one line of text"),
    ],
)
def test_a_label_that_cannot_be_drawn_is_a_usage_error(
    tmp_path: Path, label: str, why: str
) -> None:
    proc = _report(tmp_path, "--label", label, timeout=60)
    assert proc.returncode == 64 and "argument --label" in proc.stderr and why in proc.stderr
    assert not (tmp_path / "classic").exists()


def test_an_image_with_no_finite_pixel_gets_a_report_that_says_so(
    tmp_path: Path, render_cache: Path
) -> None:
    image = tmp_path / "nan.exr"
    write_exr(image, np.full((48, 64, 3), np.nan, np.float32))
    proc = _report(tmp_path / "out", "--no-pdf", "--test-image", str(image))
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    folder = tmp_path / "out" / "classic"
    page = (folder / "index.html").read_text(encoding="utf-8")
    assert 'id="no-finite-pixels"><b>nan has no finite pixel</b>' in page
    data = json.loads((folder / "report.json").read_text())
    assert data["verdict"]["status"] == "fail"
    assert data["featured"][0]["global"]["nan_test"] == 64 * 48


def _lost_interrupt() -> None:
    """SIGINT delivered while a weakref callback runs: its KeyboardInterrupt is printed as
    "Exception ignored" and dropped, as it was from matplotlib's WeakKeyDictionary."""

    class Thing:
        pass

    def callback(_: object) -> None:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # the handler runs between these bytecodes
            pass

    thing = Thing()
    ref = weakref.ref(thing, callback)
    del thing
    assert ref() is None


def test_a_stop_signal_lost_in_a_weakref_callback_still_stops() -> None:
    lost: list[BaseException | None] = []
    before = sys.unraisablehook
    sys.unraisablehook = lambda u: lost.append(u.exc_value)
    try:
        with interrupt.stop_guard(), pytest.raises(interrupt.Stopped) as stopped:
            _lost_interrupt()
            interrupt.check()
    finally:
        sys.unraisablehook = before
    assert [type(e) for e in lost] == [interrupt.Stopped]  # the first one was dropped
    assert stopped.value.exit_code == 130


# The report with a SIGINT lost inside its difference-maps step, as it happened in 1 of ~40
# runs: the run must still end 130 and leave no finished page.
LOSE_INTERRUPT_IN_MAPS = """
import sys
sys.path.insert(0, {tests!r})
from test_report_safety import _lost_interrupt
import compare.report.build as report
from compare.cli.main import main
real = report.difference_maps
def maps(ctx):
    _lost_interrupt()
    return real(ctx)
report.difference_maps = maps
sys.exit(main(sys.argv[1:]))
"""


def test_an_interrupt_lost_during_the_difference_maps_still_exits_130(
    tmp_path: Path, render_cache: Path
) -> None:
    code = LOSE_INTERRUPT_IN_MAPS.format(tests=str(Path(__file__).parent))
    args = ["report", str(SCENES / "classic.json"), "--reports-dir", str(tmp_path), *SIZE]
    proc = run([sys.executable, "-c", code, *args, "--no-pdf"], timeout=600)
    assert proc.returncode == 130, proc.stderr
    assert "Exception ignored" in proc.stderr  # the interrupt was lost once, as in the wild
    assert "difference maps:" not in proc.stderr  # ... and the step did not end
    folder = tmp_path / "classic"
    assert not [n for n in FINISHED if (folder / n).exists()]
    assert not _leftovers(folder)


# A browser that never finishes printing, with a helper process in its group, as Chromium
# has: it writes both process ids, then waits.
FAKE_CHROMIUM = """#!/bin/sh
sleep 1000 &
echo "$$ $!" > "$RTVAL_TEST_PIDS.tmp" && mv "$RTVAL_TEST_PIDS.tmp" "$RTVAL_TEST_PIDS"
wait
"""


@pytest.fixture
def stuck_chromium(tmp_path: Path) -> Iterator[tuple[dict[str, str], Path]]:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "chromium").write_text(FAKE_CHROMIUM)
    (bin_dir / "chromium").chmod(0o755)
    pids = tmp_path / "chromium.pids"
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "RTVAL_TEST_PIDS": str(pids)}
    yield env, pids
    if pids.exists():  # never leave the fake browser behind, whatever the test found
        for pid in map(int, pids.read_text().split()):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)


def _wait_for_file(path: Path, proc: subprocess.Popen[str]) -> None:
    """Until `path` appears (the fake browser started), reading the report's progress lines
    as they come: each line is an event, and the pid file is written before the browser
    prints nothing more."""
    assert proc.stderr is not None
    while not path.exists():
        ready, _, _ = select.select([proc.stderr], [], [], 1.0)
        if ready and not proc.stderr.readline() and proc.poll() is not None:
            pytest.fail(f"the report ended ({proc.returncode}) before starting Chromium")


def _ended(pids: list[int]) -> bool:
    """Whether every process has ended, waiting on each one's pidfd (10 s at most)."""
    for pid in pids:
        try:
            fd = os.pidfd_open(pid)
        except ProcessLookupError:
            continue
        try:
            if not select.select([fd], [], [], 10)[0]:
                return False
        finally:
            os.close(fd)
    return True


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_while_chromium_prints_kills_it_and_leaves_nothing(
    tmp_path: Path,
    render_cache: Path,
    stuck_chromium: tuple[dict[str, str], Path],
    signum: int,
    code: int,
) -> None:
    env, pids = stuck_chromium
    cmd = [RTVAL, "report", str(SCENES / "classic.json"), "--reports-dir", str(tmp_path), *SIZE]
    with subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=env) as proc:
        _wait_for_file(pids, proc)
        browser = [int(p) for p in pids.read_text().split()]
        proc.send_signal(signum)  # to rtval alone: the browser must go with it
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert f"interrupted ({signal.Signals(signum).name})" in err
    assert _ended(browser), f"Chromium's processes outlived the report: {browser}"
    folder = tmp_path / "classic"
    assert not [n for n in FINISHED if (folder / n).exists()]
    assert not _leftovers(folder)


def test_kill_9_of_the_report_takes_chromium_with_it(
    tmp_path: Path, render_cache: Path, stuck_chromium: tuple[dict[str, str], Path]
) -> None:
    env, pids = stuck_chromium
    cmd = [RTVAL, "report", str(SCENES / "classic.json"), "--reports-dir", str(tmp_path), *SIZE]
    with subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=env) as proc:
        _wait_for_file(pids, proc)
        browser, _ = (int(p) for p in pids.read_text().split())
        proc.kill()
        proc.communicate(timeout=60)
    assert _ended([browser]), "Chromium outlived a kill -9 of the report"


# The images step writes on every core: the third PNG fails as a full disk would.
FAIL_THIRD_PNG = """
import sys, threading
import compare.report.build as report
from compare.cli.main import main
real, calls, lock = report.derived_png, [], threading.Lock()
def derived_png(cache, sha, img, target):
    with lock:
        calls.append(target)
        third = len(calls) == 3
    if third:
        raise OSError(28, "No space left on device", str(target))
    real(cache, sha, img, target)
report.derived_png = derived_png
sys.exit(main(sys.argv[1:]))
"""


def test_a_picture_that_cannot_be_written_fails_the_report_and_names_it(
    tmp_path: Path, render_cache: Path
) -> None:
    args = ["report", str(SCENES / "classic.json"), "--reports-dir", str(tmp_path), *SIZE]
    proc = run([sys.executable, "-c", FAIL_THIRD_PNG, *args, "--no-pdf"], timeout=600)
    assert proc.returncode != 0 and "No space left on device" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and ".png" in proc.stderr, proc.stderr
    folder = tmp_path / "classic"
    assert not [n for n in FINISHED if (folder / n).exists()]
    assert not _leftovers(folder)
