"""`rtval report` on the paper's scene at its own size (1200x800), cold and warm, with the
floor of each of its parts measured on its own (the targets: cold <= 90 s, warm <= 5 s, the
report folder <= 25 MB with the PDF, on 2 cores).

Cold: a fresh, empty render cache and reports folder under /tmp; warm: the same again. The
report's own step table (report.json's "timings") gives the breakdown. Then each part's
floor, measured: Mitsuba's kernels (one `rtval reference` process for the reference, and its
render loop's own seconds), FLIP and SSIM of one 1200x800 pair on one core (the whole-image
flip-evaluator calls the judge made before flip_crops, and the judge's maps now: same pair,
same run), writing the report's PNGs and EXRs from its renders, and Chromium printing its
page. Prints both tables and which part is the floor; writes bench/results/report.json.

    python bench/bench_report.py [--keep] [--floors-only DIR]   (DIR: a --keep run's folder)
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from common import ROOT, SCENES, print_table, tool, write_results

# FLIP's floor is one core's: the report's metric workers run one OpenMP thread each.
CHILD_ENV = dict(os.environ)
os.environ["OMP_NUM_THREADS"] = "1"
SCENE = SCENES / "paper.json"
TARGETS = {"cold_s": 90.0, "warm_s": 5.0, "folder_mb": 25.0}
PARTS = {  # report step names (substrings) -> the part whose floor bounds them
    "Mitsuba": "Mitsuba's kernels",
    "metrics": "FLIP",
    "difference maps": "FLIP",
    "images (PNG, EXR)": "PNG/EXR writing",
    "PDF": "Chromium",
}


def _report(work: Path) -> dict[str, Any]:
    """One `rtval report` process into work/reports with the render cache work/cache."""
    cmd = [tool("rtval"), "report", str(SCENE), "--reports-dir", str(work / "reports"),
           "--cache", str(work / "cache")]  # fmt: skip
    env = {**CHILD_ENV, "RTVAL_CACHE": str(work / "cache")}
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env, cwd=ROOT)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"{shlex.join(cmd)} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    record = json.loads((work / "reports" / "paper" / "report.json").read_text())
    return {"wall_s": wall, "steps": record["timings"], "load_1min": os.getloadavg()[0]}


def _folder(path: Path) -> dict[str, Any]:
    sizes: dict[str, int] = {}
    for f in path.rglob("*"):
        if f.is_file():
            kind = f.suffix.lower().lstrip(".") or "other"
            sizes[kind] = sizes.get(kind, 0) + f.stat().st_size
    return {"bytes": sum(sizes.values()), "by_kind": sizes}


def _timed(fn: Any, repeats: int = 1) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _mitsuba_floor(record: dict[str, Any], tmp: Path) -> dict[str, Any]:
    """The reference's own command, alone: the process, and its render loop's seconds."""
    from compare.judge.images import read_image

    ref = next(r for r in record["renders"] if r["family"] == "reference")
    args = shlex.split(ref["command"])[1:]
    out = tmp / "reference.exr"
    args = [str(SCENE) if a == "scene.json" else str(out) if a == ref["exr"] else a for a in args]
    cmd = [tool("rtval"), *args]
    wall = _timed(lambda: subprocess.run(cmd, check=True, capture_output=True, env=CHILD_ENV))
    loop = float(read_image(out).header.get("rtval.render_seconds", "nan"))
    return {"command": shlex.join(["rtval", *args]), "process_s": wall, "render_loop_s": loop}


def _old_flip(ref: Any, test: Any) -> None:
    """The judge's FLIP before flip_crops: flip-evaluator over the whole image, LDR of the
    display values and HDR with its own exposures."""
    import flip_evaluator
    import numpy as np

    from compare.judge.images import linear_to_srgb

    p = {"ppd": 67.0}
    flip_evaluator.evaluate(
        linear_to_srgb(ref), linear_to_srgb(test), "LDR", applyMagma=False, parameters=p
    )
    clean = [np.maximum(np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0), 0) for x in (ref, test)]
    flip_evaluator.evaluate(*clean, "HDR", applyMagma=False, parameters=p)


def _flip_floor(folder: Path, tmp: Path) -> dict[str, Any]:
    """One featured pair's FLIP (LDR + HDR) and SSIM at 1200x800 on one core: the whole-image
    calls of before and the judge's maps now, for the paper-mode demo and a 16-spp physical
    render against the reference."""
    from compare.judge.images import read_image
    from compare.judge.metrics import compute_maps

    ref = read_image(folder / "images" / "ref-converged.exr").rgb
    physical = tmp / "physical-16spp.exr"
    subprocess.run([tool("rtdemo"), "render", str(SCENE), "-o", str(physical), "-q",
                    "--mode", "physical", "--spp", "16"], check=True, env=CHILD_ENV)  # fmt: skip
    rows = {}
    for name, path in (("demo paper", folder / "images" / "demo-paper-cpu.exr"),
                       ("demo physical 16 spp", physical)):  # fmt: skip
        test = read_image(path).rgb
        old = _timed(lambda t=test: _old_flip(ref, t), 2)
        new = _timed(lambda t=test: compute_maps(ref, t, hdr=True), 2)
        ldr = _timed(lambda t=test: compute_maps(ref, t, hdr=False), 2)
        rows[name] = {"whole_image_ldr_hdr_s": old, "maps_now_ldr_hdr_ssim_s": new,
                      "maps_now_ldr_ssim_s": ldr, "speedup": old / new}  # fmt: skip
    return rows


def _writing_floor(folder: Path, cache: Path, tmp: Path) -> dict[str, Any]:
    """The report's PNGs (one per shown render) and ZIP EXRs, written from its renders."""
    from compare.judge.images import read_image, write_exr
    from compare.judge.png import write_png

    record = json.loads((folder / "report.json").read_text())
    by_sha = {}
    for side in (cache / "renders").glob("*.json"):
        info = json.loads(side.read_text())
        by_sha[info.get("sha256")] = side.with_suffix(".exr")
    renders = [r for r in record["renders"] if r.get("sha256") in by_sha]
    images = {r["key"]: read_image(by_sha[r["sha256"]]) for r in renders}
    pngs = [r["key"] for r in renders if r.get("png")]
    exrs = [r["key"] for r in renders if r.get("exr")]

    def pngs_out() -> None:
        for k in pngs:
            write_png(tmp / f"{k}.png", images[k].rgb)

    def exrs_out() -> None:
        for k in exrs:
            write_exr(tmp / f"{k}.exr", images[k].rgb, aovs=images[k].aovs, header=images[k].header)

    png_s, exr_s = _timed(pngs_out), _timed(exrs_out)
    return {"png": len(pngs), "png_s": png_s, "exr": len(exrs), "exr_s": exr_s,
            "total_s": png_s + exr_s}  # fmt: skip


