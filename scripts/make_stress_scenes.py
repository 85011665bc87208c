"""Writes scenes/stress/*.json: scenes where some method is known to fail. Run it to
regenerate them (deterministic); each scene's description says what breaks there."""

from __future__ import annotations

import json
import random
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent / "scene_model" / "scenes" / "stress"
CAM = {
    "position": [0, 0, 0],
    "look_at": [0, 0, -1],
    "up": [0, 1, 0],
    "fov_y": 30,
    "width": 640,
    "height": 480,
}
GROUND = {"name": "ground", "center": [0, -10004, -20], "radius": 10000, "color": [0.2, 0.2, 0.2]}
LIGHT = {
    "name": "light",
    "center": [0, 20, -30],
    "radius": 3,
    "color": [0, 0, 0],
    "emission": [3, 3, 3],
}


def scene(name: str, description: str, spheres: list[dict], **extra: object) -> dict:
    return {
        "format": "rtval-scene/1",
        "name": name,
        "description": description,
        "camera": extra.pop("camera", CAM),
        "background": extra.pop("background", [2, 2, 2]),
        "max_depth": extra.pop("max_depth", 5),
        "bias": extra.pop("bias", 1e-4),
        "spheres": spheres,
    }


def glass(
    name: str, c: list[float], r: float, ior: float = 1.5, color: list[float] | None = None
) -> dict:
    return {
        "name": name,
        "center": c,
        "radius": r,
        "color": color or [1, 1, 1],
        "reflection": 1,
        "transparency": 1,
        "ior": ior,
    }


def mirror(name: str, c: list[float], r: float, color: list[float] | None = None) -> dict:
    return {
        "name": name,
        "center": c,
        "radius": r,
        "color": color or [0.9, 0.9, 0.9],
        "reflection": 1,
    }


def diffuse(name: str, c: list[float], r: float, color: list[float]) -> dict:
    return {"name": name, "center": c, "radius": r, "color": color}


