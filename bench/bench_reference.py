"""Issue 18: the cost of one more sample per pixel in the Mitsuba reference, our `rtval_whitted`
integrator against Mitsuba's own `path`, on the same scene and size, in one process.

Per extra sample = (time at 4N spp - time at N spp) / (3N): start-up, scene loading, kernel
compilation and the AOV pass cancel out. Each configuration is rendered once untimed first
(compiles its kernels into drjit's cache), then `--repeats` times interleaved with the other
integrator; the minimum of each is kept (the machine is shared and noisy). Times are the
reference's own render loop (ReferenceImage.seconds). Kernels per render come from drjit's
kernel history.
Usage: python bench/bench_reference.py [--scene paper] [--n 4] [--repeats 2] [--variant llvm_ad_rgb]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import SCENES, print_table, write_results

from mitsuba_ref.drjit_env import load_mitsuba
from mitsuba_ref.reference import ReferenceSettings, render_reference
from scene_model.scene import Scene, load_scene

INTEGRATORS = ("whitted", "path")


def render_once(scene: Scene, integrator: str, spp: int, variant: str) -> dict[str, Any]:
    """One render: its loop's seconds and the JIT kernels it launched (and compiled)."""
    import drjit as dr

    dr.kernel_history()  # drop what earlier renders left
    image = render_reference(
        scene, ReferenceSettings(integrator=integrator, spp=spp, variant=variant)
    )
    kernels = [k for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]
    return {
        "seconds": image.seconds,
        "spp_done": image.spp_done,
        "kernels": len(kernels),
        "compiled": sum(1 for k in kernels if not k.get("cache_hit", False)),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n".join(__doc__.splitlines()[1:]),
    )
    ap.add_argument("--scene", default="paper", help="scene name in scenes/ (default paper)")
    ap.add_argument("--n", type=int, default=4, help="N: renders at N and 4N spp (default 4)")
    ap.add_argument("--repeats", type=int, default=2, help="timed renders per point (default 2)")
    ap.add_argument(
        "--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)"
    )
    args = ap.parse_args(argv)
    if args.n < 1 or args.repeats < 1:
        ap.error("--n and --repeats must be >= 1")
    scene_file = SCENES / f"{args.scene}.json"
    if not scene_file.is_file():
        ap.error(f"{scene_file}: no such scene")
    scene = load_scene(scene_file)
    load_mitsuba(args.variant)
    import drjit as dr

    dr.set_flag(dr.JitFlag.KernelHistory, True)
    spps = (args.n, 4 * args.n)
    for integrator in INTEGRATORS:  # untimed: compile and cache each configuration's kernels
        for spp in spps:
            render_once(scene, integrator, spp, args.variant)
    runs: dict[tuple[str, int], list[dict[str, Any]]] = {
        (i, s): [] for i in INTEGRATORS for s in spps
    }
    for _ in range(args.repeats):
        for spp in spps:
            for integrator in INTEGRATORS:
                runs[integrator, spp].append(render_once(scene, integrator, spp, args.variant))

    results: dict[str, Any] = {}
    rows = []
    for integrator in INTEGRATORS:
        low, high = (min(r["seconds"] for r in runs[integrator, s]) for s in spps)
        per_extra = (high - low) / (spps[1] - spps[0])
        last = runs[integrator, spps[1]][-1]
        results[integrator] = {
            "seconds": {str(s): [r["seconds"] for r in runs[integrator, s]] for s in spps},
            "min_seconds": {str(spps[0]): low, str(spps[1]): high},
            "per_extra_sample_s": per_extra,
            "kernels_per_render_at_4n": last["kernels"],
            "kernels_compiled_in_last_timed_run": last["compiled"],
        }
        rows.append([integrator, low, high, per_extra, last["kernels"]])
    ratio = results["whitted"]["per_extra_sample_s"] / results["path"]["per_extra_sample_s"]
    width, height = scene.camera.width, scene.camera.height
    print(f"{args.scene} {width}x{height}, {args.variant}, min of {args.repeats} runs")
    print_table(
        ["integrator", f"{spps[0]} spp s", f"{spps[1]} spp s", "s per extra spp", "kernels/render"],
        rows,
    )
    print(f"whitted / path per extra sample: {ratio:.2f}x (target <= 2, aim <= 1.5)")
    path = write_results(
        "reference",
        {
            "scene": args.scene,
            "size": [width, height],
            "variant": args.variant,
            "n": args.n,
            "repeats": args.repeats,
            "integrators": results,
            "whitted_over_path": ratio,
            "command": "python bench/bench_reference.py " + " ".join(argv or sys.argv[1:]),
        },
    )
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
