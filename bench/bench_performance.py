"""Issue 10's targets, measured in one run on this machine (ratios only within the run):

- CPU demo against the seed baseline (bench/baseline/seed_tracer.cpp: plain, single-threaded,
  scalar, PPM), both timed as whole processes the way a user runs them;
- GL backend frame time on this machine's OpenGL (llvmpipe here), compile time apart;
- the judge: every metric for one 640x480 pair, and the per-effect table on top.
Usage: python bench/bench_performance.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import ROOT, SCENES, print_table, time_process, tool, write_results  # noqa: E402


def main() -> None:
    from compare.effects import EFFECTS, effect_masks
    from compare.images import read_image
    from compare.metrics import compute_maps, compute_metrics
    from mitsuba_ref.scene import load_scene

    baseline = ROOT / "build" / "cmake" / "seed_tracer"
    if not baseline.is_file():
        raise SystemExit(f"{baseline} missing: it is built with the test suite (make setup)")
    rtdemo = tool("rtdemo")
    rows, cpu = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in ("paper", "classic"):
            for mode in ("paper", "classic"):
                base = time_process([str(baseline), str(SCENES / f"{scene}.json"), f"{tmp}/b.ppm", mode], repeats=5)
                demo = time_process([rtdemo, "render", str(SCENES / f"{scene}.json"), "-o", f"{tmp}/d.exr",
                                     "--mode", mode, "-q"], repeats=5)
                demo_ppm = time_process([rtdemo, "render", str(SCENES / f"{scene}.json"), "--ppm", f"{tmp}/d.ppm",
                                         "--mode", mode, "-q"], repeats=5)
                frame = float(read_image(f"{tmp}/d.exr").header["rtval.render_seconds"])
                same = Path(f"{tmp}/b.ppm").read_bytes() == Path(f"{tmp}/d.ppm").read_bytes()
                entry = {"scene": scene, "mode": mode, "baseline_s": base["median_s"], "rtdemo_exr_s": demo["median_s"],
                         "rtdemo_ppm_s": demo_ppm["median_s"], "rtdemo_frame_s": frame,
                         "speedup_exr": base["median_s"] / demo["median_s"],
                         "speedup_ppm": base["median_s"] / demo_ppm["median_s"], "identical_ppm": same}
                cpu.append(entry)
                rows.append([scene, mode, entry["baseline_s"], entry["rtdemo_exr_s"], entry["rtdemo_ppm_s"], frame,
                             entry["speedup_exr"], entry["speedup_ppm"], same])
        print("CPU demo against the seed baseline (whole processes, median of 5)")
        print_table(["scene", "mode", "baseline s", "rtdemo exr s", "rtdemo ppm s", "frame s", "x (exr)", "x (ppm)",
                     "same ppm"], rows)

        gl = []
        for scene in ("paper", "classic"):
            time_process([rtdemo, "render", str(SCENES / f"{scene}.json"), "-o", f"{tmp}/g.exr", "--backend", "gl",
                          "--frames", "10", "-q"], repeats=1)
            h = read_image(f"{tmp}/g.exr").header
            gl.append({"scene": scene, "renderer": h["rtval.gl_renderer"], "compile_s": float(h["rtval.gl_compile_seconds"]),
                       "first_frame_s": float(h["rtval.gl_first_frame_seconds"]), "frame_s": float(h["rtval.render_seconds"])})
        print("\nGL backend (10 frames, median after the first)")
        print_table(["scene", "renderer", "compile s", "first frame s", "frame s"],
                    [[g["scene"], g["renderer"][:34], g["compile_s"], g["first_frame_s"], g["frame_s"]] for g in gl])

        scene = load_scene(SCENES / "paper.json")
        time_process([rtdemo, "render", str(SCENES / "paper.json"), "-o", f"{tmp}/p.exr", "-q"], repeats=1)
        time_process([rtdemo, "render", str(SCENES / "paper.json"), "-o", f"{tmp}/q.exr", "--mode", "physical", "-q"],
                     repeats=1)
        ref, test = read_image(f"{tmp}/q.exr"), read_image(f"{tmp}/p.exr")
        compute_maps(ref.rgb, test.rgb, hdr=True)  # warm-up (imports, FLIP set-up)
        t0 = time.perf_counter()
        maps = compute_maps(ref.rgb, test.rgb, hdr=True)
        compute_metrics(ref.rgb, test.rgb, maps)
        t_all = time.perf_counter() - t0
        t0 = time.perf_counter()
        masks = effect_masks(scene, ref.aovs["id"], ref.aovs["depth"])
        for name in EFFECTS:
            if masks[name].any():
                compute_metrics(ref.rgb, test.rgb, maps, mask=masks[name])
        t_effects = time.perf_counter() - t0
    judge = {"all_metrics_s": t_all, "per_effect_extra_s": t_effects, "per_effect_extra_pct": 100 * t_effects / t_all}
    print(f"\njudge, one 640x480 pair: all metrics incl. FLIP LDR+HDR {t_all:.3f} s; per-effect table +{t_effects:.3f} s "
          f"({judge['per_effect_extra_pct']:.0f} %)")
    print(f"wrote {write_results('performance', {'cpu': cpu, 'gl': gl, 'judge': judge})}")


if __name__ == "__main__":
    main()
