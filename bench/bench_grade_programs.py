"""Grading a class of programs: build and run in the sandbox (compare/sandbox/bwrap.py).

1. The sandbox's cost per run: `true` through run_sandboxed in the sandbox, the same without
   it (--unsandboxed: the launcher and prlimit only), and `true` started bare by subprocess.
2. A class of 30 small C++ programs (tests/foreign/classic_tracer.cpp, each copy a little
   different so that nothing is shared): `rtval grade --build 'g++ -O2 ...' --run '...'`
   on the classic scene at 640x480 with the local pool (--jobs 2), the model already in the
   cache; then the same command again (everything resumed). Target: the class in under 60 s
   on the shared 2-core machine.

Usage: python bench/bench_grade_programs.py [--students 30] [--repeats 20]
Writes bench/results/grade_programs.json.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, SCENES, print_table, tool, write_results

WORK = ROOT / "build" / "bench-grade-programs"
PROGRAM = ROOT / "tests" / "foreign" / "classic_tracer.cpp"
BUILD = "g++ -O2 -o rt classic_tracer.cpp"
RUN = "./rt {out} {width} {height}"


def overhead(repeats: int) -> dict[str, Any]:
    """Median seconds of `true`: in the sandbox, unsandboxed (same launcher), bare."""
    from compare.sandbox.bwrap import Limits, Workspace, run_sandboxed

    def timed(fn: Any) -> float:
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            fn()
            times.append(time.perf_counter() - start)
        return statistics.median(times)

    with Workspace() as ws:

        def sandboxed() -> None:
            assert run_sandboxed(["true"], ws, Limits(wall=30)).ok

        def unsandboxed() -> None:
            assert run_sandboxed(["true"], ws, Limits(wall=30), sandboxed=False).ok

        result = {
            "sandboxed_s": timed(sandboxed),
            "unsandboxed_s": timed(unsandboxed),
            "bare_s": timed(lambda: subprocess.run(["true"], check=True)),
        }
    result["sandbox_overhead_s"] = result["sandboxed_s"] - result["unsandboxed_s"]
    result["overhead_vs_bare_s"] = result["sandboxed_s"] - result["bare_s"]
    return result


def make_class(folder: Path, students: int) -> None:
    source = PROGRAM.read_text()
    for i in range(students):
        d = folder / f"student{i:02d}"
        d.mkdir(parents=True)
        (d / "classic_tracer.cpp").write_text(f"// student {i}\n{source}")


def grade(subs: Path, out: Path, cache: Path) -> tuple[float, subprocess.CompletedProcess[str]]:
    cmd = [tool("rtval"), "grade", str(subs), "--scene", str(SCENES / "classic.json")]
    cmd += ["--out", str(out), "--cache", str(cache), "--jobs", "2", "--build", BUILD, "--run", RUN]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"rtval grade failed: {proc.stderr[-3000:]}")
    return seconds, proc


def step_times(out: Path) -> dict[str, float]:
    builds, runs, peaks = [], [], []
    for f in (out / "results").glob("*.json"):
        program = json.loads(f.read_text())["program"]
        builds.append(program["build"]["seconds"])
        for r in program["runs"].values():
            runs.append(r["seconds"])
            peaks.append(r["peak_memory"])
    return {
        "build_median_s": statistics.median(builds),
        "run_median_s": statistics.median(runs),
        "run_peak_memory_median_mib": statistics.median(peaks) / (1 << 20),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--students", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    if shutil.which("g++") is None:
        raise SystemExit("g++ is needed for the class")
    cost = overhead(args.repeats)
    shutil.rmtree(WORK, ignore_errors=True)
    subs, cache = WORK / "subs", WORK / "cache"
    make_class(subs, args.students)
    warm = WORK / "warm"  # renders the model into the cache: not part of the class's time
    (warm / "subs").mkdir(parents=True)
    make_class(warm / "subs", 1)
    model_s, _ = grade(warm / "subs", warm / "grades", cache)
    class_s, _ = grade(subs, WORK / "grades", cache)
    book = json.loads((WORK / "grades" / "gradebook.json").read_text())["students"]
    passed = sum(s["status"] == "pass" for s in book)
    resume_s, again = grade(subs, WORK / "grades", cache)
    steps = step_times(WORK / "grades")
    rows = [
        ["true in the sandbox (median)", cost["sandboxed_s"]],
        ["true unsandboxed, same launcher", cost["unsandboxed_s"]],
        ["true started bare", cost["bare_s"]],
        ["sandbox overhead per run", cost["sandbox_overhead_s"]],
        ["first grade: model render + 1 student", model_s],
        [f"class of {args.students} programs (model cached)", class_s],
        ["  per student (class / students)", class_s / args.students],
        ["  build, median (g++ -O2)", steps["build_median_s"]],
        ["  run at 640x480, median", steps["run_median_s"]],
        ["the same class again (all resumed)", resume_s],
    ]
    print_table(["what", "seconds"], rows)
    print(
        f"{passed}/{args.students} passed; class target < 60 s: {'met' if class_s < 60 else 'MISSED'}"
    )
    path = write_results(
        "grade_programs",
        {
            "students": args.students,
            "repeats": args.repeats,
            "build": BUILD,
            "run": RUN,
            "overhead": cost,
            "model_and_one_student_s": model_s,
            "class_s": class_s,
            "per_student_s": class_s / args.students,
            "resume_s": resume_s,
            "passed": passed,
            "resumed_line": again.stderr.strip().splitlines()[-1] if again.stderr else "",
            **steps,
        },
    )
    print(path)


if __name__ == "__main__":
    main()
