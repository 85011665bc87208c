"""Which renders a report makes, as commands (see jobs.py).

The converged reference is Mitsuba with rtval_whitted (the demo's physical light transport,
sphere lights as calibrated points), box-filtered with REFERENCE_SPP random samples per pixel.
Everything is measured against it.

What cannot change a scene is not rendered: without a light there is no area-light
reference (no penumbrae) and no shadow ablation; without glass no refraction ablation
(`not_applicable` says why, for the page).
"""

from __future__ import annotations

from dataclasses import dataclass

from compare.judge.quirks import QUIRKS as QUIRK_TEXT
from compare.render.jobs import RenderJob
from scene_model.scene import Scene, load_scene

REFERENCE_KEY = "ref-converged"
REFERENCE_SPP = 32
AREA_SPP = 16  # soft shadows only need to show where the penumbrae are
DEMO_YARDSTICK_SPP = 64  # the demo's own finest render: its error at fewer spp (convergence.py)
QUIRKS = [f"Q{n}" for n in sorted(QUIRK_TEXT)]  # every quirk of the paper's program
SAMPLING_QUIRK = "Q10"  # the ladder fixes it last, with LADDER_SPP: its end is physical mode
LADDER_SPP = 16
# The order in which the ladder fixes the quirks: by number, pixel-centre sampling last.
LADDER_ORDER = [q for q in QUIRKS if q != SAMPLING_QUIRK] + [SAMPLING_QUIRK]
EFFECT_SWITCHES = ("shadows", "reflection", "refraction")
AREA_KEY = "ref-area"


@dataclass(frozen=True)
class LadderStep:
    name: str  # "paper", "+Q1", ..., "+Q10 = physical 16 spp"
    key: str  # the render of this step
    quirk: str | None  # the quirk this step fixes on top of the earlier ones (None: the start)


def ladder_steps() -> list[LadderStep]:
    """paper -> Q1 fixed -> Q1,Q2 fixed ... -> every quirk but Q10 fixed -> physical 16 spp."""
    steps = [LadderStep("paper", "demo-paper-cpu", None)]
    for i, q in enumerate(LADDER_ORDER[:-1], start=1):
        steps.append(LadderStep(f"+{q}", f"ladder-{i:02d}", q))
    end = f"demo-physical-cpu-{LADDER_SPP}spp"
    steps.append(LadderStep(f"+{SAMPLING_QUIRK} = physical {LADDER_SPP} spp", end, SAMPLING_QUIRK))
    return steps


def not_applicable(scene: Scene) -> dict[str, str]:
    """What the scene lacks for a render to show anything: effect switch (or "area light")
    -> why switching it changes nothing. Switches not named here can change the image."""
    kinds = {s.kind for s in scene.spheres}
    why = {}
    if not scene.lights:
        why["shadows"] = "the scene has no light, so nothing casts a shadow"
        why["area light"] = "the scene has no light, so there are no penumbrae"
    if not kinds & {"mirror", "glass"}:
        why["reflection"] = "the scene has no mirror and no glass"
    if "glass" not in kinds:
        why["refraction"] = "the scene has no glass"
    return why


def plan(scene: str, size: tuple[int, int] | None) -> list[RenderJob]:
    loaded = load_scene(scene)
    skipped = not_applicable(loaded)
    lights = "point lights" if loaded.lights else "no light"  # a label must not invent one
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
            f"Mitsuba whitted, {lights}, {REFERENCE_SPP} spp (converged reference)",
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
    if "area light" not in skipped:
        jobs.append(
            ref(
                AREA_KEY,
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
    # Ablation ladder: the paper's program with quirks fixed one after another (cumulative);
    # its first and last steps are the paper-mode and physical-mode renders above.
    for i, step in enumerate(ladder_steps()[1:-1], start=1):
        fixed = ",".join(LADDER_ORDER[:i])
        jobs.append(
            demo(step.key, f"paper + {fixed} fixed", "ladder", "--mode", "paper", "--fix", fixed)
        )
    # Effect ablation at pixel centres: each side with one effect switched off, for the
    # switches that can change this scene (the others would give three copies of their base).
    switches = [e for e in EFFECT_SWITCHES if e not in skipped]
    if switches:
        jobs.append(
            ref(
                "ref-centre",
                f"Mitsuba whitted, {lights}, pixel centres",
                "ablation",
                "--integrator",
                "whitted",
                "--light",
                "point",
                "--centre-rays",
            )
        )
    for effect in switches:
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
