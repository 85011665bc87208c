"""Renders as commands, run through the shared render cache (cache.py).

A job is the command a person could type, `rtdemo render ...` or `rtval reference ...`,
with the scene and output paths as placeholders. Demo jobs run as processes (in a pool);
every Mitsuba job that is not cached runs in ONE `rtval reference --batch` process, since
importing drjit/Mitsuba and warming its JIT costs seconds per process
(bench/bench_reference_batch.py measures it). The batch process reports progress and each
finished render as JSON lines on stdout (compare/cli/reference_batch.py).
"""

from __future__ import annotations

import contextlib
import json
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from compare.errors import ToolError
from compare.render.cache import RenderCache, render_key
from compare.render.progress import Progress
from compare.render.runner import rtdemo_path

T = TypeVar("T")
# A passing render (read_passing) made in this long or longer is kept in the cache after all:
# the deepest candidates of a search take seconds, and a later search asks for them again.
PASSING_KEEP_SECONDS = 0.5


@dataclass
class RenderJob:
    key: str  # a name within one command, e.g. "demo-paper-cpu"
    label: str
    tool: str  # "rtdemo" | "rtval"
    args: list[str]  # after the tool; "{scene}" and "{out}" stand for the two paths
    family: str  # for charts: e.g. "demo paper cpu", "mitsuba whitted llvm"
    spp: int = 1
    scene: str = ""  # the scene file the job renders
    executable: str | None = None  # another rtdemo build (rtval check --rtdemo)
    cached: bool = field(default=False, compare=False)
    seconds: float = field(default=0.0, compare=False)  # wall time of the command when run
    cache_key: str = field(default="", compare=False)
    info: dict[str, Any] = field(default_factory=dict, compare=False)  # the cache's facts
    # Seconds the command may run before its process group is killed (RenderTimeLimit);
    # None: no limit. Not in the cache key: a render made within it is the same render.
    time_limit: float | None = field(default=None, compare=False)
    # Rays an rtdemo render may trace (rtdemo render --ray-budget; RenderRayBudget past it);
    # None: no limit. Not in the cache key either, for the same reason.
    ray_budget: int | None = field(default=None, compare=False)

    def command(self, out: str | Path, scene: str | Path | None = None) -> list[str]:
        values = {"{out}": str(out), "{scene}": str(scene if scene is not None else self.scene)}
        return [self.tool, *[values.get(a, a) for a in self.args]]

    def command_text(self, out: str | Path, scene: str | Path | None = None) -> str:
        return shlex.join(self.command(out, scene))

    def exr(self, cache: RenderCache) -> Path:
        return cache.exr(self.cache_key)


class RenderLimit(ToolError):
    """A render was stopped by one of its job's limits (a search skips the candidate)."""


class RenderTimeLimit(RenderLimit):
    """A render ran past its job's time_limit and was stopped."""


class RenderRayBudget(RenderLimit):
    """An rtdemo render traced more rays than its job's ray_budget: rtdemo stopped it
    itself (exit RAY_BUDGET_EXIT, no output)."""


# rtdemo's exit status for a render stopped by --ray-budget (docs/commands/exit-codes.md).
RAY_BUDGET_EXIT = 6


def _executable(job: RenderJob) -> str:
    if job.tool == "rtdemo":
        return job.executable or rtdemo_path()
    return str(Path(sys.executable).with_name(job.tool))


class _Counter:
    """[n/N] lines from several threads."""

    def __init__(self, total: int, progress: Progress) -> None:
        self.total, self.done, self.progress = total, 0, progress
        self.lock = threading.Lock()

    def finished(self, job: RenderJob) -> None:
        with self.lock:
            self.done += 1
            state = "cached" if job.cached else f"{job.seconds:.1f} s"
            self.progress.line(f"[{self.done}/{self.total}] {job.label}: {state}")

    def update(self, label: str, done: int, total: int, elapsed: float) -> None:
        with self.lock:
            self.progress.update(f"[{self.done + 1}/{self.total}] {label}", done, total, elapsed)


