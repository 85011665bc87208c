"""Issue 7's numerical study: does physical mode converge to the Mitsuba Whitted reference,
and which way does each quirk's fix move the per-effect error?

Part 1 (same pixel sampling on both sides): demo physical (CPU and GL) with centre rays
against `rtval reference --integrator whitted --light point --centre-rays`; SSIM and relative
MSE overall and per effect mask, plus how many isolated pixels carry the relative MSE.
Part 2: the paper's program with one quirk fixed at a time, per-effect mean FLIP against the
converged (32 spp, box-filtered) point-light reference, and Q10 as 16 stratified spp.
Part 3: physical 16 spp against the area-light reference: is the difference in penumbrae?
Usage: python bench/bench_physical.py [--scenes paper classic]
"""

from __future__ import annotations

import argparse
import hashlib
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import ROOT, SCENES, print_table, tool, write_results

from compare.judge.effects import EFFECTS, effect_masks
from compare.judge.images import read_image
from compare.judge.metrics import compute_maps, compute_metrics
from compare.judge.penumbra import penumbra_numbers
from compare.render.cache import renderer_identity
from safe_files.content import sha256_file
from scene_model.scene import load_scene

CACHE = ROOT / "build" / "bench-cache"
QUIRKS = [f"Q{i}" for i in range(1, 14)]


def render(cmd: list[str], out: Path) -> Path:
    """Renders once per (command, scene, renderer build): a changed renderer re-renders."""
    tool_name = "rtdemo" if Path(cmd[0]).name == "rtdemo" else "rtval"
    key = hashlib.sha256((shlex.join(cmd[1:]) + renderer_identity(tool_name)).encode())
    key.update(sha256_file(Path(next(a for a in cmd if a.endswith(".json")))).encode())
    cached = out.with_name(f"{out.stem}-{key.hexdigest()[:16]}.exr")
    if not cached.is_file():
        tmp = cached.with_name(cached.stem + ".partial.exr")
        subprocess.run([*cmd, "-o", str(tmp)], check=True, capture_output=True)
        tmp.replace(cached)
    return cached


def rel_mse_map(ref: np.ndarray, test: np.ndarray) -> np.ndarray:
    r = ref.astype(np.float64)
    return np.asarray(((r - test) ** 2 / (r * r + 0.01)).mean(-1))


