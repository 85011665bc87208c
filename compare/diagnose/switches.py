"""What the diagnosis (diagnose.py) may change in a candidate, one switch at a time: a quirk
toggled, an effect off, another recursion depth, a hard-coded background or glass ior, a named
mistake added or removed; how each is written (`cause`: "+Q2", `change`: "+Q2 (eta = 1/ior
also when leaving glass)"), and how one candidate turns into another.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

from compare.diagnose.candidate import (
    FRESNEL_QUIRK,
    PAPERS_FRESNEL,
    RGB,
    Candidate,
    camera_words,
    rgb_text,
)
from compare.diagnose.mistakes import catalogue
from compare.judge.quirks import QUIRKS
from compare.judge.target_model import MODE_QUIRKS, SWITCHABLE_EFFECTS
from scene_model.scene import Scene

MAX_SEARCH_DEPTH = 32
# Seeds of the ior fit (constant_fit.fitted_ior refines the one that helps): common indices,
# and the scene's own each step of IOR_NEAR either side (a student's 1.45 for the scene's 1.5,
# 1.12 for 1.1: an ior that near changes too few refraction pixels to tell it from a seed
# farther off, so no farther seed helps).
# The background is not a seed: search.py reads it off the image (constant_fit.py).
IORS = (1.1, 1.2, 1.33, 1.5)
IOR_NEAR = (0.02, 0.05, 0.1)
# The kinds whose switch sets a value (any value of one kind sets the same thing).
VALUED = ("depth", "background", "ior", "bias", "fresnel", "camera", "light", "colour")
# Where the paper's Fresnel curve (Q8) is on, the sweep tries these constants (mix, power) of
# it: a mirror at every angle (the facing ratio's sign lost), half and half, and Schlick's
# curve for glass of ior 1.5; one that helps is then fitted as a value (fresnel_fit.py).
FRESNEL_SEEDS = ((1.0, 3), (0.5, 3), (0.04, 5))
# Seeds of the bias fit (constant_fit.fitted_bias refines the one that helps on a log scale):
# offsets programs hard-code (the scenes ask 1e-4), CAPBenchmarks' 1e-3 among them.
BIASES = (1e-5, 1e-3, 1e-2)
# The step of the algorithm each quirk, mistake and effect lives in (what a student reads).
QUIRK_STEPS = {
    1: "intersection (the tca < 0 test and the offset of secondary rays)",
    2: "refraction leaving glass (the index ratio)",
    3: "refraction (total internal reflection)",
    4: "shadow rays (one factor for all lights)",
    5: "shadow rays (where they stop)",
    6: "recursion at the depth limit",
    7: "direct light (the 1/pi and distance falloff)",
    8: "Fresnel (its curve)",
    9: "shadow rays through glass",
    10: "the camera (rays per pixel)",
    11: "direct light (where the sum starts)",
    12: "direct light (the Lambert cosine)",
    13: "emission of a light sphere",
}
MISTAKE_STEPS = {
    "no_offset": "secondary and shadow rays (their offset from the surface)",
    "no_inside_flip": "refraction leaving glass (the normal inside)",
    "eta_inverted": "refraction (the index ratio)",
    "shadow_past_light": "shadow rays (where they stop)",
    "fresnel_missing": "Fresnel (no weight)",
    "fresnel_constant": "Fresnel (a constant weight)",
    "fresnel_exponent": "Fresnel (its exponent)",
    "black_background": "rays that miss (the background colour)",
    "flipped_normal": "the normal (its sign)",
    "half_pixel_offset": "the camera (pixel centres)",
    "double_gamma": "image writing (the encoding)",
    "depth_cut": "recursion (the depth test)",
    "no_shadows": "shadow rays",
}
EFFECT_STEPS = {"shadows": "shadow rays", "reflection": "reflection", "refraction": "refraction"}


def glass_iors(scene: Scene) -> set[float]:
    return {s.ior for s in scene.spheres if s.transparency > 0}


@dataclass(frozen=True)
class Switch:
    """One switch tried on top of a candidate."""

    # "quirk" | "effect" | "depth" | "mistake" | "background" | "ior" | "bias" | "fresnel"
    kind: str
    # "2" | "shadows" | "10" (the new depth) | "no_offset" | "1,1,1" | "1.5" | "0.9,3" (mix, power)
    key: str
    present: bool  # quirk/mistake added, effect off, depth raised, constant not the scene's

    def apply(self, c: Candidate, scene: Scene) -> Candidate:
        if self.kind == "quirk":
            return c.with_quirk(int(self.key), self.present)
        if self.kind == "effect":
            return c.with_effect(self.key, not self.present)
        if self.kind == "mistake":
            return c.with_mistake(self.key, self.present)
        if self.kind == "background":
            return c.with_background(self._rgb() if self.present else None)
        if self.kind == "light":
            return c.with_light(self._rgb() if self.present else None)
        if self.kind == "colour":
            return c.with_colour(self.colour_of() if self.present else None)
        if self.kind == "ior":
            return c.with_ior(*self.ior_of()) if self.present else c.with_ior(None)
        if self.kind == "bias":
            return c.with_bias(float(self.key) if self.present else None)
        if self.kind == "fresnel":
            return c.with_fresnel(self.curve() if self.present else None)
        if self.kind == "camera":
            return c.with_camera(self.key if self.present else None)
        return c.at_depth(int(self.key), scene)

    def ior_of(self) -> tuple[float, str | None]:
        """An ior switch's value and the glass sphere it is for ("1.45@glass"; None: every
        glass sphere)."""
        value, _, sphere = self.key.partition("@")
        return float(value), sphere or None

    def curve(self) -> tuple[float, int]:
        """A fresnel switch's (mix, power)."""
        mix, power = self.key.split(",")
        return float(mix), int(power)

    def colour_of(self) -> tuple[str, RGB]:
        """A colour switch's sphere and colour ("glass=1,0.32,0.26")."""
        name, _, rgb = self.key.rpartition("=")
        r, g, b = (float(v) for v in rgb.split(","))
        return name, (r, g, b)

    def _rgb(self) -> RGB:
        r, g, b = (float(v) for v in self.key.split(","))
        return (r, g, b)

    @property
    def cause_kind(self) -> str:
        """What kind of cause it is: quirk, mistake, camera, image, step or constant."""
        if self.kind == "mistake":
            if catalogue()[self.key].symptom:
                return "step"  # a symptom several mistakes share: the step, not one of them
            step = catalogue()[self.key].step
            return {"camera": "camera", "image writing": "image"}.get(step, "mistake")
        return {"quirk": "quirk", "effect": "step", "camera": "camera"}.get(self.kind, "constant")

    @property
    def step(self) -> str:
        """The step of the algorithm it changes, in words."""
        if self.kind == "quirk":
            return QUIRK_STEPS.get(int(self.key), "")
        if self.kind == "mistake":
            m = catalogue()[self.key]
            return MISTAKE_STEPS.get(self.key) or f"{m.step} ({m.explanation})"
        if self.kind == "effect":
            return EFFECT_STEPS[self.key]
        return {"depth": "recursion (the depth limit)", "background": "the background colour",
                "ior": "refraction (the glass index)",
                "bias": "secondary and shadow rays (their offset)",
                "fresnel": "Fresnel (its curve's constants)",
                "light": "direct light (where the light is)",
                "colour": "shading (a sphere's surface colour)",
                "camera": "the camera (the ray through each pixel)"}[self.kind]  # fmt: skip

    def sets_same(self, other: Switch) -> bool:
        """Whether both set the same thing (a depth, a background, an ior, or one quirk,
        effect or mistake), whatever value each sets it to."""
        return self.kind == other.kind and (self.key == other.key or self.kind in VALUED)

    def cause(self, *, or_more: bool = False) -> str:
        """The switch in a word or two, for a gradebook column ("looks like +Q2"); or_more: a
        depth that every deeper limit reproduces as well."""
        if self.kind == "quirk":
            return f"{'+' if self.present else '-'}Q{self.key}"
        if self.kind == "effect":
            return f"--no-{self.key}" if self.present else f"+{self.key}"
        if self.kind == "depth":
            return f"max depth {self.key}" + (" or more" if or_more else "")
        if self.kind == "background":
            return f"background {rgb_text(self._rgb())}" if self.present else "scene background"
        if self.kind == "light":
            return f"light at {rgb_text(self._rgb())}" if self.present else "scene light"
        if self.kind == "colour":
            if not self.present:
                return "scene colours"
            name, rgb = self.colour_of()
            return f"colour of '{name}' {rgb_text(rgb)}"
        if self.kind == "ior":
            if not self.present:
                return "scene ior"
            value, sphere = self.ior_of()
            return f"ior {value:g}" + (f" for '{sphere}'" if sphere else "")
        if self.kind == "bias":
            return f"bias {float(self.key):g}" if self.present else "scene bias"
        if self.kind == "fresnel":
            return f"Fresnel {curve_text(self.curve())}" if self.present else "paper's Fresnel"
        if self.kind == "camera":
            return f"camera: {camera_words(self.key)}" if self.present else "scene camera"
        symptom = catalogue()[self.key].symptom if self.kind == "mistake" else ""
        if symptom and self.present:
            return symptom
        return f"{'' if self.present else '-'}{self.key}"

    def change(self, scene: Scene, *, or_more: bool = False) -> str:
        """What the switch does, in words, e.g. "+Q2 (eta = 1/ior also when leaving glass)"."""
        if self.kind == "quirk":
            q = int(self.key)
            return f"{'+' if self.present else '-'}Q{q} ({QUIRKS[q]}" + (
                ")" if self.present else " fixed)"
            )
        if self.kind == "effect":
            if self.present:
                return f"--no-{self.key} ({self.key} switched off)"
            return f"{self.key} switched back on"
        if self.kind == "depth":
            return self._depth_change(scene, or_more)
        if self.kind == "bias":
            if self.present:
                return f"bias {float(self.key):g} hard-coded (the scene's is {scene.bias:g})"
            return f"the scene's bias {scene.bias:g}"
        if self.kind in ("background", "ior", "light", "colour"):
            return self._constant_change(scene)
        if self.kind == "camera":
            return f"the camera: {camera_words(self.key)}" if self.present else "the scene's camera"
        if self.kind == "fresnel":
            papers = curve_text(PAPERS_FRESNEL)
            if self.present:
                return f"the Fresnel curve {curve_text(self.curve())} (the paper's: {papers})"
            return f"the paper's Fresnel curve {papers}"
        m = catalogue()[self.key]
        if self.present and m.symptom:
            alike = [o.name for o in catalogue().values() if o.symptom == m.symptom]
            return (
                f"{m.symptom}: the image shows what any of these mistakes gives and cannot tell "
                f"which: {', '.join(alike)}"
            )
        if self.present:
            return f"the mistake {m.name} ({m.explanation})"
        return f"without the mistake {m.name}"

    def _depth_change(self, scene: Scene, or_more: bool) -> str:
        d = int(self.key)
        cut = " (the mistake depth_cut)" if d == scene.max_depth - 1 else ""
        more = f" or more (every limit from {d} to {MAX_SEARCH_DEPTH} gives this image)"
        return f"max depth {d}{more if or_more else cut} (the scene asks {scene.max_depth})"

    def _constant_change(self, scene: Scene) -> str:
        if self.kind == "colour":
            if not self.present:
                return "the scene's sphere colours"
            name, rgb = self.colour_of()
            theirs = next((rgb_text(s.color) for s in scene.spheres if s.name == name), "?")
            return f"the colour of '{name}' {rgb_text(rgb)} hard-coded (the scene's is {theirs})"
        if self.kind == "light":
            theirs = ", ".join(rgb_text(s.center) for s in scene.spheres if s.kind == "light")
            if self.present:
                return (
                    f"the light at {rgb_text(self._rgb())} hard-coded (the scene's is at {theirs})"
                )
            return f"the scene's light at {theirs}"
        if self.kind == "background":
            theirs = rgb_text(scene.background)
            if not self.present:
                return f"the scene's background {theirs}"
            said = f"background {rgb_text(self._rgb())} hard-coded (the scene's is {theirs})"
            if all(v == 1.0 for v in self._rgb()) and max(scene.background) > 1.0:
                # A program that caps what each ray returns at 1 mixes the sky in as 1 too.
                said += (
                    ", or every colour a ray returns capped at 1 (the same image wherever "
                    "the light is not seen)"
                )
            return said
        theirs = ", ".join(f"{v:g}" for v in sorted(glass_iors(scene)))
        value, sphere = self.ior_of() if self.present else (0.0, None)
        if sphere is not None:
            own = next((s.ior for s in scene.spheres if s.name == sphere), 0.0)
            return (
                f"ior {value:g} hard-coded for the glass sphere '{sphere}' (the scene's is {own:g})"
            )
        if self.present:
            return (
                f"ior {float(self.key):g} hard-coded for every glass sphere (the scene's: {theirs})"
            )
        return f"the scene's ior {theirs}"


