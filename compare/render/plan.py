"""Which renders a report makes, as commands (see jobs.py), and what each is for.

The converged reference is Mitsuba with rtval_whitted (the demo's physical light transport,
sphere lights as calibrated points), box-filtered with REFERENCE_SPP random samples per pixel.
Everything is measured against it.

What cannot change a scene is not rendered: without a light there is no area-light
reference (no penumbrae) and no shadow ablation; without glass no refraction ablation
(`not_applicable` says why, for the page).

`plan()` returns a RenderPlan: the jobs in the order they run and are listed, and named fields
for the roles the report gives them, so that no render key is spelled outside this file.
"""

from __future__ import annotations

from dataclasses import dataclass

from compare.judge.quirks import QUIRKS as QUIRK_TEXT
from compare.judge.target_model import SWITCHABLE_EFFECTS
from compare.render.jobs import RenderJob
from scene_model.scene import Scene, load_scene

REFERENCE_KEY = "ref-converged"
REFERENCE_SPP = 32
AREA_SPP = 16  # soft shadows only need to show where the penumbrae are
DEMO_YARDSTICK_SPP = 64  # the demo's own finest render: its error at fewer spp (convergence.py)
DEMO_SPPS = (1, 4, 16, DEMO_YARDSTICK_SPP)  # the demo's physical mode, for its convergence
QUIRK_NAMES = [f"Q{n}" for n in sorted(QUIRK_TEXT)]  # every quirk of the paper's program
SAMPLING_QUIRK = "Q10"  # the ladder fixes it last, with LADDER_SPP: its end is physical mode
LADDER_SPP = 16
# The order in which the ladder fixes the quirks: by number, pixel-centre sampling last.
LADDER_ORDER = [q for q in QUIRK_NAMES if q != SAMPLING_QUIRK] + [SAMPLING_QUIRK]
DEMO_MODES_ABLATED = ("paper", "physical")  # the demo modes rendered with an effect off
AREA_KEY = "ref-area"
PAPER_KEY = "demo-paper-cpu"  # the demo's paper mode: the ladder's first step
# Families the speed-accuracy and convergence charts leave out: not points on a time axis.
NOT_CHARTED = ("reference", "ablation", "ladder", "reference area")


@dataclass(frozen=True)
class LadderStep:
    name: str  # "paper", "+Q1", ..., "+Q10 = physical 16 spp"
    key: str  # the render of this step
    quirk: str | None  # the quirk this step fixes on top of the earlier ones (None: the start)


def ladder_steps() -> list[LadderStep]:
    """paper -> Q1 fixed -> Q1,Q2 fixed ... -> every quirk but Q10 fixed -> physical 16 spp."""
    steps = [LadderStep("paper", PAPER_KEY, None)]
    for i, q in enumerate(LADDER_ORDER[:-1], start=1):
        steps.append(LadderStep(f"+{q}", f"ladder-{i:02d}", q))
    end = _physical_key(LADDER_SPP)
    steps.append(LadderStep(f"+{SAMPLING_QUIRK} = physical {LADDER_SPP} spp", end, SAMPLING_QUIRK))
    return steps


def _physical_key(spp: int) -> str:
    return f"demo-physical-cpu-{spp}spp"


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


@dataclass(frozen=True)
class Featured:
    """A render the report compares in full (global and per effect), under this title."""

    job: RenderJob
    title: str


@dataclass(frozen=True)
class Ablation:
    """One effect switched off at pixel centres: Mitsuba's and each demo mode's render
    without it, beside their renders with it (`base`)."""

    effect: str
    reference: RenderJob  # Mitsuba whitted at pixel centres without the effect
    demo: dict[str, RenderJob]  # demo mode -> that mode without the effect
    base: dict[str, RenderJob]  # demo mode -> that mode with every effect, at pixel centres


@dataclass(frozen=True)
class PlannedStep:
    """A ladder step with its render."""

    step: LadderStep
    job: RenderJob

    @property
    def fixes_one_quirk(self) -> bool:
        """An intermediate step: a render of its own, not the paper or physical render."""
        return self.job.family == "ladder"


