"""Grading throughput (issue 9): 200 synthetic submissions at 640x480 graded with the local
process pool (2 processes) and with a 2-worker Dask LocalCluster. The reference render is
made once (cached); each executor grades into a fresh folder, so nothing is resumed.
Usage: python bench/bench_grade.py [--students 200]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from common import ROOT, SCENES, print_table, tool, write_results


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--students", type=int, default=200)
    args = parser.parse_args()
    from class_generator import KINDS, make_class

    work = ROOT / "build" / "bench-grade"
    scene = SCENES / "classic.json"
    rtval = tool("rtval")
    warm = work / "warm"
    (work / "empty").mkdir(parents=True, exist_ok=True)
    # Grading an empty class renders (or finds) the reference the synthetic class is made from.
    subprocess.run(
        [rtval, "grade", str(work / "empty"), "--scene", str(scene), "--out", str(warm)],
        check=True,
        capture_output=True,
    )
    subs = work / "subs"
    if not subs.is_dir():
        make_class(
            warm / "references" / "classic.exr",
            scene,
            tool("rtdemo"),
            subs,
            per_kind=-(-args.students // len(KINDS)),
            size=(640, 480),
        )
    n = sum(1 for _ in subs.iterdir())
    rows, results = [], []
    for executor in ("local", "dask"):
        out = work / f"out-{executor}"
        shutil.rmtree(out, ignore_errors=True)  # the reference stays in the render cache
        cmd = [rtval, "grade", str(subs), "--scene", str(scene), "--out", str(out), "--jobs", "2"]
        cluster = None
        if executor == "dask":
            from dask.distributed import LocalCluster

            cluster = LocalCluster(
                n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
            )
            cmd += ["--executor", "dask", "--scheduler", cluster.scheduler_address]
        start = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - start
        if cluster:
            cluster.close()
        if proc.returncode != 0:
            raise SystemExit(proc.stderr)
        results.append(
            {
                "executor": executor,
                "workers": 2,
                "submissions": n,
                "wall_s": wall,
                "per_submission_s": wall / n,
            }
        )
        rows.append([executor, 2, n, wall, wall / n])
    print_table(["executor", "workers", "submissions", "wall s", "s per submission"], rows)
    print(f"wrote {write_results('grade', {'size': [640, 480], 'results': results})}")


if __name__ == "__main__":
    main()
