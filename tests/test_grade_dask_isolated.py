"""`rtval grade --executor dask` with workers that see nothing of the teacher's machine: a
`dask scheduler` and a `dask worker` started as separate processes, the worker in a folder
of its own with its own HOME and TMPDIR, unable to read the teacher's folder (another uid
where the interpreter allows it, else a bubblewrap sandbox that hides the teacher's folders).
The gradebook must be the local executor's, row for row; a worker that dies is one row.
"""

from __future__ import annotations

import contextlib
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import SCENES, run
from student_variants import render_variant

from compare.grading.executors import Executor, run_on_dask
from compare.grading.shipping import (
    MAX_SHIPPED_BYTES,
    ShipError,
    ship_images,
    ship_program,
    unpack_program,
)
from scene_model.scene import load_scene

# The worker runs this Python as another uid or in a sandbox; where it reports another patch
# release of the interpreter (seen once under a loaded parallel run), distributed only warns.
pytestmark = [
    pytest.mark.slow,
    pytest.mark.filterwarnings("ignore::distributed.versions.VersionMismatchWarning"),
]
BIN = Path(sys.executable).parent
RTVAL = str(BIN / "rtval")
NOBODY = 65534
SIZE = ["--size", "160x120", "--against", "classic"]


def _book(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        rows = {row["student"]: row for row in csv.DictReader(f)}
    for row in rows.values():
        row.pop("seconds", None)  # the time it took is the one column allowed to differ
    return rows


def _isolation(teacher: Path, worker: Path, basetemp: Path) -> list[str]:
    """The command prefix that starts the worker unable to read `teacher`: another uid when
    root can drop to one that can still run this Python; else a bubblewrap sandbox that
    mounts an empty folder over the test's temporary folders (the teacher's among them)."""
    drop = ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups"]
    env = {"PATH": "/usr/bin:/bin", "HOME": str(worker)}
    if os.geteuid() == 0 and shutil.which("setpriv"):
        probe = subprocess.run(
            [*drop, sys.executable, "-c", "import compare.grading.grade"], env=env, check=False
        )
        if probe.returncode == 0:
            os.chown(worker, NOBODY, NOBODY)
            for sub in worker.rglob("*"):
                os.chown(sub, NOBODY, NOBODY)
            return drop
    # No other uid can run this Python (an interpreter under a home of mode 0700): hide instead.
    if not shutil.which("bwrap"):
        pytest.skip("no other uid can run this Python, and no bwrap to hide the teacher's folder")
    sandbox = ["bwrap", "--die-with-parent", "--ro-bind", "/", "/", "--dev", "/dev"]
    return [
        *sandbox,
        "--proc",
        "/proc",
        "--tmpfs",
        str(basetemp),
        "--bind",
        str(worker),
        str(worker),
    ]


def _wait_for(path: Path, proc: subprocess.Popen[bytes], seconds: float) -> None:
    """Until `path` exists (the scheduler wrote its file); fails if the process ended."""
    deadline = time.monotonic() + seconds
    while not path.exists():
        assert time.monotonic() < deadline, f"no {path.name} within {seconds} s"
        with contextlib.suppress(subprocess.TimeoutExpired):  # its exit ends the wait at once
            proc.wait(timeout=0.05)
            raise AssertionError("the scheduler exited before writing its file")


def _wait_for_worker(address: str, proc: subprocess.Popen[bytes], log: Path) -> None:
    """Until the scheduler knows one worker; fails with the worker's log if it exited."""
    from dask.distributed import Client

    with Client(address, timeout=30) as client:
        deadline = time.monotonic() + 120
        while True:
            try:
                client.wait_for_workers(1, timeout=1)  # the scheduler's event: it registered
                return
            except TimeoutError:
                assert proc.poll() is None, f"the worker exited: {log.read_text()[-3000:]}"
                assert time.monotonic() < deadline, f"no worker: {log.read_text()[-3000:]}"


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGTERM)  # its own session: the worker's nanny and worker
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