def scenes() -> list[dict]:
    rng = random.Random(1000)
    many = [GROUND, LIGHT] + [
        diffuse(
            f"s{i}",
            [rng.uniform(-12, 12), rng.uniform(-3.5, 6), rng.uniform(-60, -15)],
            rng.uniform(0.2, 0.8),
            [round(rng.uniform(0.1, 1), 3) for _ in range(3)],
        )
        for i in range(998)
    ]
    return [
        scene(
            "tir_grazing",
            "Glass of ior 2.4 (diamond) around the camera's rays at grazing exits: total internal "
            "reflection, where classic mode's sqrt(k < 0) gives NaN directions (Q3).",
            [
                GROUND,
                LIGHT,
                glass("diamond", [0, 0, -12], 3, 2.4),
                glass("inner", [0.5, 0.2, -12], 1.5, 1.0),
            ],
        ),
        scene(
            "camera_inside_glass",
            "The camera sits inside a glass sphere: Q1's early-out misses it, Q2 keeps "
            "eta = 1/ior on the way out, and exits past the critical angle reflect totally.",
            [
                GROUND,
                LIGHT,
                glass("bubble", [0, 0, -1], 4, 1.5),
                diffuse("red", [0, 0, -15], 2, [1, 0.2, 0.2]),
            ],
        ),
        scene(
            "intersecting_spheres",
            "Two glass spheres and a diffuse one overlap: rays start inside other spheres.",
            [
                GROUND,
                LIGHT,
                glass("a", [-1.5, 0, -15], 3, 1.3),
                glass("b", [1.5, 0, -15], 3, 1.3),
                diffuse("c", [0, 2, -16], 2, [0.3, 0.8, 0.3]),
            ],
        ),
        scene(
            "nested_spheres",
            "A diffuse sphere inside a glass sphere inside a glass sphere.",
            [
                GROUND,
                LIGHT,
                glass("outer", [0, 0, -15], 4, 1.2),
                glass("middle", [0, 0, -15], 2.5, 1.5),
                diffuse("core", [0, 0, -15], 1, [0.9, 0.6, 0.1]),
            ],
        ),
        scene(
            "huge_floor_tiny_sphere",
            "A radius-1e4 floor and a radius-0.01 sphere on it: float32 precision at both "
            "ends of the scale.",
            [
                GROUND,
                LIGHT,
                diffuse("tiny", [0, -3.99, -8], 0.01, [1, 0.2, 0.2]),
                mirror("ball", [1, -3, -12], 1),
            ],
        ),
        scene(
            "far_objects",
            "Spheres 1e4 units away, seen with a narrow field of view: offsets and t-ranges at "
            "large distances.",
            [
                diffuse("far", [0, 0, -10000], 200, [0.8, 0.3, 0.3]),
                mirror("farmirror", [500, 0, -10500], 300),
                {
                    "name": "sun",
                    "center": [0, 5000, -5000],
                    "radius": 100,
                    "color": [0, 0, 0],
                    "emission": [3, 3, 3],
                },
            ],
            camera={**CAM, "fov_y": 5},
        ),
        scene(
            "facing_mirrors",
            "Two large mirrors facing each other with the camera between: every chain runs out "
            "of depth (max_depth 64), where Q6 shades the last mirror as diffuse.",
            [
                LIGHT,
                mirror("left", [-1006, 0, -20], 1000),
                mirror("right", [1006, 0, -20], 1000),
                diffuse("ball", [0, 0, -20], 1.5, [0.2, 0.5, 0.9]),
            ],
            max_depth=64,
        ),
        scene(
            "light_inside_glass",
            "A light inside a glass sphere: only caustics could light the room, which no "
            "method here renders (paper and classic shadow partially through glass, Q9).",
            [
                GROUND,
                glass("lamp_glass", [0, 3, -20], 3, 1.5),
                {
                    "name": "bulb",
                    "center": [0, 3, -20],
                    "radius": 0.5,
                    "color": [0, 0, 0],
                    "emission": [5, 5, 5],
                },
                diffuse("ball", [3, -2, -16], 2, [0.8, 0.8, 0.8]),
            ],
        ),
        scene(
            "coloured_lights",
            "Three coloured lights and occluders: Q4's shared shadow factor darkens later lights.",
            [
                GROUND,
                diffuse("ball", [0, -1, -18], 3, [0.9, 0.9, 0.9]),
                glass("glass", [-4, -2, -14], 1.5, 1.3),
                {
                    "name": "red",
                    "center": [-15, 15, -10],
                    "radius": 1,
                    "color": [0, 0, 0],
                    "emission": [3, 0.2, 0.2],
                },
                {
                    "name": "green",
                    "center": [0, 20, -10],
                    "radius": 1,
                    "color": [0, 0, 0],
                    "emission": [0.2, 3, 0.2],
                },
                {
                    "name": "blue",
                    "center": [15, 15, -10],
                    "radius": 1,
                    "color": [0, 0, 0],
                    "emission": [0.2, 0.2, 3],
                },
            ],
        ),
        scene(
            "grazing_floor",
            "The camera a hair above a huge diffuse floor, looking along it: shadow acne against "
            "the fixed bias.",
            [GROUND, LIGHT, diffuse("ball", [2, -3, -40], 1, [0.9, 0.4, 0.1])],
            camera={
                "position": [0, -3.99, 0],
                "look_at": [0, -3.995, -1],
                "up": [0, 1, 0],
                "fov_y": 30,
                "width": 640,
                "height": 480,
            },
        ),
        scene(
            "no_light",
            "No light at all: only the background and mirrors show anything.",
            [
                GROUND,
                mirror("mirror", [0, 0, -15], 3),
                diffuse("ball", [4, 0, -15], 1.5, [1, 0, 0]),
            ],
        ),
        scene(
            "thousand_spheres",
            "1000 spheres: the cost of testing every sphere for every ray.",
            many,
        ),
    ]


def main() -> None:
    for s in scenes():
        (HERE / f"{s['name']}.json").write_text(json.dumps(s, indent=1) + "\n")
        print(HERE / f"{s['name']}.json")


if __name__ == "__main__":
    main()
