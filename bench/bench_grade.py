"""Grading throughput at 640x480.

Scenario `classic`: 200 submissions graded against the `classic` demo model with the
local process pool (2 processes): half are exact implementations (rtdemo's classic PPM rounded
and truncated, PNG, EXR, the numpy student program's truncating PPM), the rest wrong (paper
and physical mode, classic without shadows or refraction, classic with noise) or broken
(wrong size, corrupt). Target: <= 0.3 s per submission, the first result within 5 s of the
command's start. Also measures one pair in-process: the exact match alone against the full
metrics (FLIP, SSIM), i.e. what an exact submission saves.

Scenario `mitsuba`: the synthetic class made from the Mitsuba reference, graded
`--against mitsuba` with the process pool and a 2-worker Dask LocalCluster.

Usage: python bench/bench_grade.py [--students 200] [--scenario classic|mitsuba|all]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from common import ROOT, SCENES, print_table, tool, write_results

CLASSIC_CACHE = ROOT / "build" / "bench-grade" / "cache-classic"

CLASSIC_KINDS = {  # kind -> expected status
    "ppm_round": "pass",
    "ppm_trunc": "pass",
    "png": "pass",
    "exr": "pass",
    "numpy": "pass",
    "paper": "fail",
    "physical": "fail",
    "no_shadows": "fail",
    "no_refraction": "fail",
    "noise": "fail",
    "wrong_size": "fail",
    "corrupt": "fail",
}


def _ppm(path: Path, codes: np.ndarray) -> None:
    h, w = codes.shape[:2]
    path.write_bytes(f"P6\n{w} {h}\n255\n".encode() + codes.astype(np.uint8).tobytes())


def make_classic_class(folder: Path, students: int) -> dict[str, str]:
    """Writes the class; returns id -> expected status."""
    from compare.judge.images import read_image, write_exr
    from compare.judge.png import write_png

    scene = SCENES / "classic.json"
    rtdemo = tool("rtdemo")
    folder.mkdir(parents=True, exist_ok=True)
    renders = folder.parent / "renders"
    renders.mkdir(exist_ok=True)

    def render(name: str, *args: str) -> np.ndarray:
        out = renders / f"{name}.exr"
        if not out.is_file():
            subprocess.run([rtdemo, "render", str(scene), "-o", str(out), "-q", *args], check=True)
        return read_image(out).rgb

    classic = render("classic", "--mode", "classic")
    wrong = {
        "paper": render("paper", "--mode", "paper"),
        "physical": render("physical", "--mode", "physical"),
        "no_shadows": render("no_shadows", "--mode", "classic", "--no-shadows"),
        "no_refraction": render("no_refraction", "--mode", "classic", "--no-refraction"),
    }
    numpy_ppm = renders / "numpy.ppm"
    if not numpy_ppm.is_file():
        subprocess.run(
            [
                sys.executable,
                str(ROOT / "tests/student_programs/classic_numpy.py"),
                str(scene),
                str(numpy_ppm),
            ],
            check=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
    rng = np.random.default_rng(7)
    clamped = np.clip(classic, 0, 1)
    expected = {}
    kinds = list(CLASSIC_KINDS)
    for i in range(students):
        kind = kinds[i % len(kinds)]
        sid = f"{kind}_{i:03d}"
        expected[sid] = CLASSIC_KINDS[kind]
        if kind == "ppm_round":
            _ppm(folder / f"{sid}.ppm", np.floor(255 * clamped + 0.5))
        elif kind == "ppm_trunc":
            _ppm(folder / f"{sid}.ppm", np.floor(255 * clamped))
        elif kind == "png":
            write_png(folder / f"{sid}.png", classic)
        elif kind == "exr":
            write_exr(folder / f"{sid}.exr", classic)
        elif kind == "numpy":
            shutil.copy(numpy_ppm, folder / f"{sid}.ppm")
        elif kind in wrong:
            _ppm(folder / f"{sid}.ppm", np.floor(255 * np.clip(np.nan_to_num(wrong[kind]), 0, 1)))
        elif kind == "noise":
            noisy = clamped + rng.normal(0, 0.01, clamped.shape)
            _ppm(folder / f"{sid}.ppm", np.floor(255 * np.clip(noisy, 0, 1)))
        elif kind == "wrong_size":
            _ppm(folder / f"{sid}.ppm", np.zeros((120, 160, 3)))
        elif kind == "corrupt":
            (folder / f"{sid}.ppm").write_bytes(b"P6\n640 480\n255\n" + b"\0" * 100)
    return expected


def grade_timed(cmd: list[str]) -> tuple[float, float, float, str]:
    """Runs rtval grade; returns (wall s, s to the first per-student line, CPU s of it and
    its workers, stderr). CPU time tells the cost apart from other load on a shared machine."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu0 = usage.ru_utime + usage.ru_stime
    start = time.perf_counter()
    first = float("nan")
    lines = []
    with subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True) as p:
        assert p.stderr is not None
        for line in p.stderr:
            lines.append(line)
            # A student's line ("[3/200] id: pass ..."); the model's render lines come first.
            student = line.startswith("[") and "/" in line.split("]")[0] and "model" not in line
            if student and first != first:
                first = time.perf_counter() - start
        rc = p.wait()
    wall = time.perf_counter() - start
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    if rc != 0:
        raise SystemExit("".join(lines[-20:]))
    return wall, first, usage.ru_utime + usage.ru_stime - cpu0, "".join(lines)


