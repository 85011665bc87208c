"""Which renders a report makes, as commands (see jobs.py).

The converged reference is Mitsuba with rtval_whitted (the demo's physical light transport,
sphere lights as calibrated points), box-filtered with REFERENCE_SPP random samples per pixel.
Everything is measured against it.
"""

from __future__ import annotations

from compare.render.jobs import RenderJob

REFERENCE_KEY = "ref-converged"
REFERENCE_SPP = 32
AREA_SPP = 16  # soft shadows only need to show where the penumbrae are
DEMO_YARDSTICK_SPP = 64  # the demo's own finest render: its error at fewer spp (convergence.py)
QUIRKS = [f"Q{i}" for i in range(1, 11)]
EFFECT_SWITCHES = ("shadows", "reflection", "refraction")


def plan(scene: str, size: tuple[int, int] | None) -> list[RenderJob]:
    size_demo = ["--width", str(size[0]), "--height", str(size[1])] if size else []
    size_ref = ["--size", f"{size[0]}x{size[1]}"] if size else []

    def demo(key: str, label: str, family: str, *args: str, spp: int = 1) -> RenderJob:
        return RenderJob(
            key,
            label,
            "rtdemo",
            ["render", "{scene}", "-o", "{out}", "-q", *args, *size_demo],
            family,
            spp,
            scene,
        )

    def ref(key: str, label: str, family: str, *args: str, spp: int = 1) -> RenderJob:
        return RenderJob(
            key,
            label,
            "rtval",
            ["reference", "{scene}", "-o", "{out}", *args, *size_ref],
            family,
            spp,
            scene,
        )

    jobs = [
        ref(
            REFERENCE_KEY,
            f"Mitsuba whitted, point lights, {REFERENCE_SPP} spp (converged reference)",
            "reference",
            "--integrator",
            "whitted",
            "--light",
            "point",
            "--spp",
            str(REFERENCE_SPP),
            spp=REFERENCE_SPP,
        ),
        demo("demo-paper-cpu", "demo paper mode, CPU", "demo paper cpu", "--mode", "paper"),
        demo("demo-classic-cpu", "demo classic mode, CPU", "demo classic cpu", "--mode", "classic"),
        demo(
            "demo-paper-gl",
            "demo paper mode, GL",
            "demo paper gl",
            "--mode",
            "paper",
            "--backend",
            "gl",
        ),
    ]
    for spp in (1, 4, 16, DEMO_YARDSTICK_SPP):
        jobs.append(
            demo(
                f"demo-physical-cpu-{spp}spp",
                f"demo physical mode, CPU, {spp} spp",
                "demo physical cpu",
                "--mode",
                "physical",
                "--spp",
                str(spp),
                spp=spp,
            )
        )
        if spp == DEMO_YARDSTICK_SPP:
            continue
        jobs.append(
            demo(
                f"demo-physical-gl-{spp}spp",
                f"demo physical mode, GL, {spp} spp",
                "demo physical gl",
                "--mode",
                "physical",
                "--backend",
                "gl",
                "--spp",
                str(spp),
                spp=spp,
            )
        )
    for spp in (4, 16):
        jobs.append(
            demo(
                f"demo-paper-cpu-{spp}spp",
                f"demo paper mode + Q10 fixed, CPU, {spp} spp",
                "demo paper cpu",
                "--mode",
                "paper",
                "--fix",
                "Q10",
                "--spp",
                str(spp),
                spp=spp,
            )
        )
    for spp in (1, 4):
        jobs.append(
            ref(
                f"mitsuba-whitted-llvm-{spp}spp",
                f"Mitsuba whitted llvm_ad_rgb, {spp} spp",
                "mitsuba whitted llvm",
                "--integrator",
                "whitted",
                "--light",
                "point",
                "--spp",
                str(spp),
                spp=spp,
            )
        )
    # No Whitted scalar_rgb render: one ray at a time in Python, it took 22 s of a cold report's
    # 73 s of Mitsuba for the 1 spp llvm render's very image (float64 intersections aside);
    # the path tracer's scalar render below stands for the scalar variant on the chart.
    for spp in (1, 4, 16, 64):
        jobs.append(
            ref(
                f"mitsuba-path-llvm-{spp}spp",
                f"Mitsuba path llvm_ad_rgb, {spp} spp",
                "mitsuba path llvm",
                "--integrator",
                "path",
                "--light",
                "point",
                "--spp",
                str(spp),
                spp=spp,
            )
        )
    jobs.append(
        ref(
            "mitsuba-path-scalar-1spp",
            "Mitsuba path scalar_rgb, 1 spp",
            "mitsuba path scalar",
            "--integrator",
            "path",
            "--light",
            "point",
            "--variant",
            "scalar_rgb",
            spp=1,
        )
    )
    jobs.append(
        ref(
            "ref-area",
            f"Mitsuba whitted, area lights, {AREA_SPP} spp (soft shadows)",
            "reference area",
            "--integrator",
            "whitted",
            "--light",
            "area",
            "--spp",
            str(AREA_SPP),
            spp=AREA_SPP,
        )
    )
    # Ablation ladder: the paper's program with quirks fixed one after another (cumulative).
    for i in range(1, 10):
        fixed = ",".join(QUIRKS[:i])
        jobs.append(
            demo(
                f"ladder-{i:02d}",
                f"paper + {fixed} fixed",
                "ladder",
                "--mode",
                "paper",
                "--fix",
                fixed,
            )
        )
    # Effect ablation at pixel centres: each side with one effect switched off.
    jobs.append(
        ref(
            "ref-centre",
            "Mitsuba whitted, point lights, pixel centres",
            "ablation",
            "--integrator",
            "whitted",
            "--light",
            "point",
            "--centre-rays",
        )
    )
    for effect in EFFECT_SWITCHES:
        jobs.append(
            ref(
                f"ref-centre-no-{effect}",
                f"Mitsuba whitted, pixel centres, no {effect}",
                "ablation",
                "--integrator",
                "whitted",
                "--light",
                "point",
                "--centre-rays",
                f"--no-{effect}",
            )
        )
        jobs.append(
            demo(
                f"demo-paper-cpu-no-{effect}",
                f"demo paper mode, no {effect}",
                "ablation",
                "--mode",
                "paper",
                f"--no-{effect}",
            )
        )
        jobs.append(
            demo(
                f"demo-physical-cpu-no-{effect}",
                f"demo physical mode, no {effect}",
                "ablation",
                "--mode",
                "physical",
                f"--no-{effect}",
            )
        )
    return jobs