def curve_text(curve: tuple[float, int]) -> str:
    """(0.9, 3) -> "0.9 + 0.1 (1 - cos)^3": the Fresnel weight of the reflection; (1, 3) ->
    "1 at every angle"."""
    mix, power = curve
    if mix == 1 or power == 0:
        return f"{1 if power == 0 else mix:g} at every angle"
    return f"{mix:g} + {1 - mix:.4g} (1 - cos)^{power}"


def switches(c: Candidate, scene: Scene, quirks: Sequence[int], *, full: bool) -> list[Switch]:
    """Every switch of `c` to try; `full` adds the jumps in depth."""
    depth = c.depth(scene)
    out = [Switch("quirk", str(q), q not in c.quirks) for q in quirks]
    out += [Switch("effect", e, e not in c.effects_off) for e in SWITCHABLE_EFFECTS]
    out += [Switch("depth", str(d), d > depth) for d in _depths(depth, full)]
    # Mistakes that another switch already renders (same_as) are found through that switch.
    out += [
        Switch("mistake", m.name, m.name not in c.mistakes)
        for m in catalogue().values()
        if m.same_as is None
    ]
    return out + _constant_switches(c, scene)


def _depths(d: int, full: bool) -> list[int]:
    """One level up and down from d; in a full sweep also jumps of 2, 4, 8, ... each way and
    the deepest searched, so that `MAX_RAY_DEPTH 10` in a depth-5 scene is one step."""
    steps = [1, 2, 4, 8] if full else [1]
    out = {d + s for s in steps} | {d - s for s in steps}
    if full:
        out.add(MAX_SEARCH_DEPTH)
    return sorted(x for x in out if 0 <= x <= MAX_SEARCH_DEPTH and x != d)