def study(scene_name: str) -> dict:
    scene_file = SCENES / f"{scene_name}.json"
    scene = load_scene(scene_file)
    rtdemo, rtval = tool("rtdemo"), tool("rtval")
    CACHE.mkdir(parents=True, exist_ok=True)
    c = lambda name: CACHE / f"{scene_name}-{name}.exr"  # noqa: E731
    centre = read_image(
        render(
            [
                rtval,
                "reference",
                str(scene_file),
                "--integrator",
                "whitted",
                "--light",
                "point",
                "--centre-rays",
            ],
            c("ref-centre"),
        )
    )
    converged = read_image(
        render(
            [
                rtval,
                "reference",
                str(scene_file),
                "--integrator",
                "whitted",
                "--light",
                "point",
                "--spp",
                "32",
            ],
            c("ref-converged"),
        )
    )
    area = read_image(
        render(
            [
                rtval,
                "reference",
                str(scene_file),
                "--integrator",
                "whitted",
                "--light",
                "area",
                "--spp",
                "16",
            ],
            c("ref-area"),
        )
    )
    masks_centre = effect_masks(scene, centre.aovs["id"], centre.aovs["depth"])
    masks_conv = effect_masks(scene, converged.aovs["id"], converged.aovs["depth"])

    part1 = []
    for backend in ("cpu", "gl"):
        demo = read_image(
            render(
                [
                    rtdemo,
                    "render",
                    str(scene_file),
                    "--mode",
                    "physical",
                    "--backend",
                    backend,
                    "-q",
                ],
                c(f"physical-{backend}"),
            )
        )
        maps = compute_maps(centre.rgb, demo.rgb, hdr=False)
        rel = rel_mse_map(centre.rgb, demo.rgb)
        for name in ("overall", *EFFECTS):
            region = np.ones(rel.shape, bool) if name == "overall" else masks_centre[name]
            if not region.any():
                continue
            m = compute_metrics(centre.rgb, demo.rgb, maps, mask=region)
            v = np.sort(rel[region])[::-1]
            # smallest k such that dropping the k worst pixels brings relMSE to <= 1e-3
            tail = np.cumsum(v[::-1])[::-1]  # tail[k] = sum of v[k:]
            k = int(np.argmax(tail / v.size <= 1e-3)) if (tail / v.size <= 1e-3).any() else v.size
            carriers = k
            part1.append(
                {
                    "backend": backend,
                    "mask": name,
                    "pixels": int(region.sum()),
                    "ssim": m.ssim,
                    "rel_mse": float(v.mean()),
                    "pixels_carrying_rel_mse": carriers,
                    "rel_mse_without_them": float(v[carriers:].mean())
                    if carriers < v.size
                    else 0.0,
                    "ssim_ok": m.ssim >= 0.995,
                    "rel_mse_ok": float(v.mean()) <= 1e-3,
                }
            )

    part2 = []
    variants = (
        [("paper", ["--mode", "paper"])]
        + [
            (
                f"paper +{q}",
                ["--mode", "paper", "--fix", q] + (["--spp", "16"] if q == "Q10" else []),
            )
            for q in QUIRKS
        ]
        + [("physical 16 spp", ["--mode", "physical", "--spp", "16"])]
    )
    for label, args in variants:
        key = label.replace(" ", "_").replace("+", "fix")
        img = read_image(render([rtdemo, "render", str(scene_file), "-q", *args], c(key)))
        maps = compute_maps(converged.rgb, img.rgb, hdr=False)
        row = {"variant": label}
        for name in EFFECTS:
            if masks_conv[name].any():
                row[name] = compute_metrics(
                    converged.rgb, img.rgb, maps, mask=masks_conv[name]
                ).flip_ldr
        row["overall"] = compute_metrics(converged.rgb, img.rgb, maps).flip_ldr
        part2.append(row)

    demo16 = read_image(
        render(
            [rtdemo, "render", str(scene_file), "-q", "--mode", "physical", "--spp", "16"],
            c("physical_16_spp"),
        )
    )
    part3 = penumbra_numbers(converged.rgb, area.rgb, demo16.rgb)
    return {"scene": scene_name, "centre_rays": part1, "quirks": part2, "area_lights": part3}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--scenes", nargs="+", default=["paper", "classic"])
    args = parser.parse_args()
    results = [study(s) for s in args.scenes]
    for r in results:
        print(f"\n== {r['scene']}: physical vs Whitted reference, centre rays on both sides")
        print_table(
            ["backend", "mask", "pixels", "SSIM", "rel MSE", "px carrying it", "rel MSE w/o them"],
            [
                [
                    p["backend"],
                    p["mask"],
                    p["pixels"],
                    p["ssim"],
                    p["rel_mse"],
                    p["pixels_carrying_rel_mse"],
                    p["rel_mse_without_them"],
                ]
                for p in r["centre_rays"]
            ],
        )
        print(
            f"\n== {r['scene']}: mean FLIP per effect vs the converged reference, one quirk fixed at a time"
        )
        effects = [e for e in EFFECTS if e in r["quirks"][0]]
        print_table(
            ["variant", *effects, "overall"],
            [[q["variant"], *[q[e] for e in effects], q["overall"]] for q in r["quirks"]],
        )
        a = r["area_lights"]
        print(
            f"\narea lights: {100 * a['error_share_in_penumbra']:.1f} % of physical's error lies in "
            f"{a['penumbra_pixels']} penumbra pixels; {a['differing_pixels_outside_penumbra']} pixels outside differ > 2/255;\n"
            f"  mean |demo - ref| inside: {a['mae_vs_area_inside']:.5f} vs area, {a['mae_vs_point_inside']:.5f} vs point; "
            f"outside: {a['mae_vs_area_outside']:.5f} vs area, {a['mae_vs_point_outside']:.5f} vs point"
        )
    print(f"wrote {write_results('physical', {'studies': results})}")


if __name__ == "__main__":
    main()
