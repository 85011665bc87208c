"""A foreign renderer for `rtval check` tests: the classic algorithm (tests/numpy_reference.py,
float64 numpy) as a command-line program that writes a PFM.

    pytracer.py SCENE.json OUT.pfm WIDTH HEIGHT

RTVAL_TEST_BREAK=shadows builds it with one effect broken: no shadow rays (every light is
seen from every diffuse point), the bug a regression check must name.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE.parent.parent)]  # numpy_reference; the repo

from numpy_reference import F64, ReferenceTracer  # noqa: E402

from scene_model.scene import load_scene  # noqa: E402


class NoShadows(ReferenceTracer):
    def occluded(self, j: int, origin: F64, l_dir: F64) -> NDArray[np.bool_]:
        return np.zeros(len(origin), dtype=bool)  # no shadow rays


def write_pfm(path: str, rgb: np.ndarray) -> None:
    h, w, _ = rgb.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(rgb[::-1], dtype="<f4").tobytes())


def main() -> int:
    scene_file, out, width, height = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    scene = load_scene(scene_file)
    broken = os.environ.get("RTVAL_TEST_BREAK", "")
    tracer = (NoShadows if broken == "shadows" else ReferenceTracer)(scene, "classic")
    print(f"pytracer: {scene.name} {width}x{height}", file=sys.stderr)
    write_pfm(out, tracer.render(width, height))
    return 0


if __name__ == "__main__":
    sys.exit(main())
