"""A candidate explanation of an image: a demo model (mode and the quirks present), with
effects switched off, a recursion depth and named mistakes (mistakes.py) on top, and scene
constants a program may hard-code instead of reading them from the scene (the background, the
glass spheres' ior). It is what `rtval diagnose` renders and compares; `rtdemo_args()` is the
rtdemo command line for it, `scene_changes()` what a copy of the scene must change first.

`turn` is not an explanation but a way to judge one: the candidate rendered with the camera
turned by a fraction of a pixel, as exact matching renders a model (compare/render/models.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from compare.diagnose.mistakes import catalogue
from compare.judge.target_model import MODE_QUIRKS, SWITCHABLE_EFFECTS, TargetModel

if TYPE_CHECKING:
    from scene_model.scene import Scene

RGB = tuple[float, float, float]
Vec3 = tuple[float, float, float]
VIEW_PREFIX = "view:"
FRESNEL_QUIRK = 8  # the paper's Fresnel curve, whose constants --fresnel-mix/-power change
PAPERS_FRESNEL = (0.1, 3)


def camera_numbers(camera: str) -> str:
    """rtdemo --camera-map's value of a camera key ("su,ou,sv,ov|words")."""
    return camera.split("|", 1)[0]


def is_view(camera: str) -> bool:
    """Whether a camera key is a view ("view:x,y,z;x,y,z|words": camera_view.py, where the
    camera stands and looks, a scene copy), not a camera map (rtdemo --camera-map)."""
    return camera.startswith(VIEW_PREFIX)


def view_of(camera: str) -> tuple[Vec3, Vec3]:
    """(position, look_at) of a view key."""
    numbers = camera[len(VIEW_PREFIX) :].split("|", 1)[0]
    pos, at = ([float(v) for v in part.split(",")] for part in numbers.split(";"))
    return (pos[0], pos[1], pos[2]), (at[0], at[1], at[2])


def view_key(position: Vec3, look_at: Vec3, words: str) -> str:
    """The camera key of a view."""
    numbers = ";".join(",".join(f"{v:.9g}" for v in p) for p in (position, look_at))
    return f"{VIEW_PREFIX}{numbers}|{words}"


def camera_words(camera: str) -> str:
    """What a camera key's camera is, in words."""
    return camera.split("|", 1)[1] if "|" in camera else camera


def rgb_text(rgb: RGB) -> str:
    """(1, 1, 1) -> "(1, 1, 1)": the way the names and sentences write a colour."""
    return "(" + ", ".join(f"{v:g}" for v in rgb) + ")"


