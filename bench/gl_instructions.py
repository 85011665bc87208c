"""Instructions per warm GL frame, counted by callgrind: a measure of the GLSL tracer's cost
that this machine's timing noise (up to 2.5x between minutes) cannot move. Each scene is
rendered twice under callgrind, with 1 and with 3 frames, Mesa's shader cache off so that
both runs compile alike; half the difference is one warm frame (llvmpipe's generated code,
its rasteriser and the frame's clears). Not part of `make bench`: about a minute per scene.
Needs valgrind (apt-get install valgrind).

Usage: python bench/gl_instructions.py [SCENE.json ...] [--binary PATH] [-- RTDEMO-OPTIONS]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, SCENES, print_table, write_results


def instructions(binary: str, scene: Path, frames: int, extra: list[str], out: str) -> int:
    cmd = [
        "valgrind",
        "--tool=callgrind",
        "--callgrind-out-file=/dev/null",
        binary,
        "render",
        str(scene),
        "-o",
        out,
        "--backend",
        "gl",
        "--frames",
        str(frames),
        "-q",
        *extra,
    ]
    env = dict(os.environ, MESA_SHADER_CACHE_DISABLE="true")
    run = subprocess.run(cmd, capture_output=True, text=True, env=env)
    found = re.search(r"Collected : (\d+)", run.stderr)
    if run.returncode != 0 or not found:
        raise SystemExit(f"callgrind run failed ({' '.join(cmd)}):\n{run.stderr[-2000:]}")
    return int(found.group(1))


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "scenes", nargs="*", type=Path, help="scene files (default: paper and classic)"
    )
    parser.add_argument(
        "--binary", default=str(ROOT / "build" / "cmake" / "rtdemo"), help="rtdemo to measure"
    )
    args, extra = parser.parse_known_args()
    extra = [a for a in extra if a != "--"]
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind not found: apt-get install valgrind")
    if not Path(args.binary).is_file():
        raise SystemExit(f"{args.binary} missing: build it with make setup")
    scenes = args.scenes or [SCENES / "paper.json", SCENES / "classic.json"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            if not scene.is_file():
                raise SystemExit(f"{scene}: no such scene file")
            print(
                f"  {scene.name}: 1 and 3 frames under callgrind ...", file=sys.stderr, flush=True
            )
            one = instructions(args.binary, scene, 1, extra, f"{tmp}/one.exr")
            three = instructions(args.binary, scene, 3, extra, f"{tmp}/three.exr")
            rows.append(
                {
                    "scene": scene.stem,
                    "options": " ".join(extra),
                    "instructions_per_frame": (three - one) // 2,
                }
            )
    print_table(
        ["scene", "options", "M instructions / frame"],
        [[r["scene"], r["options"], r["instructions_per_frame"] / 1e6] for r in rows],
    )
    print(f"wrote {write_results('gl_instructions', {'binary': args.binary, 'rows': rows})}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
