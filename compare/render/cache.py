"""Renders as commands, cached by content hash.

A render is the command a person could type (`rtdemo render ...`, `rtval reference ...`).
Its cache key hashes the command (output path left out), the scene file's bytes and the
renderer's identity (the rtdemo binary's bytes, or the mitsuba_ref sources plus the Mitsuba
version), so a re-run with nothing changed renders nothing and any change re-renders.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import shlex
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from compare.files import sha256_file, write_atomic
from compare.render.runner import ToolError, rtdemo_path


@dataclass
class RenderJob:
    key: str  # file stem in the report folder, e.g. "demo-paper-cpu-1spp"
    label: str
    tool: str  # "rtdemo" | "rtval"
    args: list[str]  # arguments after the tool; "{out}" stands for the output EXR
    family: str  # for charts: e.g. "demo paper cpu", "mitsuba whitted llvm"
    spp: int = 1
    cached: bool = field(default=False, compare=False)
    seconds: float = field(default=0.0, compare=False)  # wall time of the command when run

    def command(self, out: Path) -> list[str]:
        return [self.tool, *[a.replace("{out}", str(out)) for a in self.args]]

    def command_text(self, out: Path) -> str:
        return shlex.join(self.command(out))


@cache
def renderer_identity(tool: str) -> str:
    if tool == "rtdemo":
        return sha256_file(Path(rtdemo_path()))
    h = hashlib.sha256()
    # The renderer and the scene loader it reads with; report code changes must not re-render.
    for pkg in ("mitsuba_ref", "scene_model"):
        root = Path(__file__).resolve().parents[2] / pkg
        for p in sorted(root.glob("*.py")):
            h.update(p.read_bytes())
    for dist in ("mitsuba", "drjit"):
        h.update(importlib.metadata.version(dist).encode())
    return h.hexdigest()


def cache_key(job: RenderJob, scene_file: Path) -> str:
    h = hashlib.sha256()
    h.update(shlex.join(job.args).encode())
    h.update(sha256_file(scene_file).encode())
    h.update(renderer_identity(job.tool).encode())
    return h.hexdigest()[:20]


def _executable(tool: str) -> str:
    if tool == "rtdemo":
        return rtdemo_path()
    return str(Path(sys.executable).with_name(tool))


def run_jobs(
    jobs: list[RenderJob],
    scene_file: Path,
    cache_dir: Path,
    out_dir: Path,
    *,
    jobs_in_parallel: int = 1,
    progress: Callable[[str], None] = print,
) -> None:
    """Makes out_dir/<key>.exr for every job, from the cache when the key matches."""
    cache_dir.mkdir(parents=True, exist_ok=True)
    out_dir.mkdir(parents=True, exist_ok=True)
    total = len(jobs)
    done = [0]

    def one(job: RenderJob) -> None:
        cached = cache_dir / f"{job.key}-{cache_key(job, scene_file)}.exr"
        target = out_dir / f"{job.key}.exr"
        if cached.is_file():
            job.cached = True
        else:
            tmp = cached.with_name(cached.stem + ".partial.exr")
            cmd = job.command(tmp)
            cmd[0] = _executable(cmd[0])
            start = time.perf_counter()
            try:
                proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            except BaseException:  # interrupted: leave nothing that looks like a result
                tmp.unlink(missing_ok=True)
                raise
            job.seconds = time.perf_counter() - start
            if proc.returncode != 0:
                tmp.unlink(missing_ok=True)
                raise ToolError(
                    f"{job.label} failed (exit {proc.returncode}): "
                    f"{job.command_text(target)}\n{proc.stderr.strip()[-2000:]}"
                )
            tmp.replace(cached)
        write_atomic(target, cached.read_bytes())
        done[0] += 1
        state = "cached" if job.cached else f"{job.seconds:.1f} s"
        progress(f"[{done[0]}/{total}] {job.label}: {state}")

    # Mitsuba runs take the whole machine; demo runs are short. Run demo jobs in the pool.
    demo = [j for j in jobs if j.tool == "rtdemo"]
    other = [j for j in jobs if j.tool != "rtdemo"]
    with ThreadPoolExecutor(max_workers=max(1, jobs_in_parallel)) as pool:
        list(pool.map(one, demo))
        list(pool.map(one, other))