@dataclass(frozen=True)
class Candidate:
    """A candidate explanation of an image: a demo model with switches, mistakes and constants.

    Attributes
    ----------
    mode : str
        The rtdemo mode: "paper", "classic" or "physical".
    quirks : frozenset[int]
        The quirks present (Q1 to Q13, docs/paper-model.md).
    effects_off : frozenset[str]
        Effects switched off, a subset of SWITCHABLE_EFFECTS (rtdemo's ``--no-<effect>``);
        default empty.
    max_depth : int or None
        The recursion limit; default None: the scene's.
    mistakes : frozenset[str]
        Named mistakes switched on (names of `catalogue`); default empty.
    background : tuple[float, float, float] or None
        The background colour a program hard-codes; default None: the scene's.
    ior : float or None
        Every glass sphere's index of refraction (or `ior_sphere`'s alone); default None: the
        scene's.
    ior_sphere : str or None
        The one glass sphere (its name) that `ior` is hard-coded for, in a scene whose glass
        spheres differ in ior; default None: every glass sphere.
    bias : float or None
        The offset of secondary rays a program hard-codes; default None: the scene's.
    light : tuple[float, float, float] or None
        Where a program puts the scene's one light (its centre); default None: the scene's.
    colour : tuple[str, tuple[float, float, float]] or None
        One sphere's surface colour as a program types it: (the sphere's name, the colour);
        default None: the scene's.
    camera : str or None
        Another camera, as camera_fit.Fitted.key writes it: "su,ou,sv,ov|what it is", the
        numbers rtdemo's ``--camera-map`` (camera_fit.py); or a view, "view:x,y,z;x,y,z|what
        it is", the position and look_at of a scene copy (camera_view.py); default None: the
        scene's.
    fresnel : tuple[float, int] or None
        The paper's Fresnel curve (Q8) with other constants (mix, power): mix + (1 - mix)
        (1 - cos)^power, rtdemo's ``--fresnel-mix`` and ``--fresnel-power``; default None:
        the paper's (0.1, 3). Set only while Q8 is present.
    turn : tuple[float, float] or None
        The camera turned by (dx, dy) pixels: not an explanation but a way to judge one;
        default None.
    grow : int or None
        Every sphere grown by this many float32 ulps (shrunk when negative;
        models.grown_scene); default None.
    model : TargetModel
        The demo model of `mode` and `quirks` (read-only).
    name : str
        Its name, e.g. "classic+Q2 --no-shadows --mistake no_offset [ior 1.5]" (read-only).
    """

    mode: str
    quirks: frozenset[int]
    effects_off: frozenset[str] = frozenset()
    max_depth: int | None = None
    mistakes: frozenset[str] = field(default_factory=frozenset)
    background: RGB | None = None
    ior: float | None = None
    bias: float | None = None
    fresnel: tuple[float, int] | None = None
    camera: str | None = None
    turn: tuple[float, float] | None = None
    grow: int | None = None
    ior_sphere: str | None = None
    light: Vec3 | None = None
    colour: tuple[str, RGB] | None = None

    @staticmethod
    def of_mode(mode: str) -> Candidate:
        return Candidate(mode, MODE_QUIRKS[mode])

    @staticmethod
    def from_model(model: TargetModel) -> Candidate:
        if not model.is_demo or model.mode is None:
            raise ValueError(f"{model.name} is not a demo model")
        return Candidate(model.mode, model.quirks)

    @property
    def model(self) -> TargetModel:
        return TargetModel("demo", self.mode, self.quirks)

    @property
    def name(self) -> str:
        parts = [self.model.name]
        parts += [f"--no-{e}" for e in SWITCHABLE_EFFECTS if e in self.effects_off]
        if self.max_depth is not None:
            parts.append(f"--max-depth {self.max_depth}")
        if self.mistakes:
            parts.append("--mistake " + ",".join(self.ordered_mistakes()))
        if self.fresnel is not None:
            parts.append(f"--fresnel-mix {self.fresnel[0]:g} --fresnel-power {self.fresnel[1]}")
        if self.camera is not None and not is_view(self.camera):
            parts.append(f"--camera-map {camera_numbers(self.camera)}")
        # Scene constants in brackets: they are a scene copy, not rtdemo options.
        if self.camera is not None and is_view(self.camera):
            pos, at = view_of(self.camera)
            parts.append(f"[camera at {rgb_text(pos)} looking at {rgb_text(at)}]")
        if self.background is not None:
            parts.append(f"[background {rgb_text(self.background)}]")
        if self.ior is not None:
            where = f" for '{self.ior_sphere}'" if self.ior_sphere is not None else ""
            parts.append(f"[ior {self.ior:g}{where}]")
        if self.bias is not None:
            parts.append(f"[bias {self.bias:g}]")
        if self.light is not None:
            parts.append(f"[light at {rgb_text(self.light)}]")
        if self.colour is not None:
            parts.append(f"[colour of '{self.colour[0]}' {rgb_text(self.colour[1])}]")
        if self.turn is not None:
            parts.append(f"[camera turned {self.turn[0]:+g}, {self.turn[1]:+g} px]")
        if self.grow is not None:
            parts.append(f"[spheres {self.grow:+d} ulps]")
        return " ".join(parts)

    def ordered_mistakes(self) -> list[str]:
        return [m for m in catalogue() if m in self.mistakes]

    def rtdemo_args(self) -> list[str]:
        """rtdemo render options for this candidate (of the scene copy, with scene_changes)."""
        args = self.model.rtdemo_args()
        args += [f"--no-{e}" for e in SWITCHABLE_EFFECTS if e in self.effects_off]
        if self.max_depth is not None:
            args += ["--max-depth", str(self.max_depth)]
        if self.mistakes:
            args += ["--mistake", ",".join(self.ordered_mistakes())]
        if self.camera is not None and not is_view(self.camera):
            args += ["--camera-map", camera_numbers(self.camera)]
        if self.fresnel is not None:
            args += [
                "--fresnel-mix",
                f"{self.fresnel[0]:g}",
                "--fresnel-power",
                str(self.fresnel[1]),
            ]
        return args

    def scene_changes(self) -> dict[str, Any]:
        """What the scene copy it is rendered from changes: {"background": [1, 1, 1],
        "ior": 1.5, "light": [0, 30, -30], "camera": {"position": ..., "look_at": ...}} (the camera turn is not listed: it is how a candidate is judged)."""
        out: dict[str, Any] = {}
        if self.background is not None:
            out["background"] = list(self.background)
        if self.ior is not None:
            out["ior"] = self.ior
            if self.ior_sphere is not None:
                out["ior_sphere"] = self.ior_sphere
        if self.bias is not None:
            out["bias"] = self.bias
        if self.light is not None:
            out["light"] = list(self.light)
        if self.colour is not None:
            out["colour"] = {"sphere": self.colour[0], "rgb": list(self.colour[1])}
        if self.camera is not None and is_view(self.camera):
            pos, at = view_of(self.camera)
            out["camera"] = {"position": list(pos), "look_at": list(at)}
        return out

    def with_quirk(self, quirk: int, present: bool) -> Candidate:
        q = self.quirks | {quirk} if present else self.quirks - {quirk}
        # The curve's constants belong to Q8's curve: without it there is none to change.
        fresnel = self.fresnel if FRESNEL_QUIRK in q else None
        return dataclasses.replace(self, quirks=frozenset(q), fresnel=fresnel)

    def with_effect(self, effect: str, on: bool) -> Candidate:
        off = self.effects_off - {effect} if on else self.effects_off | {effect}
        return dataclasses.replace(self, effects_off=frozenset(off))

    def with_depth(self, depth: int | None) -> Candidate:
        return dataclasses.replace(self, max_depth=depth)

    def depth(self, scene: Scene) -> int:
        """The recursion limit it renders `scene` with: its own, else the scene's."""
        return scene.max_depth if self.max_depth is None else self.max_depth

    def at_depth(self, depth: int, scene: Scene) -> Candidate:
        """With this recursion limit; the scene's own is left unset, so that one image has
        one name."""
        return self.with_depth(None if depth == scene.max_depth else depth)

    def with_mistake(self, name: str, present: bool) -> Candidate:
        m = self.mistakes | {name} if present else self.mistakes - {name}
        return dataclasses.replace(self, mistakes=frozenset(m))

    def with_background(self, rgb: RGB | None) -> Candidate:
        return dataclasses.replace(self, background=rgb)

    def with_ior(self, ior: float | None, sphere: str | None = None) -> Candidate:
        """With `ior` hard-coded for the glass sphere named `sphere`, or for every glass
        sphere (sphere None); ior None: the scene's."""
        return dataclasses.replace(self, ior=ior, ior_sphere=sphere if ior is not None else None)

    def ior_refit(self, ior: float) -> Candidate:
        """Another ior for the same sphere or spheres."""
        return self.with_ior(ior, self.ior_sphere)

    def with_bias(self, bias: float | None) -> Candidate:
        return dataclasses.replace(self, bias=bias)

    def with_light(self, centre: Vec3 | None) -> Candidate:
        return dataclasses.replace(self, light=centre)

    def with_colour(self, colour: tuple[str, RGB] | None) -> Candidate:
        return dataclasses.replace(self, colour=colour)

    def with_fresnel(self, curve: tuple[float, int] | None) -> Candidate:
        return dataclasses.replace(self, fresnel=curve)

    def with_camera(self, camera: str | None) -> Candidate:
        return dataclasses.replace(self, camera=camera)

    def turned(self, turn: tuple[float, float] | None) -> Candidate:
        return dataclasses.replace(self, turn=turn)

    def grown(self, ulps: int | None) -> Candidate:
        return dataclasses.replace(self, grow=ulps)
