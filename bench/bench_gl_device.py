"""The GLSL tracer on whatever GPU this machine has, against the CPU tracer beside it.

For each scene, mode and size: rtdemo's own GL timings (shader compile, first frame, median of
the following frames) and the CPU tracer's fastest frame on all cores, and how far the two 8-bit
PPMs are apart (bytes that differ, largest difference). Standard library only, so that it runs
on a machine that has rtdemo and python3 and nothing of the venv: a lent GPU machine.

Usage: python3 bench/bench_gl_device.py [--rtdemo PATH] [--frames N] [--sizes WxH,...]
       [--json OUT.json]   (default: bench/results/gl_device.json and its history)
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import SCENES, print_table, stamped, tool, write_results

GL_LINE = re.compile(
    r"gl on (?P<renderer>.+?), compile (?P<compile>[\d.]+) s, first frame (?P<first>[\d.]+) s, "
    r"frame (?P<frame>[\d.]+) s"
)
CPU_LINE = re.compile(r"spp \d+: (?P<frame>[\d.]+) s on (?P<threads>\d+) threads")


def summary(cmd: list[str], pattern: re.Pattern[str]) -> dict[str, str]:
    """Runs one rtdemo render and returns the fields of its summary line."""
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    match = pattern.search(proc.stderr)
    if proc.returncode != 0 or match is None:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {proc.returncode}): {proc.stderr}")
    return match.groupdict()


def ppm_difference(a: Path, b: Path) -> tuple[int, int]:
    """(bytes that differ, largest difference) between two PPMs of one size."""
    pa, pb = a.read_bytes(), b.read_bytes()
    if len(pa) != len(pb):
        raise SystemExit(f"{a} and {b} differ in size")
    diffs = [abs(x - y) for x, y in zip(pa, pb, strict=True) if x != y]
    return len(diffs), max(diffs, default=0)


def measure(rtdemo: str, scene: str, mode: str, size: str, frames: int, tmp: Path) -> dict:
    width, height = size.split("x")
    base = [rtdemo, "render", str(SCENES / f"{scene}.json"), "--mode", mode]
    base += ["--width", width, "--height", height]
    gl_ppm, cpu_ppm = tmp / "gl.ppm", tmp / "cpu.ppm"
    gl = summary([*base, "--backend", "gl", "--frames", str(frames), "--ppm", str(gl_ppm)], GL_LINE)
    cpu = summary([*base, "--frames", "3", "--keep-frame", "--ppm", str(cpu_ppm)], CPU_LINE)
    differing, largest = ppm_difference(gl_ppm, cpu_ppm)
    return {
        "scene": scene,
        "mode": mode,
        "size": size,
        "renderer": gl["renderer"],
        "gl_compile_s": float(gl["compile"]),
        "gl_first_frame_s": float(gl["first"]),
        "gl_frame_s": float(gl["frame"]),
        "cpu_frame_s": float(cpu["frame"]),
        "cpu_threads": int(cpu["threads"]),
        "ppm_bytes_differing": differing,
        "ppm_largest_difference": largest,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rtdemo", default=None, help="rtdemo executable (default: the venv's)")
    parser.add_argument("--frames", type=int, default=20, help="GL frames to time (default 20)")
    parser.add_argument("--sizes", default="640x480,1200x800,3840x2160", help="WxH,... to render")
    parser.add_argument("--json", default=None, help="write here instead of bench/results")
    args = parser.parse_args()
    rtdemo = args.rtdemo or tool("rtdemo")
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in ("paper", "classic"):
            for mode in ("paper", "physical"):
                for size in args.sizes.split(","):
                    results.append(measure(rtdemo, scene, mode, size, args.frames, Path(tmp)))
    keys = ["scene", "mode", "size", "gl_compile_s", "gl_first_frame_s", "gl_frame_s"]
    keys += ["cpu_frame_s", "cpu_threads", "ppm_bytes_differing", "ppm_largest_difference"]
    print(f"GL renderer: {results[0]['renderer']}")
    print_table(keys, [[r[k] for k in keys] for r in results])
    data = {"frames": args.frames, "results": results}
    if args.json:
        Path(args.json).write_text(json.dumps(stamped(data), indent=2) + "\n")
        print(f"wrote {args.json}")
    else:
        print(f"wrote {write_results('gl_device', data)}")


if __name__ == "__main__":
    main()