def run_jobs(
    jobs: list[RenderJob],
    cache: RenderCache,
    *,
    jobs_in_parallel: int = 1,
    progress: Progress | None = None,
) -> dict[str, float]:
    """Makes every job's render in the cache (job.exr(cache)); returns seconds per phase."""
    progress = progress or Progress()
    for job in jobs:
        set_key(job)
    counter = _Counter(len(jobs), progress)
    todo: list[RenderJob] = []
    seen: set[str] = set()
    for job in jobs:
        info = cache.info(job.cache_key)
        if info is not None:
            job.cached, job.info = True, info
            job.seconds = float(info.get("seconds", 0.0))
            counter.finished(job)
        elif job.cache_key in seen:  # the same render twice in one list: made once
            todo.append(job)
        else:
            seen.add(job.cache_key)
            todo.append(job)
    cache.count(hits=len(jobs) - len(todo), misses=len(seen))
    demo = [j for j in todo if j.tool == "rtdemo"]
    mitsuba = [j for j in todo if j.tool != "rtdemo"]
    timings: dict[str, float] = {}
    start = time.perf_counter()
    # Demo renders first, then Mitsuba: never both at once, so that render times stay honest.
    with ThreadPoolExecutor(max_workers=max(1, jobs_in_parallel)) as pool:
        list(pool.map(lambda j: _run_demo(j, cache, counter), _unique(demo)))
    timings["renders: demo"] = time.perf_counter() - start
    start = time.perf_counter()
    if mitsuba:
        _run_batch(_unique(mitsuba), cache, counter)
    timings["renders: Mitsuba"] = time.perf_counter() - start
    for job in todo:  # duplicates take the entry their twin made
        if not job.info:
            info = cache.info(job.cache_key)
            if info is None:
                raise ToolError(f"{job.label}: no render in the cache after running it")
            job.cached, job.info = True, info
            counter.finished(job)
    if todo:
        cache.evict()  # what this run just used is within the grace period and stays
    return timings


def set_key(job: RenderJob) -> str:
    """The job's cache key (render_key of its command, scene and renderer), kept on it."""
    if not job.scene:
        raise ValueError(f"render job {job.key} has no scene")
    job.cache_key = render_key(job.tool, job.args, Path(job.scene), job.executable)
    return job.cache_key


def render_one(
    job: RenderJob, cache: RenderCache, *, extra_args: Sequence[str] = (), again: bool = False
) -> bool:
    """Makes one rtdemo job's render in the cache (job.exr(cache)) without progress lines,
    for the many small renders of a search; returns whether it was cached. `extra_args`
    change no pixel (--threads) and stay out of the key; `again`: render even when cached
    (the entry could not be read). Counting and eviction are the caller's, once for all
    (RenderCache.count, RenderCache.evict)."""
    if job.tool != "rtdemo":
        raise ValueError(f"render job {job.key}: render_one runs rtdemo jobs only")
    key = set_key(job)
    info = None if again else cache.info(key)
    if info is not None:
        job.cached, job.info = True, info
        job.seconds = float(info.get("seconds", 0.0))
        return True
    _make_demo(job, cache, extra_args)
    return False


def read_passing(
    job: RenderJob,
    cache: RenderCache,
    read: Callable[[Path], T],
    *,
    extra_args: Sequence[str] = (),
) -> tuple[T, bool]:
    """The job's render as `read` makes it of the file, for a render looked at once (a
    search's candidate, scored and dropped): from the cache where it is there (True); else
    made into a temporary file, read there and removed, and stored only when it took
    PASSING_KEEP_SECONDS or more. A quicker one costs more to keep than to make again: its
    hash, its sidecar and the kernel writing it to disk (11.5 MB at 1200x800; bench/NOTES.md)."""
    if job.tool != "rtdemo":
        raise ValueError(f"render job {job.key}: read_passing runs rtdemo jobs only")
    key = set_key(job)
    info = cache.info(key)
    if info is not None:  # its cost known, as render_one's hits: the time limits follow it
        job.cached, job.info = True, info
        job.seconds = float(info.get("seconds", 0.0))
        return read(job.exr(cache)), True
    tmp = cache.tmp_path(job.cache_key)
    try:
        _run_into(job, tmp, extra_args)
        value = read(tmp)
        if job.seconds >= PASSING_KEEP_SECONDS:
            job.info = cache.store(job.cache_key, tmp, _facts(job))
        return value, False
    finally:  # read, stored, interrupted or failed: leave nothing behind
        tmp.unlink(missing_ok=True)


