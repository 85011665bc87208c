"""Seconds per submission of `rtval grade` with failing submissions diagnosed (issue 32: 200
image submissions at 640x480 against classic, half of them wrong, <= 0.5 s per submission).

The class: N submissions (--submissions, default 14), half the numpy classic program (they
pass), half its student-style variants in turn (they fail; tests/student_variants.py), as
truncating PPMs, graded against `classic` with the local process pool (--jobs 2), each run a
whole `rtval grade` process into a fresh folder with its own render cache (--cache):
  1. --no-diagnose;
  2. diagnosing, with a cache that holds the model's renders only (every candidate rendered
     once for the class);
  3. diagnosing a second class of the same images under other names, with the cache that
     run 2 left (every candidate read).
Added cost per failing submission = (run - run 1) / failing submissions. Prints a table and
writes bench/results/grade_diagnosis.json.

    python bench/bench_grade_diagnosis.py [--submissions 200] [--size 640x480] [--jobs 2]
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

from common import ROOT, SCENES, print_table, run_measured, tool, write_results

sys.path.insert(0, str(ROOT / "tests"))

TARGET_S_PER_SUBMISSION = 0.5


def _grade(
    subs: Path, out: Path, cache: Path, args: argparse.Namespace, *extra: str
) -> dict[str, Any]:
    cmd = [tool("rtval"), "grade", str(subs), "--scene", str(SCENES / "classic.json"),
           "--size", args.size, "--against", "classic", "--out", str(out), "--jobs",
           str(args.jobs), "--cache", str(cache), *extra]  # fmt: skip
    _, wall, cpu = run_measured(cmd)
    with (out / "gradebook.csv").open() as f:
        book = {r["student"]: r for r in csv.DictReader(f)}
    return {
        "wall_s": wall,
        "cpu_s": cpu,
        "submissions": len(book),
        "failing": sum(r["status"] == "fail" for r in book.values()),
        "diagnosis": {k: r["diagnosis"] for k, r in book.items()},
    }


def _class(folder: Path, n: int, images: dict[str, Path], suffix: str) -> None:
    """n submissions: every other one the exact program, the rest the variants in turn."""
    wrong = [v for v in images if v != "exact"]
    folder.mkdir()
    for i in range(n):
        v = "exact" if i % 2 == 0 else wrong[(i // 2) % len(wrong)]
        shutil.copy(images[v], folder / f"s{i:03d}_{v}{suffix}.ppm")


def main() -> None:
    from student_variants import VARIANTS, render_variant

    from scene_model.scene import load_scene

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--submissions", type=int, default=14)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    scene = load_scene(SCENES / "classic.json")
    runs: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="rtval-bench-grade-diagnosis-") as tmp:
        root = Path(tmp)
        images = {
            v: render_variant(scene, v, w, h, root / f"{v}.ppm") for v in ["exact", *VARIANTS]
        }
        _class(root / "subs", args.submissions, images, "")
        _class(root / "twins", args.submissions, images, "_twin")
        # The model renders once, outside the timing: every run starts from a copy of it.
        _grade(root / "subs", root / "warm", root / "warm-cache", args, "--no-diagnose")
        for name, folder, extra, start_cache in (
            ("no diagnosis", "subs", ["--no-diagnose"], "warm-cache"),
            ("diagnosis, model renders cached", "subs", [], "warm-cache"),
            ("diagnosis, candidates cached (second class)", "twins", [], "cache-2"),
        ):
            cache = root / f"cache-{len(runs) + 1}"
            shutil.copytree(root / start_cache, cache)
            runs[name] = _grade(root / folder, root / f"out-{len(runs) + 1}", cache, args, *extra)
    _report(runs, args, (w, h))


def _report(
    runs: dict[str, dict[str, Any]], args: argparse.Namespace, size: tuple[int, int]
) -> None:
    base = runs["no diagnosis"]
    rows, results = [], []
    for name, r in runs.items():
        per = r["wall_s"] / max(1, r["submissions"])
        added = (r["wall_s"] - base["wall_s"]) / max(1, r["failing"])
        added_cpu = (r["cpu_s"] - base["cpu_s"]) / max(1, r["failing"])
        rows.append([name, r["submissions"], r["failing"], r["wall_s"], per, added, added_cpu,
                     "yes" if per <= TARGET_S_PER_SUBMISSION else "NO"])  # fmt: skip
        results.append({"run": name, **r, "s_per_submission": per, "added_s_per_failing": added,
                        "added_cpu_s_per_failing": added_cpu})  # fmt: skip
    print_table(["run", "submissions", "failing", "wall s", "s / submission",
                 "added s / failing", "added cpu s / failing",
                 f"<= {TARGET_S_PER_SUBMISSION} s"], rows)  # fmt: skip
    cells = sorted(set(runs["diagnosis, model renders cached"]["diagnosis"].values()))
    for cell in cells:
        print(f"  {cell or '(passes: not diagnosed)'}")
    load = os.getloadavg()[0]
    path = write_results("grade_diagnosis", {"size": list(size), "jobs": args.jobs,
                                             "submissions": args.submissions, "load_1min": load,
                                             "target_s_per_submission": TARGET_S_PER_SUBMISSION,
                                             "results": results})  # fmt: skip
    print(f"load average {load:.1f}; wrote {path}")


if __name__ == "__main__":
    main()
