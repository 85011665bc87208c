"""The light-units rule shared with demo_cpp (light_units.h).

The paper's emission E has no 1/pi and no falloff. Calibrated units (the default) make a
white Lambertian surface facing the light at the camera's look_at receive E:
point intensity I = pi * E * d0^2 (d0 = light centre to look_at, at least the radius), and
an area (sphere) light the radiance of equal power, I / (pi R^2). Physical units take E as
the sphere's radiance, and give the point light the same power: I = E * pi R^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scene_model.scene import Scene, Sphere, Vec3

UNITS = ("calibrated", "physical")


@dataclass(frozen=True)
class LightValues:
    intensity: Vec3  # point light, W/sr
    radiance: Vec3  # sphere area light
    factor: float  # intensity / E


def calibration_distance_sq(scene: Scene, light: Sphere) -> float:
    d = [a - b for a, b in zip(light.center, scene.camera.look_at, strict=False)]
    return max(sum(x * x for x in d), light.radius * light.radius)


def light_values(scene: Scene, light: Sphere, units: str = "calibrated") -> LightValues:
    if units not in UNITS:
        raise ValueError(f"light units must be one of {UNITS}, got {units!r}")
    area = math.pi * light.radius**2
    factor = math.pi * calibration_distance_sq(scene, light) if units == "calibrated" else area
    e = light.emission
    intensity = (e[0] * factor, e[1] * factor, e[2] * factor)
    radiance = (intensity[0] / area, intensity[1] / area, intensity[2] / area)
    return LightValues(intensity=intensity, radiance=radiance, factor=factor)
