"""One line per paper quirk (docs/paper-model.md has the full text), for sentences."""

from __future__ import annotations

QUIRKS: dict[int, str] = {
    1: "the tca < 0 early-out and a fixed bias",
    2: "eta = 1/ior also when leaving glass",
    3: "a NaN direction at total internal reflection",
    4: "one shadow factor shared by all lights",
    5: "shadow rays not stopped at the light",
    6: "specular surfaces shaded as diffuse at max depth",
    7: "no 1/pi and no distance falloff",
    8: "the paper's Fresnel curve 0.1 + 0.9 (1 - cos)^3",
    9: "glass casts partial shadows",
    10: "one ray through each pixel centre",
    11: "the directly lit colour starts at 1, not 0",
    12: "no Lambert cosine: lights behind a surface light it too",
    13: "the hit sphere's own emission is never added",
}