def _unique(jobs: Iterable[RenderJob]) -> list[RenderJob]:
    out, seen = [], set()
    for j in jobs:
        if j.cache_key not in seen:
            seen.add(j.cache_key)
            out.append(j)
    return out


def _run_demo(job: RenderJob, cache: RenderCache, counter: _Counter) -> None:
    _make_demo(job, cache)
    counter.finished(job)


def _make_demo(job: RenderJob, cache: RenderCache, extra_args: Sequence[str] = ()) -> None:
    """Runs an rtdemo job into a temporary file of the cache and stores it under its key."""
    tmp = cache.tmp_path(job.cache_key)
    try:
        _run_into(job, tmp, extra_args)
        job.info = cache.store(job.cache_key, tmp, _facts(job))
    finally:  # interrupted or failed: leave nothing that looks like a result
        tmp.unlink(missing_ok=True)


def _run_into(job: RenderJob, out: Path, extra_args: Sequence[str]) -> None:
    """Runs an rtdemo job writing `out`; its wall time into job.seconds."""
    cmd = [*job.command(out), *extra_args]
    if job.ray_budget is not None:
        cmd += ["--ray-budget", str(job.ray_budget)]
    cmd[0] = _executable(job)
    start = time.perf_counter()
    if job.time_limit is None:
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    else:
        proc = _run_limited(cmd, job)
    job.seconds = time.perf_counter() - start
    if proc.returncode == RAY_BUDGET_EXIT and job.ray_budget is not None:
        said = (proc.stderr.strip().splitlines() or [f"ray budget of {job.ray_budget} rays"])[-1]
        said = said.removeprefix("rtdemo: ").removesuffix("; no output written")
        raise RenderRayBudget(f"{job.label} stopped: {said}")
    if proc.returncode != 0:
        raise ToolError(
            f"{job.label} failed (exit {proc.returncode}): {job.command_text('OUT.exr')}\n"
            f"{proc.stderr.strip()[-2000:]}"
        )


def _run_limited(cmd: list[str], job: RenderJob) -> subprocess.CompletedProcess[str]:
    """Runs cmd in a process group of its own, killed whole once job.time_limit passes (or
    when the caller is interrupted)."""
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        out, err = proc.communicate(timeout=job.time_limit)
    except BaseException as e:
        _kill_group(proc)
        if isinstance(e, subprocess.TimeoutExpired):
            raise RenderTimeLimit(
                f"{job.label} stopped after {job.time_limit:.1f} s (its time limit): "
                f"{job.command_text('OUT.exr')}"
            ) from None
        raise
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def _kill_group(proc: subprocess.Popen[str]) -> None:
    with contextlib.suppress(ProcessLookupError):  # already gone
        os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()


def _facts(job: RenderJob) -> dict[str, Any]:
    return {"seconds": job.seconds, "label": job.label, "command": job.command("OUT.exr")}


_NOT_PREFIXES = ("--time-budget", "--target-stderr")  # they stop after a number not known ahead


def _spp_free(job: RenderJob) -> tuple[str, ...] | None:
    """The job's command without its --spp value: jobs alike in it differ only in samples."""
    if "--spp" not in job.args or any(a in job.args for a in _NOT_PREFIXES):
        return None
    i = job.args.index("--spp")
    return (job.scene, *job.args[:i], *job.args[i + 2 :])