def pair_costs() -> dict[str, float]:
    """One 640x480 pair in-process: exact match only, and the full metrics on top."""
    from compare.judge.images import read_image
    from compare.judge.target_model import parse_model
    from compare.render.cache import RenderCache
    from compare.verdict.against import judge_against_model, load, prepare

    work = ROOT / "build" / "bench-grade"
    loaded = load(
        prepare(parse_model("classic"), SCENES / "classic.json", None, RenderCache(CLASSIC_CACHE))
    )
    test = read_image(work / "renders" / "numpy.ppm")
    judge_against_model(test, loaded)  # the model's bounds, once per process
    t = time.process_time()
    for _ in range(5):
        ev = judge_against_model(test, loaded)
    exact = (time.process_time() - t) / 5
    wrong = read_image(next((work / "subs-classic").glob("paper_*.ppm")))
    t = time.process_time()
    ev = judge_against_model(wrong, loaded)
    assert ev.score is not None
    failing = time.process_time() - t
    t = time.process_time()
    _ = ev.maps, ev.per_effect
    full = time.process_time() - t
    return {
        "exact_match_cpu_s": exact,
        "failing_with_flip_cpu_s": failing,
        "full_maps_and_metrics_cpu_s": full,
    }


def scenario_classic(students: int, diagnose: bool = True) -> dict[str, object]:
    work = ROOT / "build" / "bench-grade"
    subs = work / "subs-classic"
    shutil.rmtree(subs, ignore_errors=True)
    expected = make_classic_class(subs, students)
    out = work / "out-classic"
    shutil.rmtree(out, ignore_errors=True)
    # Cold: the command renders the model itself (five classic renders) before grading, into
    # a render cache of its own that starts empty.
    shutil.rmtree(CLASSIC_CACHE, ignore_errors=True)
    cmd = [tool("rtval"), "grade", str(subs), "--scene", str(SCENES / "classic.json")]
    cmd += ["--out", str(out), "--jobs", "2", "--against", "classic"]
    cmd += ["--cache", str(CLASSIC_CACHE)]
    if not diagnose:
        cmd += ["--no-diagnose"]  # the judging alone; diagnosis costs extra per failing student
    load = os.getloadavg()[0]
    wall, first, cpu, _ = grade_timed(cmd)
    import csv

    with (out / "gradebook.csv").open() as f:
        book = {r["student"]: r for r in csv.DictReader(f)}
    wrong = [s for s, st in expected.items() if book[s]["status"] != st]
    empty = [s for s, r in book.items() if r["status"] == "fail" and not r["reasons"]]
    return {
        "scenario": "classic" if diagnose else "classic --no-diagnose",
        "submissions": students,
        "wall_s": wall,
        "per_submission_s": wall / students,
        "first_result_s": first,
        "cpu_s": cpu,
        "cpu_per_submission_s": cpu / students,
        "load_average_at_start": load,
        "wrong_verdicts": wrong,
        "fails_without_reason": empty,
        **pair_costs(),
    }


