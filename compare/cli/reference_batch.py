"""`rtval reference --batch JOBS.json`: several references in one process.

Importing drjit and Mitsuba, and compiling the integrator's kernels, is paid once per
process; a batch pays it once for all its renders. JOBS.json is `{"jobs": [ARGS, ...]}`
where each ARGS is the argument list of one `rtval reference` command (scene, -o OUT,
options), so every render in a batch is still a command a person can run alone.

Output: one JSON object per line on stdout, for the caller (compare/render/jobs.py):
  {"event": "progress", "job": I, "done": N, "total": M, "elapsed": S}   samples so far
  {"event": "snapshot", "job": I, "spp": N, "seconds": S, "output": PATH}  a --snapshot
  {"event": "done", "job": I, "seconds": S, "output": PATH}            the EXR is written
  {"event": "error", "job": I, "message": TEXT}                         then exit 1
The jobs run in order; the first failure stops the batch.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

MAX_JOBS = 10_000


def read_batch(path: Path) -> list[list[str]]:
    """The jobs of a batch file; ValueError naming the file and field on anything else."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise OSError(f"{path}: cannot read batch file: {e.strerror}") from None
    except ValueError as e:
        raise ValueError(f"{path}: not JSON: {e}") from None
    jobs = data.get("jobs") if isinstance(data, dict) else None
    if not isinstance(jobs, list) or len(jobs) > MAX_JOBS:
        raise ValueError(f"{path}: jobs: expected a list of at most {MAX_JOBS} argument lists")
    for i, args in enumerate(jobs):
        if not isinstance(args, list) or not all(isinstance(a, str) for a in args):
            raise ValueError(
                f"{path}: jobs[{i}]: expected a list of strings (rtval reference's arguments)"
            )
    return jobs


def _emit(**event: Any) -> None:
    sys.stdout.write(json.dumps(event) + "\n")
    sys.stdout.flush()


def run_batch(
    path: Path,
    parse: Callable[[list[str]], argparse.Namespace],
    render: Callable[
        [argparse.Namespace, Callable[[int, int, float], None], Callable[[int, str, float], None]],
        tuple[float, str],
    ],
) -> int:
    """`parse` turns one job's arguments into options (exits on bad ones, caught here);
    `render` renders them to their -o file, reporting (done, total, elapsed) and each
    snapshot written (spp, path, seconds), and returns its wall time and a summary."""
    jobs = read_batch(path)
    for i, args in enumerate(jobs):
        start = time.perf_counter()
        try:
            options = parse(args)

            def report(done: int, total: int, elapsed: float, i: int = i) -> None:
                _emit(event="progress", job=i, done=done, total=total, elapsed=elapsed)

            def snapshot(spp: int, output: str, seconds: float, i: int = i) -> None:
                _emit(event="snapshot", job=i, spp=spp, seconds=seconds, output=output)

            render(options, report, snapshot)
        except SystemExit:  # argparse has printed why on stderr
            _emit(event="error", job=i, message=f"bad arguments: {' '.join(args)}")
            return 1
        except Exception as e:  # reported per job; the caller names the command
            print(f"rtval reference: job {i}: {e}", file=sys.stderr)
            _emit(event="error", job=i, message=str(e))
            return 1
        _emit(event="done", job=i, seconds=time.perf_counter() - start, output=options.output)
    return 0
