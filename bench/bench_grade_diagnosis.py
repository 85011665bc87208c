"""What diagnosing failing submissions adds to `rtval grade` at 640x480.

The class: the numpy classic program (passes) and its six student-style variants (fail;
tests/student_variants.py), truncating PPMs, graded against `classic` with the local process
pool (--jobs 2), each run a whole `rtval grade` process into a fresh folder:
  1. --no-diagnose;
  2. diagnosing, with an empty candidate cache (OUT/cache/diagnose);
  3. diagnosing a second class of the same images under other names, with the cache that run 2
     left (identical candidates across students render once).
Added cost per failing submission = (run - run 1) / failing submissions. Prints a table and
writes bench/results/grade_diagnosis.json.

    python bench/bench_grade_diagnosis.py [--size 640x480] [--jobs 2]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from common import ROOT, SCENES, print_table, tool, write_results

sys.path.insert(0, str(ROOT / "tests"))


def _grade(subs: Path, out: Path, size: str, jobs: int, *extra: str) -> dict[str, Any]:
    cmd = [tool("rtval"), "grade", str(subs), "--scene", str(SCENES / "classic.json"),
           "--size", size, "--against", "classic", "--out", str(out), "--jobs", str(jobs),
           *extra]  # fmt: skip
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr}")
    with (out / "gradebook.csv").open() as f:
        book = {r["student"]: r for r in csv.DictReader(f)}
    renders = hits = 0
    for p in (out / "results").glob("*.json"):
        for s in json.loads(p.read_text())["scenes"]:
            c = (s.get("diagnosis_detail") or {}).get("cache") or {}
            renders += c.get("rendered", 0)
            hits += c.get("hits", 0)
    return {
        "wall_s": wall,
        "cpu_s": (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime),
        "failing": sum(r["status"] == "fail" for r in book.values()),
        "diagnosis": {k: r["diagnosis"] for k, r in book.items()},
        "candidate_renders": renders,
        "cache_hits": hits,
    }


def main() -> None:
    from student_variants import VARIANTS, render_variant

    from scene_model.scene import load_scene

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    scene = load_scene(SCENES / "classic.json")
    with tempfile.TemporaryDirectory(prefix="rtval-bench-grade-diagnosis-") as tmp:
        root = Path(tmp)
        subs, twins = root / "subs", root / "twins"
        subs.mkdir()
        twins.mkdir()
        for v in ["exact", *VARIANTS]:
            render_variant(scene, v, w, h, subs / f"{v}.ppm")
            shutil.copy(subs / f"{v}.ppm", twins / f"{v}_twin.ppm")
        # The model renders once, outside the timing: every run copies its cache.
        _grade(subs, root / "warm", args.size, args.jobs, "--no-diagnose")
        runs: dict[str, dict[str, Any]] = {}
        for name, folder, extra, diag_cache in (
            ("no diagnosis", subs, ["--no-diagnose"], None),
            ("diagnosis, empty cache", subs, [], None),
            ("diagnosis, cache of run 2", twins, [], root / "diagnosis, empty cache"),
        ):
            out = root / name
            shutil.copytree(root / "warm" / "cache", out / "cache")
            if diag_cache is not None:
                shutil.copytree(diag_cache / "cache" / "diagnose", out / "cache" / "diagnose")
            runs[name] = _grade(folder, out, args.size, args.jobs, *extra)
    base = runs["no diagnosis"]
    rows, results = [], []
    for name, r in runs.items():
        added = (r["wall_s"] - base["wall_s"]) / max(1, r["failing"])
        added_cpu = (r["cpu_s"] - base["cpu_s"]) / max(1, r["failing"])
        rows.append([name, r["failing"], r["wall_s"], added, added_cpu, r["candidate_renders"],
                     r["cache_hits"]])  # fmt: skip
        results.append({"run": name, **r, "added_s_per_failing": added,
                        "added_cpu_s_per_failing": added_cpu})  # fmt: skip
    print_table(["run", "failing", "wall s", "added s / failing", "added cpu s / failing",
                 "renders", "cache hits"], rows)  # fmt: skip
    for k, v in runs["diagnosis, empty cache"]["diagnosis"].items():
        print(f"  {k}: {v or '(passes: not diagnosed)'}")
    load = os.getloadavg()[0]
    out_path = write_results(
        "grade_diagnosis",
        {"size": [w, h], "jobs": args.jobs, "load_1min": load, "results": results},
    )
    print(f"load average {load:.1f}; wrote {out_path}")


if __name__ == "__main__":
    main()
