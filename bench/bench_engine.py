"""Issue 20's targets, measured in one run with alternating processes (ratios only within the run):

- whole process, classic scene, classic mode, 640x480: the plain program
  (bench/baseline/seed_tracer.cpp, PPM) against rtdemo's packet engine writing the PPM and
  writing the EXR with its AOVs (targets >= 15x and >= 12x);
- physical mode at 16 spp, whole process with the EXR: the packet engine against the previous
  engine (`--engine scalar`, the one-ray-at-a-time tracer) (target >= 5x);
- the floors of the classic frame, each measured: an empty rtdemo process (`--version`), the
  write alone (timed inside rtdemo around the writer, in processes that keep the whole frame:
  `--keep-frame`; by default a single PPM or EXR output is written band by band during the
  frame), tracing alone (fastest of several frames in one process), and what each technique
  brings: instruction sets (RTDEMO_ISA), threads, packet against scalar engine, streaming the
  output against keeping the frame.

The machine's two cores are shared with other work: every comparison alternates its commands
round by round (the order rotated each round), reports medians and the spread, and the ratio
of medians. Usage: python bench/bench_engine.py [--rounds N] [--rtdemo PATH] [--seed PATH]
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import ROOT, SCENES, print_table, write_results

# rtdemo and seed_tracer of the test build (make bench-build: BUILD_TESTING=ON, RTDEMO_BENCH=ON).
BUILD = ROOT / "build" / "cmake"
SUMMARY = re.compile(r": ([0-9.]+) s on (\d+) threads, ([0-9.]+) M rays .* write ([0-9.]+) s")
CLASSIC = str(SCENES / "classic.json")


def run_once(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, float, str]:
    """Wall time, CPU time (user + system of the child, from wait4: less moved by other work
    waiting for the same cores than wall time) and output (stdout and stderr together) of one
    process. Started with posix_spawn, its output to a file read afterwards: subprocess.run with
    pipes added about 0.3 ms to every process, both programs' alike (bench/NOTES.md). Signals
    Python ignores (SIGPIPE, SIGXFSZ) are set back to their defaults in the child, as
    subprocess does; an interrupted benchmark kills the process it waits for."""
    with tempfile.TemporaryFile() as log:
        fd = log.fileno()
        actions = [(os.POSIX_SPAWN_DUP2, fd, 1), (os.POSIX_SPAWN_DUP2, fd, 2)]
        start = time.perf_counter()
        pid = os.posix_spawn(
            cmd[0],
            cmd,
            env if env is not None else os.environ,
            file_actions=actions,
            setsigdef=(signal.SIGPIPE, signal.SIGXFSZ),
        )
        try:
            _, status, usage = os.wait4(pid, 0)
        except BaseException:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise
        elapsed = time.perf_counter() - start
        log.seek(0)
        output = log.read().decode(errors="replace")
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({code}): {output.strip()}")
    return elapsed, usage.ru_utime + usage.ru_stime, output


def cpu_times() -> list[int] | None:
    """The machine's CPU time counters (/proc/stat, all CPUs): user, nice, system, idle,
    iowait, irq, softirq, steal; None where there is no /proc/stat."""
    try:
        fields = Path("/proc/stat").read_text().splitlines()[0].split()
    except OSError:
        return None
    values = [int(v) for v in fields[1:9]]
    return values if len(values) == 8 else None


def steal_share(before: list[int] | None, after: list[int] | None) -> float | None:
    """Share of the CPUs' time the host gave to other guests (steal) between two readings: the
    noise no alternating of runs removes, since short two-thread processes lose more of it."""
    if before is None or after is None:
        return None
    delta = [b - a for a, b in zip(before, after, strict=True)]
    return delta[7] / sum(delta) if sum(delta) > 0 else None


def alternate(
    cmds: dict[str, list[str]], rounds: int, envs: dict[str, dict[str, str]] | None = None
) -> dict[str, dict[str, Any]]:
    """Runs every command once per round, the order rotated each round; wall times and output.
    "{round}" in an argument becomes the round's number: such outputs are new files each round
    (the previous round's are removed before the round starts, untimed), as rtval's render
    cache writes them. Replacing an existing file costs its old pages (measured apart)."""
    names = list(cmds)
    fresh = [a for c in cmds.values() for a in c if "{round}" in a]
    times: dict[str, list[float]] = {n: [] for n in names}
    cpus: dict[str, list[float]] = {n: [] for n in names}
    errs: dict[str, list[str]] = {n: [] for n in names}
    for r in range(rounds):
        for a in fresh:
            Path(a.replace("{round}", str(r - 1))).unlink(missing_ok=True)
        for k in range(len(names)):
            name = names[(r + k) % len(names)]
            env = {**os.environ, **(envs or {}).get(name, {})}
            t, cpu, err = run_once([a.replace("{round}", str(r)) for a in cmds[name]], env)
            times[name].append(t)
            cpus[name].append(cpu)
            errs[name].append(err)
    return {
        n: {
            "median_s": statistics.median(v),
            "min_s": min(v),
            "max_s": max(v),
            "cpu_median_s": statistics.median(cpus[n]),
            "runs_s": v,
            "cpu_runs_s": cpus[n],
            "output": errs[n],
        }
        for n, v in times.items()
    }


def summary(output: str) -> dict[str, float]:
    m = SUMMARY.search(output)
    if not m:
        raise SystemExit(f"no rtdemo summary line in: {output!r}")
    return {
        "frame_s": float(m.group(1)),
        "threads": int(m.group(2)),
        "mrays": float(m.group(3)),
        "write_s": float(m.group(4)),
    }


def rays_from_header(exr: str) -> dict[str, int]:
    from compare.judge.images import read_image

    h = read_image(exr).header
    return {k: int(h[f"rtval.rays_{k}"]) for k in ("camera", "secondary", "shadow")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--rounds", type=int, default=15, help="alternating rounds per comparison (default 15)"
    )
    parser.add_argument(
        "--rtdemo", default=str(BUILD / "rtdemo"), help="rtdemo binary (default: build/cmake)"
    )
    parser.add_argument(
        "--seed",
        default=str(BUILD / "seed_tracer"),
        help="the plain program (default: build/cmake)",
    )
    parser.add_argument(
        "--physical-rounds", type=int, default=5, help="rounds for physical 16 spp (default 5)"
    )
    args = parser.parse_args()
    rtdemo, seed = args.rtdemo, args.seed
    for path in (rtdemo, seed):
        if not Path(path).is_file():
            raise SystemExit(f"{path} missing: build with make bench-build")
    from scene_model.scene import load_scene

    spheres = len(load_scene(SCENES / "classic.json").spheres)
    results: dict[str, Any] = {"rounds": args.rounds}
    with tempfile.TemporaryDirectory() as tmp:
        render = [rtdemo, "render", CLASSIC, "--mode", "classic"]
        ppm_round = [*render, "--ppm-rounding", "round", "--ppm"]
        # 1. Whole processes against the plain program, and the empty process.
        stat_before = cpu_times()
        whole = alternate(
            {
                "seed_ppm": [seed, CLASSIC, f"{tmp}/seed-{{round}}.ppm", "classic"],
                # Rounded as the plain program rounds (rtdemo truncates by default): the same
                # bytes, so the same work; both conventions cost the same (image_io.cpp).
                "packet_ppm": [*ppm_round, f"{tmp}/p-{{round}}.ppm"],
                "packet_exr": [*render, "-o", f"{tmp}/p-{{round}}.exr"],
                "empty_process": [rtdemo, "--version"],
                # The whole frame traced first, then written: the writers' time alone.
                "packet_ppm_kept": [*ppm_round, f"{tmp}/k-{{round}}.ppm", "--keep-frame"],
                "packet_exr_kept": [*render, "-o", f"{tmp}/k-{{round}}.exr", "--keep-frame"],
                # The same outputs over the previous round's file: the floor of replacing it.
                "packet_ppm_replace": [*ppm_round, f"{tmp}/replaced.ppm"],
                "packet_exr_replace": [*render, "-o", f"{tmp}/replaced.exr"],
            },
            args.rounds,
        )
        steal = steal_share(stat_before, cpu_times())
        last = args.rounds - 1
        same_ppm = (
            Path(f"{tmp}/seed-{last}.ppm").read_bytes() == Path(f"{tmp}/p-{last}.ppm").read_bytes()
        )
        rays = rays_from_header(f"{tmp}/p-{last}.exr")
        base = whole["seed_ppm"]["median_s"]
        same_ppm = same_ppm and (
            Path(f"{tmp}/k-{last}.ppm").read_bytes() == Path(f"{tmp}/p-{last}.ppm").read_bytes()
        )

        def median_of(row: str, key: str) -> float:
            return statistics.median(summary(e)[key] for e in whole[row]["output"])

        write_ppm = median_of("packet_ppm_kept", "write_s")
        write_exr = median_of("packet_exr_kept", "write_s")
        # Tracing in a fresh process (the kept EXR's frame), and the streamed frames (their
        # summary leaves out the threads' share of writing bands, which it reports as writing).
        frame_in_process = median_of("packet_exr_kept", "frame_s")
        streamed_frames = {k: median_of(f"packet_{k}", "frame_s") for k in ("ppm", "exr")}
        streamed_writes = {k: median_of(f"packet_{k}", "write_s") for k in ("ppm", "exr")}

        # 2. Tracing alone (fastest of 10 frames in one process) per engine, ISA and thread count.
        variants = {
            "packet_avx512_2t": ({}, ["--threads", "2"]),
            "packet_avx2_2t": ({"RTDEMO_ISA": "avx2"}, ["--threads", "2"]),
            "packet_scalar_2t": ({"RTDEMO_ISA": "scalar"}, ["--threads", "2"]),
            "packet_avx512_1t": ({}, ["--threads", "1"]),
            "scalar_engine_2t": ({}, ["--threads", "2", "--engine", "scalar"]),
        }
        if "avx512f" not in Path("/proc/cpuinfo").read_text():  # the best ISA is AVX2 here
            variants = {
                k.replace("avx512", "best"): v for k, v in variants.items() if k != "packet_avx2_2t"
            }
        tracing = alternate(
            {
                k: [*render, "--ppm", f"{tmp}/t.ppm", "--frames", "10", *extra]
                for k, (_, extra) in variants.items()
            },
            max(3, args.rounds // 3),
            {k: env for k, (env, _) in variants.items()},
        )
        trace_s = {
            k: statistics.median(summary(e)["frame_s"] for e in v["output"])
            for k, v in tracing.items()
        }
        best = next(iter(trace_s))
        total_rays = sum(rays.values())
        tests = (rays["camera"] + rays["secondary"]) * spheres + rays["shadow"] * (spheres - 1)

        # 3. Physical mode, 16 spp, whole process with the EXR: packet against the previous engine.
        phys = [
            rtdemo,
            "render",
            CLASSIC,
            "--mode",
            "physical",
            "--spp",
            "16",
        ]
        physical = alternate(
            {
                "packet": [*phys, "-o", f"{tmp}/ph-packet-{{round}}.exr"],
                "scalar_engine": [
                    *phys,
                    "-o",
                    f"{tmp}/ph-scalar-{{round}}.exr",
                    "--engine",
                    "scalar",
                ],
            },
            args.physical_rounds,
        )

    exr_s, ppm_s, empty_s = (
        whole["packet_exr"]["median_s"],
        whole["packet_ppm"]["median_s"],
        whole["empty_process"]["median_s"],
    )
    labels = {
        "seed_ppm": "seed_tracer (PPM)",
        "packet_ppm": "rtdemo packet, PPM",
        "packet_exr": "rtdemo packet, EXR+AOVs",
        "empty_process": "empty rtdemo process",
        "packet_ppm_kept": "rtdemo packet, PPM, frame kept then written",
        "packet_exr_kept": "rtdemo packet, EXR+AOVs, frame kept then written",
        "packet_ppm_replace": "rtdemo packet, PPM over an existing file",
        "packet_exr_replace": "rtdemo packet, EXR over an existing file",
    }
    base_cpu = whole["seed_ppm"]["cpu_median_s"]
    rows = [
        [
            label,
            whole[k]["median_s"],
            whole[k]["min_s"],
            whole[k]["max_s"],
            base / whole[k]["median_s"],
            whole[k]["cpu_median_s"],
            base_cpu / whole[k]["cpu_median_s"],
        ]
        for k, label in labels.items()
    ]
    host = "unknown" if steal is None else f"{100 * steal:.1f} %"
    print(
        f"Whole processes, classic scene, classic mode, 640x480 ({args.rounds} alternating rounds; same PPM as the "
        f"plain program: {same_ppm}; the host's steal of the CPUs meanwhile: {host})"
    )
    print_table(
        ["process", "median s", "min s", "max s", "x plain", "cpu s (median)", "x plain (cpu)"],
        rows,
    )
    floor_ppm = empty_s + trace_s[best] + write_ppm
    floor_exr = empty_s + trace_s[best] + write_exr
    print(
        f"\nfloors (medians): empty process {empty_s * 1e3:.1f} ms, tracing alone {trace_s[best] * 1e3:.1f} ms "
        f"(in a process keeping the EXR's frame: {frame_in_process * 1e3:.1f} ms), PPM write {write_ppm * 1e3:.1f} ms, "
        f"EXR write {write_exr * 1e3:.1f} ms (the writers alone, frame kept)"
    )
    print(
        f"  streamed: frame {streamed_frames['ppm'] * 1e3:.1f} ms and writing "
        f"{streamed_writes['ppm'] * 1e3:.1f} ms (PPM), frame {streamed_frames['exr'] * 1e3:.1f} ms "
        f"and writing {streamed_writes['exr'] * 1e3:.1f} ms (EXR), in the process (the writing "
        "done on the render threads, its share of the frame)"
    )
    print(
        f"  sum of floors: PPM {floor_ppm * 1e3:.1f} ms (at most {base / floor_ppm:.1f}x), EXR {floor_exr * 1e3:.1f} ms "
        f"(at most {base / floor_exr:.1f}x)"
    )
    replace_ppm = whole["packet_ppm_replace"]["median_s"] - ppm_s
    replace_exr = whole["packet_exr_replace"]["median_s"] - exr_s
    print(
        f"  replacing an existing output instead of writing a new file adds {replace_ppm * 1e3:.1f} ms "
        f"(PPM) and {replace_exr * 1e3:.1f} ms (EXR): the kernel frees the old file's pages"
    )
    outside = {k: 1 - streamed_frames[k] / whole[f"packet_{k}"]["median_s"] for k in ("ppm", "exr")}
    print(
        f"  share of the process outside tracing (the streamed frame less its writing): "
        f"PPM {100 * outside['ppm']:.0f} %, EXR {100 * outside['exr']:.0f} %"
    )
    print(
        f"\nTracing alone (fastest of 10 frames per process, median of processes); {total_rays} rays "
        f"({rays['camera']} camera, {rays['secondary']} secondary, {rays['shadow']} shadow), {tests} ray-sphere tests"
    )
    print_table(
        ["variant", "frame s", "M rays/s", "G tests/s", "x scalar engine"],
        [
            [k, v, total_rays / v / 1e6, tests / v / 1e9, trace_s["scalar_engine_2t"] / v]
            for k, v in trace_s.items()
        ],
    )
    ph_ratio = physical["scalar_engine"]["median_s"] / physical["packet"]["median_s"]
    print(
        f"\nPhysical mode, 16 spp, classic scene, whole process with EXR ({args.physical_rounds} alternating rounds): "
        f"packet {physical['packet']['median_s']:.3f} s, previous engine {physical['scalar_engine']['median_s']:.3f} s, "
        f"{ph_ratio:.2f}x"
    )
    for d in (whole, tracing, physical):
        for v in d.values():
            v.pop("output", None)
    results.update(
        {
            "whole": whole,
            "same_ppm_as_plain": same_ppm,
            "host_steal_share": steal,
            "speedup_ppm": base / ppm_s,
            "speedup_exr": base / exr_s,
            "speedup_ppm_cpu_time": base_cpu / whole["packet_ppm"]["cpu_median_s"],
            "speedup_exr_cpu_time": base_cpu / whole["packet_exr"]["cpu_median_s"],
            "floors_s": {
                "empty_process": empty_s,
                "tracing_alone": trace_s[best],
                "tracing_in_process": frame_in_process,
                "streamed_frame_ppm": streamed_frames["ppm"],
                "streamed_frame_exr": streamed_frames["exr"],
                "streamed_write_ppm": streamed_writes["ppm"],
                "streamed_write_exr": streamed_writes["exr"],
                "write_ppm": write_ppm,
                "write_exr": write_exr,
                "replacing_ppm": replace_ppm,
                "replacing_exr": replace_exr,
            },
            "outside_tracing_share": outside,
            "rays": rays,
            "sphere_tests": tests,
            "tracing_s": trace_s,
            "rays_per_s": total_rays / trace_s[best],
            "tests_per_s": tests / trace_s[best],
            "physical_16spp": physical,
            "speedup_physical_16spp": ph_ratio,
        }
    )
    print(f"wrote {write_results('engine', results)}")


if __name__ == "__main__":
    main()
