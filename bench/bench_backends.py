"""CPU and GL backends of rtdemo on both scenes at 640x480.

Whole-process wall time (start-up, EGL context, shader compile and EXR write included) and,
for GL, the compile time, first frame and the median of the following frames as rtdemo
reports them in its EXR header. Usage: python bench/bench_backends.py [--label NAME]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import SCENES, print_table, time_process, tool, write_results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--label", default="backends", help="results file name (bench/results/LABEL.json)"
    )
    parser.add_argument("--rtdemo", default=None, help="rtdemo executable (default: the venv's)")
    parser.add_argument("--frames", type=int, default=10, help="GL frames to time (default 10)")
    args = parser.parse_args()
    rtdemo = args.rtdemo or tool("rtdemo")
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from compare.judge.images import read_image

    rows, results = [], []
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out.exr")
        for scene in ("paper", "classic"):
            for mode in ("paper", "physical"):
                for backend in ("cpu", "gl"):
                    cmd = [
                        rtdemo,
                        "render",
                        str(SCENES / f"{scene}.json"),
                        "-o",
                        out,
                        "--mode",
                        mode,
                        "--backend",
                        backend,
                        "-q",
                    ]
                    whole = time_process(cmd)
                    entry = {
                        "scene": scene,
                        "mode": mode,
                        "backend": backend,
                        "process_s": whole["median_s"],
                    }
                    if backend == "gl":
                        time_process([*cmd, "--frames", str(args.frames)], repeats=1)
                        h = read_image(out).header
                        entry.update(
                            renderer=h["rtval.gl_renderer"],
                            compile_s=float(h["rtval.gl_compile_seconds"]),
                            first_frame_s=float(h["rtval.gl_first_frame_seconds"]),
                            frame_s=float(h["rtval.render_seconds"]),
                        )
                    else:
                        h = read_image(out).header
                        entry.update(
                            renderer=f"cpu x{h['rtval.threads']}",
                            frame_s=float(h["rtval.render_seconds"]),
                        )
                    results.append(entry)
                    rows.append(
                        [
                            scene,
                            mode,
                            backend,
                            entry["renderer"][:32],
                            entry["process_s"],
                            entry.get("compile_s", "-"),
                            entry.get("first_frame_s", "-"),
                            entry["frame_s"],
                        ]
                    )
    print_table(
        [
            "scene",
            "mode",
            "backend",
            "renderer",
            "process s",
            "compile s",
            "1st frame s",
            "frame s",
        ],
        rows,
    )
    print(f"wrote {write_results(args.label, {'width': 640, 'height': 480, 'results': results})}")


if __name__ == "__main__":
    main()
