"""Seconds per image of `rtval diagnose` at 640x480 (the issue's goal: <= 10 s on 2 cores).

The images are the numpy classic program and its student-style variants
(tests/student_variants.py), written as truncating PPMs; each is diagnosed by the command a
user types (`rtval diagnose IMG --scene classic --json F`), timed as a whole process.
Prints a table and writes bench/results/diagnose.json.

    python bench/bench_diagnose.py [--variants exact,no_offset,...] [--size 640x480]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import ROOT, SCENES, print_table, tool, write_results

sys.path.insert(0, str(ROOT / "tests"))


def main() -> None:
    from student_variants import VARIANTS, render_variant

    from scene_model.scene import load_scene

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variants", default=",".join(["exact", *VARIANTS]))
    ap.add_argument("--size", default="640x480")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    scene_file = SCENES / "classic.json"
    scene = load_scene(scene_file)
    rtval = tool("rtval")
    rows, results = [], []
    with tempfile.TemporaryDirectory(prefix="rtval-bench-diagnose-") as tmp:
        for variant in args.variants.split(","):
            image = render_variant(scene, variant, w, h, Path(tmp) / f"{variant}.ppm")
            out = Path(tmp) / f"{variant}.json"
            cmd = [rtval, "diagnose", str(image), "--scene", str(scene_file), "--json", str(out)]
            cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            wall = time.perf_counter() - start
            cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            # CPU seconds of rtval and every rtdemo it ran: on a shared machine the wall time
            # also holds other people's work; cpu / 2 is what 2 idle cores would need at best.
            cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
            if proc.returncode != 0:
                raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr}")
            d = json.loads(out.read_text())
            expected = VARIANTS.get(variant, "")
            results.append(
                {
                    "variant": variant,
                    "expected": expected,
                    "diagnosis": d["result"],
                    "mistakes": d["mistakes"],
                    "unexplained": d["unexplained"],
                    "renders": d["renders"],
                    "search_s": d["seconds"],
                    "wall_s": wall,
                    "cpu_s": cpu,
                    "load_1min": os.getloadavg()[0],
                }
            )
            rows.append([variant, d["result"], d["renders"], d["seconds"], wall, cpu])
    print_table(["variant", "diagnosis", "renders", "diagnose s", "process s", "cpu s (all)"], rows)
    print(f"wrote {write_results('diagnose', {'size': [w, h], 'results': results})}")


if __name__ == "__main__":
    main()