def _spp(job: RenderJob) -> int:
    return int(job.args[job.args.index("--spp") + 1]) if "--spp" in job.args else 1


def _prefix_groups(jobs: list[RenderJob]) -> list[tuple[RenderJob, list[RenderJob]]]:
    """(the job with the most samples, the jobs alike with fewer) for each group of jobs
    that differ only in --spp. The fewer-sample ones become --snapshot's of the first:
    the very image of their own command, taken on its way (mitsuba_ref/reference.py)."""
    groups: dict[object, list[RenderJob]] = {}
    for j in jobs:
        groups.setdefault(_spp_free(j) or j.cache_key, []).append(j)
    out = []
    for alike in groups.values():
        alike.sort(key=_spp, reverse=True)
        out.append((alike[0], alike[1:]))
    return out


def _run_batch(jobs: list[RenderJob], cache: RenderCache, counter: _Counter) -> None:
    """All Mitsuba jobs in one `rtval reference --batch` process, a job's fewer-sample
    twins as its snapshots."""
    groups = _prefix_groups(jobs)
    jobs = [carrier for carrier, _ in groups]
    outs = [cache.tmp_path(j.cache_key) for j in jobs]
    snaps = {
        (i, _spp(s)): (s, cache.tmp_path(s.cache_key))
        for i, (_, ss) in enumerate(groups)
        for s in ss
    }
    spec = {"jobs": [j.command(out)[2:] for j, out in zip(jobs, outs, strict=True)]}
    for (i, spp), (_, path) in snaps.items():
        spec["jobs"][i] += ["--snapshot", f"{spp}:{path}"]
    with tempfile.TemporaryDirectory(prefix="rtval-batch-") as tmp_name:
        batch_file = Path(tmp_name) / "jobs.json"
        batch_file.write_text(json.dumps(spec, indent=1))
        log = Path(tmp_name) / "stderr.txt"
        cmd = [
            str(Path(sys.executable).with_name("rtval")),
            "reference",
            "--batch",
            str(batch_file),
        ]
        try:
            with log.open("w") as err:
                proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, text=True)
                assert proc.stdout is not None
                failed: int | None = None
                try:
                    for line in proc.stdout:
                        failed = _event(line, jobs, outs, snaps, cache, counter, failed)
                    proc.wait()
                except BaseException:
                    proc.kill()
                    proc.wait()
                    raise
                finally:
                    proc.stdout.close()
            if proc.returncode != 0 or failed is not None:
                which = jobs[failed] if failed is not None else None
                head = (
                    f"{which.label} failed: {which.command_text('OUT.exr')}"
                    if which
                    else f"rtval reference --batch failed (exit {proc.returncode})"
                )
                raise ToolError(f"{head}\n{log.read_text().strip()[-2000:]}")
        finally:
            for out in [*outs, *(path for _, path in snaps.values())]:
                out.unlink(missing_ok=True)


def _event(
    line: str,
    jobs: list[RenderJob],
    outs: list[Path],
    snaps: dict[tuple[int, int], tuple[RenderJob, Path]],
    cache: RenderCache,
    counter: _Counter,
    failed: int | None,
) -> int | None:
    try:
        ev = json.loads(line)
        i = int(ev["job"])
        job = jobs[i]
    except (ValueError, KeyError, IndexError, TypeError):
        return failed  # not an event (a library printing to stdout)
    kind = ev.get("event")
    if kind == "progress":
        counter.update(job.label, int(ev["done"]), int(ev["total"]), float(ev["elapsed"]))
    elif kind == "done":
        job.seconds = float(ev["seconds"])
        job.info = cache.store(job.cache_key, outs[i], _facts(job))
        counter.finished(job)
    elif kind == "snapshot":  # a fewer-sample job's image, seconds from the carrier's start
        snap, path = snaps[i, int(ev["spp"])]
        snap.seconds = float(ev["seconds"])
        snap.info = cache.store(snap.cache_key, path, _facts(snap))
        counter.finished(snap)
    elif kind == "error":
        return i
    return failed