def _chromium_floor(folder: Path, tmp: Path) -> dict[str, Any]:
    from compare.report.pdf import write_pdf

    pdf = tmp / "report.pdf"
    return {"print_s": _timed(lambda: write_pdf(folder / "index.html", pdf)),
            "pdf_bytes": pdf.stat().st_size}  # fmt: skip


def _floors(work: Path) -> dict[str, Any]:
    folder, cache = work / "reports" / "paper", work / "cache"
    record = json.loads((folder / "report.json").read_text())
    with tempfile.TemporaryDirectory(prefix="rtval-bench-floors-") as t:
        tmp = Path(t)
        return {
            "Mitsuba's kernels": _mitsuba_floor(record, tmp),
            "FLIP": _flip_floor(folder, tmp),
            "PNG/EXR writing": _writing_floor(folder, cache, tmp),
            "Chromium": _chromium_floor(folder, tmp),
        }


def _floor_seconds(floors: dict[str, Any]) -> dict[str, float]:
    """Each part's measured floor in seconds: the reference's process; one featured pair's
    maps now; every picture written; one print."""
    pair = max(r["maps_now_ldr_hdr_ssim_s"] for r in floors["FLIP"].values())
    return {
        "Mitsuba's kernels": floors["Mitsuba's kernels"]["process_s"],
        "FLIP": pair,
        "PNG/EXR writing": floors["PNG/EXR writing"]["total_s"],
        "Chromium": floors["Chromium"]["print_s"],
    }