def scenario_mitsuba(students: int) -> list[dict[str, object]]:
    from class_generator import KINDS, make_class

    work = ROOT / "build" / "bench-grade"
    scene = SCENES / "classic.json"
    rtval = tool("rtval")
    warm = work / "warm"
    (work / "empty").mkdir(parents=True, exist_ok=True)
    # Grading an empty class renders (or finds) the reference the synthetic class is made from.
    subprocess.run(
        [
            rtval,
            "grade",
            str(work / "empty"),
            "--scene",
            str(scene),
            "--out",
            str(warm),
            "--against",
            "mitsuba",
        ],
        check=True,
        capture_output=True,
    )
    ref = warm / "references" / "classic-mitsuba.exr"  # grade's copy of the model render
    subs = work / "subs"
    if not subs.is_dir():
        make_class(
            ref, scene, tool("rtdemo"), subs, per_kind=-(-students // len(KINDS)), size=(640, 480)
        )
    n = sum(1 for _ in subs.iterdir())
    results = []
    for executor in ("local", "dask"):
        out = work / f"out-{executor}"
        shutil.rmtree(out, ignore_errors=True)  # the reference stays in the render cache
        cmd = [rtval, "grade", str(subs), "--scene", str(scene), "--out", str(out), "--jobs", "2"]
        cmd += ["--against", "mitsuba"]
        cluster = None
        if executor == "dask":
            from dask.distributed import LocalCluster

            cluster = LocalCluster(
                n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
            )
            cmd += ["--executor", "dask", "--scheduler", cluster.scheduler_address]
        load = os.getloadavg()[0]
        wall, first, cpu, _ = grade_timed(cmd)
        if cluster:
            cluster.close()
        results.append(
            {
                "scenario": f"mitsuba ({executor})",
                "submissions": n,
                "wall_s": wall,
                "per_submission_s": wall / n,
                "first_result_s": first,
                "cpu_s": cpu,
                "cpu_per_submission_s": cpu / n,
                "load_average_at_start": load,
            }
        )
    return results


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--students", type=int, default=200)
    parser.add_argument("--scenario", choices=("classic", "mitsuba", "all"), default="all")
    parser.add_argument(
        "--no-diagnose", action="store_true", help="grade the classic class without diagnoses"
    )
    args = parser.parse_args()
    results: list[dict[str, object]] = []
    if args.scenario in ("classic", "all"):
        results.append(scenario_classic(args.students, diagnose=not args.no_diagnose))
    if args.scenario in ("mitsuba", "all"):
        results += scenario_mitsuba(args.students)
    rows = [
        [
            r["scenario"],
            r["submissions"],
            r["wall_s"],
            r["per_submission_s"],
            r["first_result_s"],
            r["cpu_per_submission_s"],
            r["load_average_at_start"],
        ]
        for r in results
    ]
    print_table(
        [
            "scenario",
            "submissions",
            "wall s",
            "s per submission",
            "first result s",
            "CPU s per submission",
            "load at start",
        ],
        rows,
    )
    for r in results:
        if "exact_match_cpu_s" in r:
            print(
                f"one 640x480 pair, CPU s: an exact image {r['exact_match_cpu_s']:.3f}; a failing "
                f"one (FLIP over the failing effects' crop) {r['failing_with_flip_cpu_s']:.3f}; "
                f"full SSIM+FLIP maps and metrics {r['full_maps_and_metrics_cpu_s']:.3f}; "
                f"wrong verdicts {len(r['wrong_verdicts'])}, fails without a reason "  # type: ignore[arg-type]
                f"{len(r['fails_without_reason'])}"  # type: ignore[arg-type]
            )
    print(f"wrote {write_results('grade', {'size': [640, 480], 'cores': 2, 'results': results})}")


if __name__ == "__main__":
    main()