@pytest.fixture
def cluster(
    tmp_path: Path, tmp_path_factory: pytest.TempPathFactory, request: pytest.FixtureRequest
) -> Iterator[tuple[str, Path, Path]]:
    """(scheduler address, the teacher's folder, the worker's folder). The worker's folder is
    outside the test's temporary folders, as another machine's would be."""
    teacher = tmp_path / "teacher"
    teacher.mkdir(mode=0o700)
    worker = Path(tempfile.mkdtemp(prefix="rtval-worker-"))
    request.addfinalizer(lambda: shutil.rmtree(worker, ignore_errors=True))
    for sub in ("home", "tmp", "dask"):
        (worker / sub).mkdir(parents=True)
    prefix = _isolation(teacher, worker, tmp_path_factory.getbasetemp())
    sched_file, log = tmp_path / "scheduler.json", tmp_path / "worker.log"
    scheduler = subprocess.Popen(
        [str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
         "--no-dashboard", "--scheduler-file", str(sched_file)],
        start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    procs = [scheduler]
    try:
        _wait_for(sched_file, scheduler, 60)
        address = json.loads(sched_file.read_text())["address"]
        env = {"PATH": f"{BIN}:/usr/bin:/bin", "HOME": str(worker / "home")}
        env["TMPDIR"] = str(worker / "tmp")
        with log.open("wb") as log_file:
            worker_proc = subprocess.Popen(
                [
                    *prefix,
                    str(BIN / "dask"),
                    "worker",
                    address,
                    "--nthreads",
                    "1",
                    "--no-dashboard",
                    "--no-nanny",  # a nanny re-executes Python by a path this uid cannot
                    "--local-directory",
                    str(worker / "dask"),
                ],
                cwd=worker,
                env=env,
                start_new_session=True,
                stdout=subprocess.DEVNULL,
                stderr=log_file,
            )  # fmt: skip
        procs.append(worker_proc)
        _wait_for_worker(address, worker_proc, log)
        peek = [*prefix, sys.executable, "-c", f"import os; os.listdir({str(teacher)!r})"]
        denied = subprocess.run(peek, env=env, cwd=worker, check=False, stderr=subprocess.DEVNULL)
        assert denied.returncode != 0, "the worker can read the teacher's folder"
        yield address, teacher, worker
    finally:
        for p in reversed(procs):
            _stop(p)


def test_workers_need_nothing_of_the_teachers_machine(cluster: tuple[str, Path, Path]) -> None:
    address, teacher, worker = cluster
    subs = teacher / "subs"
    subs.mkdir()
    scene_file = teacher / "classic.json"  # the scene too is only on the teacher's side
    shutil.copyfile(SCENES / "classic.json", scene_file)
    scene = load_scene(scene_file)
    render_variant(scene, "exact", 160, 120, subs / "alice.ppm")
    render_variant(scene, "wrong_eta_leaving", 160, 120, subs / "bob.ppm")
    (subs / "carol.ppm").write_bytes(b"P6\nnot an image at all")
    grade = [RTVAL, "grade", str(subs), "--scene", str(scene_file), *SIZE]
    start = time.perf_counter()
    local = run([*grade, "--out", str(teacher / "local"), "--jobs", "1"])
    local_s = time.perf_counter() - start
    assert local.returncode == 0, local.stderr
    dask = [*grade, "--out", str(teacher / "dask"), "--executor", "dask", "--scheduler", address]
    start = time.perf_counter()
    proc = run(dask)
    dask_s = time.perf_counter() - start
    assert proc.returncode == 0, proc.stderr
    print(f"class of 3: local {local_s:.1f} s, dask (fresh worker cache) {dask_s:.1f} s")
    book = _book(teacher / "dask")
    assert book == _book(teacher / "local")
    assert [book[s]["status"] for s in ("alice", "bob", "carol")] == ["pass", "fail", "fail"]
    assert book["bob"]["diagnosis"].startswith("looks like Q2 (")  # diagnosed on the worker
    assert "unreadable" in book["carol"]["reasons"]
    # The client alone wrote OUT: the pages' pictures came back as bytes.
    assert (teacher / "dask" / "students" / "bob" / "classic-diff.png").is_file()
    assert (teacher / "dask" / "results" / "alice.json").is_file()
    # The worker rendered the diagnosis' candidates into its own cache, under its HOME.
    cache = worker / "home" / ".cache" / "rtval"
    assert any((cache / "renders").iterdir()) and any((cache / "shipped").iterdir())
    assert not list((worker / "tmp").glob("rtval-task-*"))  # each task's folder went
    again = run(dask)
    assert again.returncode == 0 and "(3 resumed)" in again.stderr


def _sometimes_dies(task: int, marker: str) -> int:
    """A student's task; -1 kills its worker once the others' rows have arrived (the event
    named `marker`: then no other task is on that worker to be suspected with it)."""
    from distributed import Event

    if task < 0:
        Event(marker).wait(timeout=120)
        os._exit(3)  # the worker process dies mid-task, as the OOM killer would end it
    return task * 10


def test_a_dead_worker_is_one_row_and_the_rest_go_on(tmp_path: Path) -> None:
    import cloudpickle
    import dask
    from dask.distributed import LocalCluster

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    from distributed import Event

    marker = f"others-arrived-{tmp_path.name}"
    got: list[object] = []

    def arrived(value: object) -> None:
        got.append(value)
        if sum(isinstance(g, int) for g in got) == 2:
            Event(marker).set()  # run_on_dask's client is the default one here

    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 0}),
        LocalCluster(n_workers=1, threads_per_worker=3, dashboard_address=":0") as c,
    ):
        where = Executor("dask", c.scheduler_address, scheduler_timeout=30)
        run_on_dask(_sometimes_dies, [1, -1, 2], marker, arrived, _failed, where)
    assert sorted(g for g in got if isinstance(g, int)) == [10, 20]
    [dead] = [g for g in got if isinstance(g, tuple)]
    assert dead[:2] == ("failed", -1) and "worker grading it died" in str(dead[2])


def _failed(task: int, why: str) -> tuple[str, int, str]:
    return ("failed", task, why)


def test_a_program_folder_travels_with_its_links_and_modes(tmp_path: Path) -> None:
    src = tmp_path / "bob"
    (src / "src").mkdir(parents=True)
    (src / "src" / "main.cpp").write_text("int main() {}\n")
    (src / "run.sh").write_text("#!/bin/sh\n")
    (src / "run.sh").chmod(0o755)
    (src / "notes").symlink_to("/etc/passwd")  # travels as a link, for grading to refuse
    os.mkfifo(src / "pipe")  # never opened, never sent
    there = tmp_path / "worker"
    there.mkdir()
    root = unpack_program(ship_program(str(src)), there)
    assert (root / "src" / "main.cpp").read_text() == "int main() {}\n"
    assert os.access(root / "run.sh", os.X_OK) and not os.access(root / "src" / "main.cpp", os.X_OK)
    assert os.readlink(root / "notes") == "/etc/passwd" and not (root / "pipe").exists()


def test_a_file_too_large_to_send_is_refused_by_name(tmp_path: Path) -> None:
    huge = tmp_path / "huge.ppm"
    with huge.open("wb") as f:  # sparse: no disk used
        f.truncate(MAX_SHIPPED_BYTES + 1)
    with pytest.raises(ShipError, match=r"huge\.ppm: .* bytes, over the"):
        ship_images({"classic": str(huge)})
