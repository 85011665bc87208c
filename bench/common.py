"""Shared helpers for the benchmarks: timing whole processes, machine facts, JSON output."""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

# Timed processes import rtval as an installation does, from compiled bytecode: with
# PYTHONDONTWRITEBYTECODE set (some shells set it) every rtval process compiles its ~250 modules
# again, about 0.7 s of each command's time.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
SCENES = ROOT / "scenes"


def tool(name: str) -> str:
    """A console script of the project's venv (rtdemo, rtval)."""
    path = Path(sys.executable).with_name(name)
    if not path.is_file():
        raise SystemExit(f"{path} missing: run `make setup` first")
    return str(path)


def time_process(
    cmd: list[str], repeats: int = 3, env: dict[str, str] | None = None
) -> dict[str, Any]:
    """Wall time of a whole process (start-up and output included), median of `repeats`."""
    times = []
    last = None
    for _ in range(repeats):
        start = time.perf_counter()
        last = subprocess.run(
            cmd, capture_output=True, text=True, check=False, env={**os.environ, **(env or {})}
        )
        times.append(time.perf_counter() - start)
        if last.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed: {last.stderr}")
    return {
        "median_s": statistics.median(times),
        "min_s": min(times),
        "runs": times,
        "stderr": last.stderr.strip() if last else "",
    }


def run_measured(cmd: list[str]) -> tuple[subprocess.CompletedProcess[str], float, float]:
    """One run of `cmd`: (the finished process, wall seconds, CPU seconds of it and every child
    it waited for). Exits naming the command when it fails."""
    import resource

    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr}")
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    return proc, wall, cpu


def machine() -> dict[str, Any]:
    cpu = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "host": platform.node(),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "system": f"{platform.system()} {platform.release()}",
        "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def source_state() -> dict[str, Any]:
    """The commit measured and whether the work tree had uncommitted changes."""

    def git(*args: str) -> str:
        proc = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=False)
        return proc.stdout.strip() if proc.returncode == 0 else ""

    commit = git("rev-parse", "HEAD")
    return {
        "commit": commit or None,
        "dirty": bool(git("status", "--porcelain")) if commit else None,
    }


def stamped(data: dict[str, Any]) -> dict[str, Any]:
    """`data` with the machine it was measured on and the commit measured."""
    return {"machine": machine(), "source": source_state(), **data}


def write_results(name: str, data: dict[str, Any]) -> Path:
    """bench/results/NAME.json holds the latest run; NAME.history.jsonl keeps every run, one
    JSON object a line, so a slower commit can be found later."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    record = stamped(data)
    path = RESULTS / f"{name}.json"
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(record, indent=2) + "\n")
    tmp.replace(path)
    with (RESULTS / f"{name}.history.jsonl").open("a", encoding="utf-8") as history:
        history.write(json.dumps(record) + "\n")
    return path


def print_table(headers: list[str], rows: list[list[Any]]) -> None:
    cells = [[str(h) for h in headers]] + [
        [f"{c:.4g}" if isinstance(c, float) else str(c) for c in r] for r in rows
    ]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    for i, r in enumerate(cells):
        print("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=False)))
        if i == 0:
            print("  ".join("-" * w for w in widths))
