"""Student-style variants of the classic program, for `rtval diagnose`'s tests: the
independent numpy tracer of tests/numpy_reference.py (classic mode) with one mistake each,
written as the classic program writes its output (a binary PPM, each channel
`(unsigned char)(min(1, x) * 255)`: clamped and truncated, NaN as 0).

Each variant names the cause `diagnose` should find, in the words of its Diagnosis:
a quirk present ("+Q2"), an effect off ("shadows") or a named mistake (mistakes.json).
"""

from __future__ import annotations

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


# variant -> (what diagnose should name, the tracer with that mistake)
_TRACERS: dict[str, tuple[str, type[StudentTracer]]] = {
    "wrong_eta_leaving": ("+Q2", WrongEtaLeaving),
    "no_offset": ("no_offset", NoOffset),
    "no_shadows": ("shadows", NoShadows),
    "no_inside_flip": ("no_inside_flip", NoInsideFlip),
    "constant_fresnel": ("fresnel_constant", ConstantFresnel),
    "black_background": ("black_background", BlackBackground),
}
VARIANTS: dict[str, str] = {name: cause for name, (cause, _) in _TRACERS.items()}


def student_tracer(scene: Scene, variant: str = "exact") -> StudentTracer:
    """The classic program with one of VARIANTS (or none: "exact")."""
    if variant == "exact":
        return StudentTracer(scene)
    if variant not in _TRACERS:
        raise ValueError(variant)
    return _TRACERS[variant][1](scene)


def write_truncating_ppm(path: Path, rgb: F64) -> None:
    """P6 as the classic program writes it: (unsigned char)(min(1, x) * 255), NaN -> 0."""
    c = np.minimum(1.0, np.nan_to_num(rgb, nan=0.0))
    data = (np.maximum(c, 0.0) * 255).astype(np.uint8)
    h, w = data.shape[:2]
    path.write_bytes(f"P6\n{w} {h}\n255\n".encode() + data.tobytes())


def render_variant(scene: Scene, variant: str, width: int, height: int, path: Path) -> Path:
    write_truncating_ppm(path, student_tracer(scene, variant).render(width, height))
    return path