@dataclass(frozen=True)
class RenderPlan:
    """The report's renders by role; `jobs()` lists every one in order, once."""

    all_jobs: tuple[RenderJob, ...]
    reference: RenderJob  # the converged reference: everything is measured against it
    area: RenderJob | None  # soft shadows (None: the scene has no light)
    paper: RenderJob  # the demo's paper mode: the image under test unless one is given
    demo_convergence: dict[int, RenderJob]  # spp -> the demo's physical mode (DEMO_SPPS)
    penumbra_demo: RenderJob  # the demo render whose shadows are held against the area light
    featured: tuple[Featured, ...]
    mapped: tuple[RenderJob, ...]  # renders whose difference/FLIP/SSIM maps the page shows
    # Mitsuba renders that estimate the reference's very image (rtval_whitted, point lights,
    # box-filtered independent samples): only their sample count differs.
    same_estimator_as_reference: tuple[RenderJob, ...]
    ladder: tuple[PlannedStep, ...]
    centre_reference: RenderJob | None  # Mitsuba at pixel centres (None: no ablation)
    ablations: tuple[Ablation, ...]  # one per effect switch that can change the scene
    not_applicable: dict[str, str]  # what was left out, and why

    def jobs(self) -> list[RenderJob]:
        """Every render job, in the order they run and the page lists them."""
        return list(self.all_jobs)

    def shown(self) -> list[RenderJob]:
        """The renders the page shows as PNGs (ablation renders are only measured)."""
        return [j for j in self.all_jobs if j.family != "ablation"]

    def charted(self) -> list[RenderJob]:
        """The renders on the speed-accuracy and convergence charts."""
        return [j for j in self.all_jobs if j.family not in NOT_CHARTED]

    def mitsuba(self) -> list[RenderJob]:
        """Every Mitsuba configuration, the reference included (time to converge)."""
        return [j for j in self.all_jobs if j.family.startswith("mitsuba") or j is self.reference]


class _Jobs:
    """The plan's one table of jobs, in order: each job is made and listed here once."""

    def __init__(self, scene: str, size: tuple[int, int] | None) -> None:
        self.scene = scene
        self.size_demo = ["--width", str(size[0]), "--height", str(size[1])] if size else []
        self.size_ref = ["--size", f"{size[0]}x{size[1]}"] if size else []
        self.table: list[RenderJob] = []

    def demo(self, key: str, label: str, family: str, *args: str, spp: int = 1) -> RenderJob:
        cmd = ["render", "{scene}", "-o", "{out}", "-q", *args, *self.size_demo]
        return self._add(RenderJob(key, label, "rtdemo", cmd, family, spp, self.scene))

    def ref(self, key: str, label: str, family: str, *args: str, spp: int = 1) -> RenderJob:
        cmd = ["reference", "{scene}", "-o", "{out}", *args, *self.size_ref]
        return self._add(RenderJob(key, label, "rtval", cmd, family, spp, self.scene))

    def whitted(self, key: str, label: str, family: str, *args: str, spp: int = 1) -> RenderJob:
        return self.ref(key, label, family, "--integrator", "whitted", *args, spp=spp)

    def _add(self, job: RenderJob) -> RenderJob:
        self.table.append(job)
        return job


def plan(scene: str, size: tuple[int, int] | None) -> RenderPlan:
    loaded = load_scene(scene)
    skipped = not_applicable(loaded)
    lights = "point lights" if loaded.lights else "no light"  # a label must not invent one
    t = _Jobs(scene, size)
    reference = t.whitted(
        REFERENCE_KEY,
        f"Mitsuba whitted, {lights}, {REFERENCE_SPP} spp (converged reference)",
        "reference",
        *("--light", "point", "--spp", str(REFERENCE_SPP)),
        spp=REFERENCE_SPP,
    )
    demo = _demo_jobs(t)
    mitsuba = _mitsuba_jobs(t)
    area = None
    if "area light" not in skipped:
        area = t.whitted(
            AREA_KEY,
            f"Mitsuba whitted, area lights, {AREA_SPP} spp (soft shadows)",
            "reference area",
            *("--light", "area", "--spp", str(AREA_SPP)),
            spp=AREA_SPP,
        )
    ladder = _ladder_jobs(t, {j.key: j for j in t.table})
    centre, ablations = _ablation_jobs(t, skipped, lights, demo)
    physical, path = demo["physical"], mitsuba["path"]
    return RenderPlan(
        all_jobs=tuple(t.table),
        reference=reference,
        area=area,
        paper=demo["paper"][1],
        demo_convergence=physical,
        penumbra_demo=physical[16],
        featured=(
            Featured(demo["paper"][1], "demo, paper mode"),
            Featured(demo["classic"][1], "demo, classic mode"),
            Featured(physical[1], "demo, physical mode (pixel centres)"),
            Featured(physical[16], "demo, physical mode, 16 spp"),
            Featured(demo["physical gl"][16], "demo, physical mode, GL, 16 spp"),
            Featured(path[64], "Mitsuba path tracer, 64 spp"),
        ),
        mapped=(demo["paper"][1], physical[16], path[64]),
        same_estimator_as_reference=(reference, *mitsuba["whitted"].values()),
        ladder=ladder,
        centre_reference=centre,
        ablations=ablations,
        not_applicable=skipped,
    )