def _constant_switches(c: Candidate, scene: Scene) -> list[Switch]:
    out = [Switch("bias", f"{v:g}", True) for v in BIASES if v not in (scene.bias, c.bias)]
    if c.bias is not None:
        out.append(Switch("bias", "scene", False))
    if FRESNEL_QUIRK in c.quirks:
        out += [
            Switch("fresnel", f"{m:g},{p}", True) for m, p in FRESNEL_SEEDS if (m, p) != c.fresnel
        ]
        if c.fresnel is not None:
            out.append(Switch("fresnel", "paper", False))
    theirs = glass_iors(scene)
    if theirs:
        near = {round(v + s * d, 2) for v in theirs for d in IOR_NEAR for s in (-1, 1)}
        near = {v for v in near if v > 1}
        seeds = sorted(set(IORS) | near)
        out += [Switch("ior", f"{v:g}", True) for v in seeds if {v} != theirs and v != c.ior]
        out += _sphere_ior_seeds(c, scene)
        if c.ior is not None:
            out.append(Switch("ior", "scene", False))
    return out


def _sphere_ior_seeds(c: Candidate, scene: Scene) -> list[Switch]:
    """Where the scene's glass spheres differ in ior, each one's own ior each step of IOR_NEAR
    either side, for that sphere alone (a program with one sphere's index mistyped)."""
    if len(glass_iors(scene)) < 2 or c.ior is not None:
        return []
    return [
        Switch("ior", f"{round(s.ior + d, 2):g}@{s.name}", True)
        for s in scene.spheres
        if s.transparency > 0
        for d in (sign * step for step in IOR_NEAR for sign in (-1, 1))
        if s.ior + d > 1
    ]


