"""Issue 32: where the report's Mitsuba time goes, per render, at the paper's size.

Renders every Mitsuba job the report plans (compare/render/plan.py: the converged reference,
the whitted and path renders, the ablations) in ONE process, in plan order, as the report's
`rtval reference --batch` does, and splits each render's loop time (ReferenceImage.seconds)
into drjit kernel execution, kernel code generation, LLVM compilation (zero on a hit in
drjit's kernel cache, ~/.drjit) and the rest (Python tracing the wavefront, numpy sums).
CPU seconds (user + system, both cores) are printed beside wall seconds: on a shared
machine they move less. `--fresh-kernel-cache` points drjit at an empty cache (HOME), so
that compilation is what a fresh machine pays. `--snapshots` renders each job that differs
from a larger one only in --spp as a `--snapshot` of it (the same images, bit for bit: its
samples are a prefix of the larger render's), which is what the report could do.
Usage: python bench/bench_reference_profile.py [--scene paper] [--size 1200x800]
       [--only KEY ...] [--fresh-kernel-cache] [--snapshots]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import SCENES, print_table, write_results


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _without_spp(argv: list[str]) -> tuple[tuple[str, ...], int]:
    i = argv.index("--spp") if "--spp" in argv else -1
    if i < 0:
        return tuple(argv), 1
    return tuple(argv[:i] + argv[i + 2 :]), int(argv[i + 1])


def merge_prefixes(commands: dict[str, list[str]]) -> dict[str, tuple[list[str], list[str]]]:
    """key -> (argv, keys snapshotted in it): each command that differs from another only in
    a smaller --spp becomes a `--snapshot SPP:OUT` of the largest (OUT is its own -o)."""
    groups: dict[tuple[str, ...], list[tuple[int, str]]] = {}
    for key, argv in commands.items():
        rest, spp = _without_spp([a for a in argv if a != argv[argv.index("-o") + 1]])
        groups.setdefault(rest, []).append((spp, key))
    merged = {}
    for members in groups.values():
        members.sort()
        spp, key = members[-1]
        argv = list(commands[key])
        for small, other in members[:-1]:
            if small < spp:
                out = commands[other][commands[other].index("-o") + 1]
                argv += ["--snapshot", f"{small}:{out}"]
        merged[key] = (argv, [k for _, k in members[:-1]])
    return merged


def _profile_job(key: str, argv: list[str]) -> dict[str, Any]:
    import drjit as dr

    from compare.cli.reference import _parse_job, render_to_file

    args = _parse_job(argv)
    out = Path(args.output)
    dr.kernel_history()  # drop what earlier renders left
    cpu, wall = _cpu(), time.perf_counter()
    _, summary = render_to_file(args, lambda d, t, e: None)
    wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    kernels = [k for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]
    from compare.judge.images import read_image

    loop = float(read_image(out).header["rtval.render_seconds"])
    ms = 1e-3  # drjit reports milliseconds
    execution = sum(k.get("execution_time", 0.0) for k in kernels) * ms
    return {
        "key": key,
        "wall_s": wall,
        "cpu_s": cpu,
        "loop_s": loop,
        "kernel_exec_s": execution,
        "codegen_s": sum(k.get("codegen_time", 0.0) for k in kernels) * ms,
        "compile_s": sum(k.get("backend_time", 0.0) for k in kernels) * ms,
        "kernels": len(kernels),
        "compiled": sum(1 for k in kernels if not k.get("cache_hit", False)),
        "summary": summary,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="paper")
    ap.add_argument("--size", default="1200x800")
    ap.add_argument("--only", nargs="*", default=None, metavar="KEY", help="these jobs only")
    ap.add_argument("--fresh-kernel-cache", action="store_true")
    ap.add_argument("--snapshots", action="store_true", help="smaller-spp jobs as snapshots")
    args = ap.parse_args(argv)
    if args.fresh_kernel_cache:
        os.environ["HOME"] = tempfile.mkdtemp(prefix="rtval-bench-home-")
    from compare.render.plan import plan
    from mitsuba_ref.drjit_env import load_mitsuba

    scene_file = SCENES / f"{args.scene}.json"
    w, h = (int(v) for v in args.size.split("x"))
    jobs = [j for j in plan(str(scene_file), (w, h)).all_jobs if j.tool == "rtval"]
    if args.only:
        jobs = [j for j in jobs if j.key in args.only]
    start_cpu, start = _cpu(), time.perf_counter()
    load_mitsuba("llvm_ad_rgb")
    import drjit as dr

    dr.set_flag(dr.JitFlag.KernelHistory, True)
    startup = time.perf_counter() - start
    rows, runs = [], []
    with tempfile.TemporaryDirectory(prefix="rtval-bench-") as tmp:
        commands = {j.key: j.command(Path(tmp) / f"{j.key}.exr", scene_file)[2:] for j in jobs}
        merged = (
            merge_prefixes(commands)
            if args.snapshots
            else {k: (a, []) for k, a in commands.items()}
        )
        for key, (argv, inside) in merged.items():
            r = _profile_job(key + (f" +{len(inside)} snapshots" if inside else ""), argv)
            runs.append(r)
            rest = r["loop_s"] - r["kernel_exec_s"] - r["codegen_s"] - r["compile_s"]
            rows.append([r["key"], r["wall_s"], r["cpu_s"], r["loop_s"], r["kernel_exec_s"],
                         r["codegen_s"], r["compile_s"], rest, r["kernels"]])  # fmt: skip
    total = time.perf_counter() - start
    print(f"{args.scene} {w}x{h}: {len(jobs)} Mitsuba renders in one process, "
          f"{total:.1f} s wall, {_cpu() - start_cpu:.1f} s CPU (import + variant {startup:.1f} s)")  # fmt: skip
    print_table(["job", "wall s", "CPU s", "loop s", "kernels s", "codegen s", "compile s",
                 "rest s", "kernels"], rows)  # fmt: skip
    sums = {
        k: sum(r[k] for r in runs) for k in ("loop_s", "kernel_exec_s", "codegen_s", "compile_s")
    }
    print("all renders: " + ", ".join(f"{k} {v:.1f}" for k, v in sums.items()))
    path = write_results(
        "reference_profile_snapshots" if args.snapshots else "reference_profile",
        {
            "scene": args.scene,
            "size": [w, h],
            "fresh_kernel_cache": args.fresh_kernel_cache,
            "snapshots": args.snapshots,
            "startup_s": startup,
            "total_wall_s": total,
            "renders": runs,
            "sums": sums,
            "load_average": os.getloadavg(),
            "command": "python bench/bench_reference_profile.py " + " ".join(argv or sys.argv[1:]),
        },
    )
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