def _demo_jobs(t: _Jobs) -> dict[str, dict[int, RenderJob]]:
    """The demo's modes and backends: name -> spp -> job."""
    paper = t.demo(PAPER_KEY, "demo paper mode, CPU", "demo paper cpu", "--mode", "paper")
    classic = t.demo(
        "demo-classic-cpu", "demo classic mode, CPU", "demo classic cpu", "--mode", "classic"
    )
    gl = ("--mode", "paper", "--backend", "gl")
    t.demo("demo-paper-gl", "demo paper mode, GL", "demo paper gl", *gl)
    physical, physical_gl = {}, {}
    for spp in DEMO_SPPS:
        physical[spp] = t.demo(
            _physical_key(spp),
            f"demo physical mode, CPU, {spp} spp",
            "demo physical cpu",
            *("--mode", "physical", "--spp", str(spp)),
            spp=spp,
        )
        if spp == DEMO_YARDSTICK_SPP:
            continue
        physical_gl[spp] = t.demo(
            f"demo-physical-gl-{spp}spp",
            f"demo physical mode, GL, {spp} spp",
            "demo physical gl",
            *("--mode", "physical", "--backend", "gl", "--spp", str(spp)),
            spp=spp,
        )
    for spp in (4, 16):
        t.demo(
            f"demo-paper-cpu-{spp}spp",
            f"demo paper mode + Q10 fixed, CPU, {spp} spp",
            "demo paper cpu",
            *("--mode", "paper", "--fix", "Q10", "--spp", str(spp)),
            spp=spp,
        )
    return {
        "paper": {1: paper},
        "classic": {1: classic},
        "physical": physical,
        "physical gl": physical_gl,
    }


def _mitsuba_jobs(t: _Jobs) -> dict[str, dict[int, RenderJob]]:
    """Mitsuba's integrators and variants beside the reference: name -> spp -> job."""
    whitted = {
        spp: t.whitted(
            f"mitsuba-whitted-llvm-{spp}spp",
            f"Mitsuba whitted llvm_ad_rgb, {spp} spp",
            "mitsuba whitted llvm",
            *("--light", "point", "--spp", str(spp)),
            spp=spp,
        )
        for spp in (1, 4)
    }
    # No Whitted scalar_rgb render: one ray at a time in Python, it took 22 s of a cold report's
    # 73 s of Mitsuba for the 1 spp llvm render's very image (float64 intersections aside);
    # the path tracer's scalar render below stands for the scalar variant on the chart.
    path = {
        spp: t.ref(
            f"mitsuba-path-llvm-{spp}spp",
            f"Mitsuba path llvm_ad_rgb, {spp} spp",
            "mitsuba path llvm",
            *("--integrator", "path", "--light", "point", "--spp", str(spp)),
            spp=spp,
        )
        for spp in (1, 4, 16, 64)
    }
    t.ref(
        "mitsuba-path-scalar-1spp",
        "Mitsuba path scalar_rgb, 1 spp",
        "mitsuba path scalar",
        # Charted for its image and time alone: no AOVs (a Python loop per pixel in scalar).
        *("--integrator", "path", "--light", "point", "--variant", "scalar_rgb", "--no-aovs"),
    )
    return {"whitted": whitted, "path": path}


def _ladder_jobs(t: _Jobs, made: dict[str, RenderJob]) -> tuple[PlannedStep, ...]:
    """The ablation ladder: the paper's program with quirks fixed one after another
    (cumulative); its first and last steps are the paper-mode and physical-mode renders."""
    steps = ladder_steps()
    for i, step in enumerate(steps[1:-1], start=1):
        fixed = ",".join(LADDER_ORDER[:i])
        made[step.key] = t.demo(
            step.key, f"paper + {fixed} fixed", "ladder", "--mode", "paper", "--fix", fixed
        )
    return tuple(PlannedStep(step, made[step.key]) for step in steps)


def _ablation_jobs(
    t: _Jobs, skipped: dict[str, str], lights: str, demo: dict[str, dict[int, RenderJob]]
) -> tuple[RenderJob | None, tuple[Ablation, ...]]:
    """Effect ablation at pixel centres: each side with one effect switched off, for the
    switches that can change this scene (the others would give three copies of their base)."""
    switches = [e for e in SWITCHABLE_EFFECTS if e not in skipped]
    if not switches:
        return None, ()
    point = ("--light", "point", "--centre-rays")
    centre = t.whitted(
        "ref-centre", f"Mitsuba whitted, {lights}, pixel centres", "ablation", *point
    )
    base = {"paper": demo["paper"][1], "physical": demo["physical"][1]}
    ablations = []
    for effect in switches:
        reference = t.whitted(
            f"ref-centre-no-{effect}",
            f"Mitsuba whitted, pixel centres, no {effect}",
            "ablation",
            *point,
            f"--no-{effect}",
        )
        without = {
            mode: t.demo(
                f"demo-{mode}-cpu-no-{effect}",
                f"demo {mode} mode, no {effect}",
                "ablation",
                *("--mode", mode, f"--no-{effect}"),
            )
            for mode in DEMO_MODES_ABLATED
        }
        ablations.append(Ablation(effect, reference, without, base))
    return centre, tuple(ablations)
