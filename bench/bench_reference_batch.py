"""What a Mitsuba process costs before it renders: the report's Mitsuba renders
run as one `rtval reference` process each, against the same renders in one
`rtval reference --batch` process, at a small size so that the renders themselves are
cheap and the difference is start-up (importing drjit and Mitsuba, setting the variant,
registering the integrator, loading the scene, compiling or loading kernels).
Also: the bare import of Mitsuba with a variant set, in a fresh interpreter.
Usage: python bench/bench_reference_batch.py [--size 80x60] [--scene classic]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, SCENES, print_table, tool, write_results

sys.path.insert(0, str(ROOT))
from compare.render.plan import plan


def _timed(cmd: list[str]) -> float:
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--size", default="80x60")
    parser.add_argument("--scene", default="classic")
    args = parser.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    scene = str(SCENES / f"{args.scene}.json")
    rtval = tool("rtval")
    jobs = [j for j in plan(scene, (w, h)) if j.tool == "rtval"]
    load = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="rtval-bench-batch-") as tmp_name:
        tmp = Path(tmp_name)
        # Warm the on-disk kernel cache and the page cache once, so both sides start equal.
        _timed([rtval, *jobs[0].command(tmp / "warm.exr")[1:]])
        imports = [
            _timed(
                [
                    sys.executable,
                    "-c",
                    "from mitsuba_ref.drjit_env import load_mitsuba; "
                    "load_mitsuba('llvm_ad_rgb'); from mitsuba_ref import whitted; "
                    "whitted.register()",
                ]
            )
            for _ in range(3)
        ]
        separate = sum(
            _timed([rtval, *j.command(tmp / f"sep-{i}.exr")[1:]]) for i, j in enumerate(jobs)
        )
        batch_file = tmp / "jobs.json"
        batch_file.write_text(
            json.dumps({"jobs": [j.command(tmp / f"bat-{i}.exr")[2:] for i, j in enumerate(jobs)]})
        )
        batch = _timed([rtval, "reference", "--batch", str(batch_file)])
    n = len(jobs)
    per_process = (separate - batch) / (n - 1)
    rows = [
        [
            "import mitsuba + variant + integrator (fresh interpreter, median of 3)",
            sorted(imports)[1],
        ],
        [f"{n} renders, one process each", separate],
        [f"{n} renders, one --batch process", batch],
        ["start-up saved per render by the batch", per_process],
    ]
    print(f"{args.scene} at {w}x{h}, load average before {load[0]:.2f}")
    print_table(["what", "seconds"], rows)
    path = write_results(
        "reference_batch",
        {
            "scene": args.scene,
            "size": [w, h],
            "renders": n,
            "load_average_before": list(load),
            "import_seconds": imports,
            "separate_processes_s": separate,
            "one_batch_s": batch,
            "saved_per_render_s": per_process,
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
