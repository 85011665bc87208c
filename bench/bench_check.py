"""`rtval check --renderer` overhead: the time a check adds to the renderer's own,
per 640x480 scene. The renderer is tests/foreign/classic_tracer.cpp (compiled here; PPM out).

  warm pass   masks cached, the render equals its baseline: what a CI re-run costs
  cold pass   first run: the rtdemo AOV render and the masks are made and cached
  warm fail   shadows broken: the failing case also computes FLIP and per-effect verdicts

Overhead = the case's time minus the renderer's wall time (CaseResult.overhead_seconds),
median of --repeats in-process runs, and this process's CPU time per case (the renderer is a
child, so none of it is counted; on a shared, loaded machine wall time overstates); `process` adds a whole `rtval check` process (Python
start-up, imports) divided by the scenes it checks. Goal: warm pass <= 1 s per scene.
Usage: python bench/bench_check.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, SCENES, print_table, tool, write_results

from compare.check import run as check
from compare.render import foreign
from compare.render.cache import RenderCache

SIZE = (640, 480)
GOAL_S = 1.0


def _compile(work: Path) -> Path:
    exe = work / "classic_tracer"
    src = ROOT / "tests" / "foreign" / "classic_tracer.cpp"
    if not exe.is_file() or exe.stat().st_mtime < src.stat().st_mtime:
        subprocess.run(["g++", "-O2", "-std=c++17", "-o", str(exe), str(src)], check=True)
    return exe


CPU: dict[str, list[float]] = {}


def _run(settings: check.CheckSettings, scenario: str = "") -> list[check.CaseResult]:
    """Runs a check; records this process's CPU time per case (the renderer is a child process,
    so none of its time is in it): on a loaded machine wall time overstates the overhead."""
    cpu = time.process_time()
    results = check.run_check(settings, progress=lambda _: None)
    CPU.setdefault(scenario, []).append((time.process_time() - cpu) / len(results))
    return results


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    work = ROOT / "build" / "bench-check"
    work.mkdir(parents=True, exist_ok=True)
    exe = _compile(work)
    template = f"{exe} {{out}} {{width}} {{height}}"
    cmd = foreign.parse_command(template, "bench", "ppm")
    scenes = [str(SCENES / "classic.json"), str(SCENES / "paper.json")]
    baselines = work / "baselines"
    shutil.rmtree(baselines, ignore_errors=True)

    def settings(cache: Path, **kw: object) -> check.CheckSettings:
        return check.CheckSettings(
            scenes=scenes,
            baseline_dir=baselines,
            size=SIZE,
            renderer=cmd,
            cache=RenderCache(cache),
            **kw,  # type: ignore[arg-type]
        )

    cache = work / "cache"
    shutil.rmtree(cache, ignore_errors=True)
    _run(settings(cache, update=True))  # baselines (and a warm cache)
    samples: dict[str, list[float]] = {"cold pass": [], "warm pass": [], "warm fail": []}
    render_s: dict[str, list[float]] = {k: [] for k in samples}
    for _ in range(args.repeats):
        with tempfile.TemporaryDirectory() as cold:
            for r in _run(settings(Path(cold)), "cold pass"):
                assert r.status == "pass", r.reasons
                samples["cold pass"].append(r.overhead_seconds)
                render_s["cold pass"].append(r.seconds)
        for r in _run(settings(cache), "warm pass"):
            assert r.status == "pass", r.reasons
            samples["warm pass"].append(r.overhead_seconds)
            render_s["warm pass"].append(r.seconds)
        os.environ["RTVAL_TEST_BREAK"] = "shadows"
        try:
            for r in _run(settings(cache, keep_images=True), "warm fail"):
                assert r.status == "fail"
                samples["warm fail"].append(r.overhead_seconds)
                render_s["warm fail"].append(r.seconds)
        finally:
            del os.environ["RTVAL_TEST_BREAK"]
    # The whole process: start-up and imports spread over the scenes it checks.
    rtval = tool("rtval")
    proc_overhead = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        proc = subprocess.run(
            [rtval, "check", "--renderer", template, "--renderer-name", "bench",
             "--output-format", "ppm", "--size", f"{SIZE[0]}x{SIZE[1]}", "--baseline",
             str(baselines), "--cache", str(cache), "--scenes", *scenes,
             "--json", str(work / "process.json")],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        wall = time.perf_counter() - start
        assert proc.returncode == 0, proc.stdout + proc.stderr
        import json

        cases = json.loads((work / "process.json").read_text())["cases"]
        proc_overhead.append((wall - sum(c["seconds"] for c in cases)) / len(cases))
    rows, results = [], []
    for name, values in samples.items():
        med = statistics.median(values)
        cpu = statistics.median(CPU[name])
        renderer = statistics.median(render_s[name])
        rows.append([name, renderer, med, max(values), cpu, med <= GOAL_S, cpu <= GOAL_S])
        results.append(
            {
                "scenario": name,
                "renderer_median_s": statistics.median(render_s[name]),
                "overhead_median_s": med,
                "overhead_max_s": max(values),
                "samples_s": values,
                "overhead_cpu_median_s": cpu,
                "within_goal": med <= GOAL_S,
                "cpu_within_goal": cpu <= GOAL_S,
            }
        )
    med = statistics.median(proc_overhead)
    rows.append(["warm pass, whole process", "", med, max(proc_overhead), "", med <= GOAL_S, ""])
    results.append(
        {
            "scenario": "warm pass, whole process",
            "overhead_median_s": med,
            "overhead_max_s": max(proc_overhead),
            "samples_s": proc_overhead,
            "within_goal": med <= GOAL_S,
        }
    )
    print(f"rtval check overhead per {SIZE[0]}x{SIZE[1]} scene (goal <= {GOAL_S} s), "
          f"{args.repeats} repeats x {len(scenes)} scenes")  # fmt: skip
    print(f"load average at the end: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print_table(
        ["scenario", "renderer s", "overhead s", "max s", "overhead CPU s", "wall ok", "CPU ok"],
        rows,
    )
    path = write_results(
        "check",
        {
            "size": list(SIZE),
            "goal_s": GOAL_S,
            "repeats": args.repeats,
            "load_average": os.getloadavg()[0],
            "results": results,
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