def _print(cold: dict[str, Any], warm: dict[str, Any] | None, floors: dict[str, Any]) -> str:
    warm_steps = {s["step"]: s["seconds"] for s in (warm or {}).get("steps", [])}
    rows = []
    for s in cold["steps"]:
        part = next((p for k, p in PARTS.items() if k in s["step"]), "")
        rows.append([s["step"], s["seconds"], warm_steps.get(s["step"], "-"), part])
    rows.append(["whole process", cold["wall_s"], warm["wall_s"] if warm else "-", ""])
    print_table(["step", "cold s", "warm s", "part"], rows)
    seconds = _floor_seconds(floors)
    loop = floors["Mitsuba's kernels"]["render_loop_s"]
    print()
    print_table(["part", "floor s", "measured as"], [
        ["Mitsuba's kernels", seconds["Mitsuba's kernels"],
         f"one `rtval reference` process (render loop {loop:.2f} s)"],
        ["FLIP", seconds["FLIP"], "one featured 1200x800 pair's maps, one core"],
        ["PNG/EXR writing", seconds["PNG/EXR writing"],
         f"{floors['PNG/EXR writing']['png']} PNGs + {floors['PNG/EXR writing']['exr']} EXRs"],
        ["Chromium", seconds["Chromium"], "one print of the page"],
    ])  # fmt: skip
    print()
    print_table(["FLIP pair, one core", "whole image s", "maps now s", "ratio"], [
        [k, v["whole_image_ldr_hdr_s"], v["maps_now_ldr_hdr_ssim_s"], v["speedup"]]
        for k, v in floors["FLIP"].items()
    ])  # fmt: skip
    floor = max(seconds, key=lambda k: seconds[k])
    print(f"\nfloor: {floor} ({seconds[floor]:.2f} s)")
    return floor


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--floors-only", type=Path, help="a kept run's work folder: floors only")
    ap.add_argument("--keep", action="store_true", help="keep the run's render cache (~1 GB)")
    args = ap.parse_args()
    work = args.floors_only or Path(tempfile.mkdtemp(prefix="rtval-bench-report-"))
    cold = warm = None
    if not args.floors_only:
        print(f"cold report into {work} ...", flush=True)
        cold = _report(work)
        print("warm report ...", flush=True)
        warm = _report(work)
    folder = _folder(work / "reports" / "paper")
    floors = _floors(work)
    if cold is None:
        record = json.loads((work / "reports" / "paper" / "report.json").read_text())
        cold = {"wall_s": float("nan"), "steps": record["timings"]}
    floor = _print(cold, warm, floors)
    mb = folder["bytes"] / 1e6
    print(f"reports/paper: {mb:.1f} MB (target <= {TARGETS['folder_mb']:.0f} MB)")
    path = write_results("report", {
        "scene": str(SCENE.relative_to(ROOT)), "size": "1200x800", "work": str(work),
        "cold": cold, "warm": warm, "targets": TARGETS, "folder": folder,
        "floors": floors, "floor_seconds": _floor_seconds(floors), "floor": floor,
    })  # fmt: skip
    print(f"wrote {path}")
    if not args.floors_only and not args.keep:
        shutil.rmtree(work / "cache", ignore_errors=True)  # ~1 GB of renders
    return 0


if __name__ == "__main__":
    sys.exit(main())
