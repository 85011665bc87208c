"""Student-style variants of the classic program, for `rtval diagnose`'s tests: the
independent numpy tracer of tests/numpy_reference.py (classic mode) with one mistake each,
written as the classic program writes its output (a binary PPM, each channel
`(unsigned char)(min(1, x) * 255)`: clamped and truncated, NaN as 0).

Each variant names the cause `diagnose` should find, in the words of its Diagnosis:
a quirk present ("+Q2"), an effect off ("shadows") or a named mistake (mistakes.json).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from numpy_reference import ReferenceTracer

from scene_model.scene import Scene

F64 = NDArray[np.float64]


class StudentTracer(ReferenceTracer):
    """The classic program without a mistake ("exact"); each variant overrides one hook."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene, "classic")


class WrongEtaLeaving(StudentTracer):
    def eta(self, ior: F64, inside: NDArray[np.bool_]) -> F64:
        return 1 / ior  # the ratio entering, also used when leaving the glass


class NoOffset(StudentTracer):
    def offset(self) -> float:
        return 0.0  # every secondary and shadow ray starts on the surface


class NoShadows(StudentTracer):
    def occluded(self, j: int, origin: F64, l_dir: F64) -> NDArray[np.bool_]:
        return np.zeros(len(origin), dtype=bool)  # no shadow rays: every light is seen


class NoInsideFlip(StudentTracer):
    def face_forward(self, n: F64, inside: NDArray[np.bool_]) -> F64:
        return n  # inside is known, but the normal stays outward


class ConstantFresnel(StudentTracer):
    def fresnel(self, facing: F64) -> F64:
        return np.full(len(facing), 0.5)


class BlackBackground(StudentTracer):
    def background(self) -> F64:
        return np.zeros(3)  # a miss returns black, not the scene's colour


class WhiteBackground(StudentTracer):
    def background(self) -> F64:
        return np.ones(3)  # a hard-coded white sky (1, 1, 1), as the paper's program returns


class DeepRecursion(StudentTracer):
    """`#define MAX_RAY_DEPTH 10`, whatever the scene asks."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(dataclasses.replace(scene, max_depth=10))


class HardCodedIor(StudentTracer):
    """Every glass sphere refracts with ior 1.5 (a constant in the program)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        self.ior = np.where(self.transparency > 0, 1.5, self.ior)


class GlassColourMissing(StudentTracer):
    """Glass mixes reflection and refraction but never multiplies by its colour: (R F +
    T (1 - F) transparency) instead of that times the colour. Mirrors keep their colour."""

    def _specular(
        self, d: F64, p: F64, n: F64, inside: NDArray[np.bool_], idx: NDArray[np.int_], depth: int
    ) -> F64:
        out = super()._specular(d, p, n, inside, idx, depth)
        glass = self.transparency[idx] > 0
        out[glass] /= self.colors[idx][glass]  # the scenes' glass colours have no zero channel
        return out


class RefractionMisses(StudentTracer):
    """The refracted direction is never computed (a zero-length vector, here NaN): the ray hits
    nothing, so glass shows the background through its (1 - F) transparency share."""

    def eta(self, ior: F64, inside: NDArray[np.bool_]) -> F64:
        return np.full(len(ior), np.nan)  # a NaN direction misses every sphere, as in C++


# variant -> (what diagnose should name, the tracer with that mistake)
_TRACERS: dict[str, tuple[str, type[StudentTracer]]] = {
    "wrong_eta_leaving": ("+Q2", WrongEtaLeaving),
    "no_offset": ("no_offset", NoOffset),
    "no_shadows": ("shadows", NoShadows),
    "no_inside_flip": ("no_inside_flip", NoInsideFlip),
    "constant_fresnel": ("fresnel_constant", ConstantFresnel),
    "black_background": ("black_background", BlackBackground),
}
# Programs the diagnosis must explain with a scene constant or a depth, or must call not
# explained (no candidate reproduces their pixels): variant -> the words it should find.
MORE: dict[str, tuple[str, type[StudentTracer]]] = {
    "white_background": ("background (1, 1, 1)", WhiteBackground),
    "depth_10": ("max depth 10", DeepRecursion),
    "ior_1_5": ("ior 1.5", HardCodedIor),
    "glass_colour_missing": ("not explained: refraction", GlassColourMissing),
    "refraction_misses": ("not explained: refraction", RefractionMisses),
}
VARIANTS: dict[str, str] = {name: cause for name, (cause, _) in _TRACERS.items()}


def student_tracer(scene: Scene, variant: str = "exact") -> StudentTracer:
    """The classic program with one of VARIANTS (or none: "exact")."""
    if variant == "exact":
        return StudentTracer(scene)
    tracers = _TRACERS | MORE
    if variant not in tracers:
        raise ValueError(variant)
    return tracers[variant][1](scene)


def write_truncating_ppm(path: Path, rgb: F64) -> None:
    """P6 as the classic program writes it: (unsigned char)(min(1, x) * 255), NaN -> 0."""
    c = np.minimum(1.0, np.nan_to_num(rgb, nan=0.0))
    data = (np.maximum(c, 0.0) * 255).astype(np.uint8)
    h, w = data.shape[:2]
    path.write_bytes(f"P6\n{w} {h}\n255\n".encode() + data.tobytes())


def render_variant(
    scene: Scene, variant: str, width: int, height: int, path: Path, *, flip: str = ""
) -> Path:
    """The variant's PPM; flip "lr" mirrors it left to right, "ud" upside down (as a program
    that draws its rows or columns the wrong way round shows it)."""
    rgb = student_tracer(scene, variant).render(width, height)
    if "lr" in flip:
        rgb = rgb[:, ::-1]
    if "ud" in flip:
        rgb = rgb[::-1]
    write_truncating_ppm(path, rgb)
    return path