def differences(a: Candidate, b: Candidate, scene: Scene) -> list[Switch]:
    """The one-at-a-time switches that turn candidate a into b."""
    out = [Switch("quirk", str(q), q in b.quirks) for q in sorted(a.quirks ^ b.quirks)]
    out += [
        Switch("effect", e, e in b.effects_off)
        for e in SWITCHABLE_EFFECTS
        if (e in a.effects_off) != (e in b.effects_off)
    ]
    da, db = a.depth(scene), b.depth(scene)
    if da != db:
        out.append(Switch("depth", str(db), db > da))
    out += [Switch("mistake", m, m in b.mistakes) for m in sorted(a.mistakes ^ b.mistakes)]
    if a.background != b.background:
        rgb = b.background or a.background
        assert rgb is not None
        out.append(Switch("background", ",".join(f"{v:g}" for v in rgb), b.background is not None))
    if (a.ior, a.ior_sphere) != (b.ior, b.ior_sphere):
        hard = b if b.ior is not None else a
        where = f"@{hard.ior_sphere}" if hard.ior_sphere else ""
        out.append(Switch("ior", f"{hard.ior or 0.0:g}{where}", b.ior is not None))
    if a.colour != b.colour:
        name, rgb = b.colour or a.colour or ("", (0.0, 0.0, 0.0))
        coloured = f"{name}=" + ",".join(f"{v:g}" for v in rgb)
        out.append(Switch("colour", coloured, b.colour is not None))
    if a.light != b.light:
        centre = b.light or a.light
        assert centre is not None
        out.append(Switch("light", ",".join(f"{v:g}" for v in centre), b.light is not None))
    if a.bias != b.bias:
        out.append(Switch("bias", f"{b.bias or a.bias:g}", b.bias is not None))
    if a.camera != b.camera:
        key = b.camera or a.camera
        assert key is not None
        out.append(Switch("camera", key, b.camera is not None))
    if a.fresnel != b.fresnel:
        mix, power = b.fresnel or a.fresnel or PAPERS_FRESNEL
        out.append(Switch("fresnel", f"{mix:g},{power}", b.fresnel is not None))
    return out


