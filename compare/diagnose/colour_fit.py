"""A sphere's surface colour as a program types it, read off the pixels that see that sphere
first: ggerholm's Java port gives scratchapixel's glass (1, 0.32, 0.26) for (1, 0.32, 0.36).

Every way a Whitted tracer shades a hit multiplies by the sphere's colour: the diffuse term,
the mirror's reflection and the glass's whole specular mix. So where a camera ray hits the
sphere first, a channel of the image over the same channel of the candidate's render is the
colour's ratio, r, on paths that meet the sphere once, and r^k on paths that meet it k times
(inside glass); those lie further from 1. The ratio is therefore read where it lies nearest
1 (the 90th percentile of the ratios below 1, the 10th of those above), only where every
ratio of the channel lies on one side of 1 and the other channels keep theirs. The colour it
gives is snapped to two decimals and offered with its neighbours a hundredth either side in
that channel; renders decide, and the gates whether it is named.
"""

from __future__ import annotations

import numpy as np

from compare.diagnose.candidate import RGB
from compare.diagnose.refine import code_readings
from compare.judge.arrays import F32
from compare.judge.images import Image
from scene_model.scene import Scene

# The pixels used: lit in both images by at least this much, and not clipped.
DARKEST = 8 / 255
BRIGHTEST = 254 / 255
MIN_PIXELS = 64
# A channel is changed when its ratios lie beyond CHANGED of 1 (10th to 90th percentile),
# kept when its median lies within KEPT of 1.
CHANGED = 0.01
KEPT = 0.01
STEP = 0.01  # the neighbours offered either side of the snapped value
MAX_SAMPLES = 20_000  # pixels per sphere a ratio is read from (a 1200x800 glass has ~100,000)


def colours_seen(test: F32, render: Image, scene: Scene, encoding: str) -> list[tuple[str, RGB]]:
    """(sphere name, colour) for every sphere whose first-hit pixels show it in another
    colour than `render` (a candidate's, with its id AOV) has it, for each reading of the
    8-bit codes: the snapped reading and its neighbours, without repeats; [] where no sphere
    shows one."""
    if "id" not in render.aovs:
        return []
    ids = np.rint(render.aovs["id"]).astype(int)
    seen = np.where(_interior(ids), ids, -1).ravel()
    spheres = [(k, s) for k, s in enumerate(scene.spheres) if s.kind != "light"]
    where = {k: _sampled(np.flatnonzero(seen == k)) for k, _ in spheres}
    rgb = render.rgb.reshape(-1, 3)
    out: list[tuple[str, RGB]] = []
    for reading in code_readings(test, encoding):
        values = reading.reshape(-1, 3)
        for k, sphere in spheres:
            ratios = _ratios(values[where[k]], rgb[where[k]])
            found = [(sphere.name, c) for c in _colours(sphere.color, ratios)]
            out += [f for f in found if f not in out]
    return out


def _sampled(index: np.ndarray) -> np.ndarray:
    """At most about MAX_SAMPLES of the indices, evenly spread: percentiles need no more."""
    return index[:: max(1, len(index) // MAX_SAMPLES)]


def _interior(ids: np.ndarray) -> np.ndarray:
    """Pixels whose four neighbours see the same sphere first (no silhouette)."""
    out = np.ones(ids.shape, bool)
    for axis in (0, 1):
        change = np.diff(ids, axis=axis) != 0
        if axis == 0:
            out[1:] &= ~change
            out[:-1] &= ~change
        else:
            out[:, 1:] &= ~change
            out[:, :-1] &= ~change
    return out


def _ratios(test: np.ndarray, render: np.ndarray) -> list[np.ndarray | None]:
    """Per channel, the image's values over the render's where both are lit and not clipped
    (None where too few are)."""
    out: list[np.ndarray | None] = []
    for ch in range(3):
        a, b = render[:, ch].astype(np.float64), test[:, ch].astype(np.float64)
        lit = (a > DARKEST) & (b > DARKEST) & (a < BRIGHTEST) & (b < BRIGHTEST)
        out.append(b[lit] / a[lit] if lit.sum() >= MIN_PIXELS else None)
    return out


def _colours(colour: RGB, ratios: list[np.ndarray | None]) -> list[RGB]:
    """The colours the ratios read (snapped, and a hundredth either side in each changed
    channel), or [] where no channel changed or one is neither changed nor kept."""
    readings: list[list[float]] = []
    changed = False
    for value, r in zip(colour, ratios, strict=True):
        if r is None:
            readings.append([value])
            continue
        low, high = np.percentile(r, [10, 90])
        if high < 1 - CHANGED or low > 1 + CHANGED:
            near = high if high < 1 else low
            snapped = round(float(value * near), 2)
            readings.append([round(snapped + d, 2) for d in (0.0, -STEP, STEP)])
            changed = True
        elif abs(float(np.median(r)) - 1) <= KEPT:
            readings.append([value])
        else:
            return []
    # A typo in one or two numbers: every channel changed by one factor is a brightness
    # (the light's, the exposure), not a colour typed.
    if not changed or all(len(options) > 1 for options in readings):
        return []
    first = tuple(options[0] for options in readings)
    out = [(first[0], first[1], first[2])]
    for ch, options in enumerate(readings):
        for v in options[1:]:
            c = list(first)
            c[ch] = v
            out.append((c[0], c[1], c[2]))
    return [c for c in out if c != tuple(colour) and all(0 <= v <= 1 for v in c)]