def undone(final: Candidate, begin: Candidate, drop: list[Switch], scene: Scene) -> Candidate:
    """final with the dropped switches undone (each set back to begin's value)."""
    out = final
    for u in differences(final, begin, scene):
        if any(u.sets_same(d) for d in drop):
            out = u.apply(out, scene)
    return out


def simplest(c: Candidate, invisible: set[int]) -> Candidate:
    """The same candidate written from the mode it differs least from, counting only quirks
    that change pixels (paper-Q2 --no-shadows is classic --no-shadows when Q4 and Q9 are
    invisible)."""
    best, best_count = c, len(c.quirks ^ MODE_QUIRKS[c.mode])
    for mode in ("classic", "paper", "physical"):
        quirks = (c.quirks - invisible) | (MODE_QUIRKS[mode] & invisible)
        count = len(quirks ^ MODE_QUIRKS[mode])
        if count < best_count:
            best = dataclasses.replace(c, mode=mode, quirks=frozenset(quirks))
            best_count = count
    return best


def aliases(c: Candidate, scene: Scene) -> list[str]:
    """Named mistakes that the candidate's switches amount to (catalogue `same_as`)."""
    out = []
    depth = c.depth(scene)
    for m in catalogue().values():
        if (
            (m.same_as == "+Q5" and 5 in c.quirks and 5 not in MODE_QUIRKS[c.mode])
            or (m.same_as == "--no-shadows" and "shadows" in c.effects_off)
            or (m.same_as == "--max-depth N-1" and depth == scene.max_depth - 1)
        ):
            out.append(m.name)
    return out
