"""Where an error nothing explains lives: the pixels that still differ from the diagnosis'
result, grouped by the path class of the model's ray tree at each pixel (rtdemo's `path` AOV,
docs/diagnosis.md "Where the error lives"), and the step of the algorithm the counts point to.

For each path bit b (and each pair of bits), with D the differing pixels and P_b the pixels
whose path has b: recall = |D∩P_b| / |D|, precision = |D∩P_b| / |P_b|. The step named is that
of the bit (or pair) with recall at least RECALL_MIN and the highest precision; with no such
bit the error is "spread over several steps" and only the largest classes are given.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np
from numpy.typing import NDArray

BOOL = NDArray[np.bool_]
INT = NDArray[np.int64]

# rtdemo's path-class bits (demo_cpp/src/core/ray_tree.h), in bit order.
PATH_BITS: dict[str, int] = {
    "CAMERA_MISS": 1,
    "DIFFUSE_LIT": 2,
    "DIFFUSE_SHADOW": 4,
    "SHADOW_GLASS": 8,
    "MIRROR": 16,
    "GLASS_ENTER": 32,
    "GLASS_LEAVE": 64,
    "TIR": 128,
    "DEPTH_LIMIT": 256,
    "SECONDARY_MISS": 512,
    "LIGHT_HIT": 1024,
    "GLASS_HIT": 2048,
    "MIRROR_HIT": 4096,
}
# The step of the algorithm (the shared vocabulary) each bit's pixels go through.
BIT_STEPS: dict[str, str] = {
    "CAMERA_MISS": "background",
    "DIFFUSE_LIT": "direct light",
    "DIFFUSE_SHADOW": "shadow rays",
    "SHADOW_GLASS": "shadow through glass",
    "MIRROR": "reflection",
    "GLASS_ENTER": "refraction entering",
    "GLASS_LEAVE": "refraction leaving",
    "TIR": "fresnel",
    "DEPTH_LIMIT": "depth limit",
    "SECONDARY_MISS": "background",
    "LIGHT_HIT": "emission",
    "GLASS_HIT": "refraction entering",
    "MIRROR_HIT": "reflection",
}
# What a pixel's path does, for the sentence: "those whose path leaves glass".
BIT_PHRASES: dict[str, str] = {
    "CAMERA_MISS": "sees the background directly",
    "DIFFUSE_LIT": "reaches a diffuse surface the light shines on",
    "DIFFUSE_SHADOW": "reaches a diffuse surface in an opaque sphere's shadow",
    "SHADOW_GLASS": "has a shadow ray through a glass sphere",
    "MIRROR": "is reflected",
    "GLASS_ENTER": "enters glass",
    "GLASS_LEAVE": "leaves glass",
    "TIR": "is totally reflected inside glass",
    "DEPTH_LIMIT": "reaches the depth limit on a specular surface",
    "SECONDARY_MISS": "escapes to the background after a bounce",
    "LIGHT_HIT": "hits the light",
    "GLASS_HIT": "starts on a glass sphere",
    "MIRROR_HIT": "starts on a mirror sphere",
}
# Where several bits mark the very same differing pixels (every glass path is also
# reflected), the image cannot tell their steps apart: all are given, the most specific first.
SPECIFIC_FIRST = (
    "GLASS_LEAVE",
    "GLASS_ENTER",
    "TIR",
    "SHADOW_GLASS",
    "DEPTH_LIMIT",
    "DIFFUSE_SHADOW",
    "DIFFUSE_LIT",
    "SECONDARY_MISS",
    "LIGHT_HIT",
    "CAMERA_MISS",
    "MIRROR",
    "MIRROR_HIT",
    "GLASS_HIT",
)
# A step is named only when its pixels hold at least this share of the differing ones
# (recall); below it the error is spread over several steps.
RECALL_MIN = 0.9
# Above this precision the differing pixels are "exactly" those of the class, else "mostly".
EXACT_PRECISION = 0.9
TOP_CLASSES = 4
# Bits that say where the camera ray lands, not a step the path goes through: they group the
# classes but never name the step.
FIRST_SURFACE = ("GLASS_HIT", "MIRROR_HIT")
# A pair of bits is named instead of its best single bit only when it is this much more
# precise: one bit is the plainer statement.
PAIR_GAIN = 0.15
# The background seen directly is judged right where this many pixels see it and under this
# share of them differ: then a bounced ray's background is not the only suspect.
SKY_MIN = 100
SKY_DIFFERING = 0.02
# Differing pixels outside the class named, at least this share of them, that are "exactly"
# another class of their own: two steps differ, or one both take.
SECOND_SHARE = 0.05


@dataclass(frozen=True)
class Located:
    step: str  # a step of the vocabulary, or "spread over several steps"
    sentence: str
    bits: tuple[str, ...]  # the bit (or pair) named; () when spread
    differing: int  # |D|
    pixels: int  # |P| of the bits named (0 when spread)
    recall: float
    precision: float
    # Other steps whose pixels are the same differing ones (the image cannot tell them apart).
    alternatives: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        return {
            "step": self.step,
            "sentence": self.sentence,
            "differing": self.differing,
            "pixels": self.pixels,
            "recall": self.recall,
            "precision": self.precision,
            "alternatives": list(self.alternatives),
        }


def class_name(bits: int) -> str:
    """ "GLASS_HIT|GLASS_ENTER|GLASS_LEAVE" for a path value; "NONE" for 0."""
    names = [n for n, b in PATH_BITS.items() if bits & b]
    return "|".join(names) or "NONE"


def classes(differing: BOOL, path: INT, top: int = TOP_CLASSES) -> list[dict[str, Any]]:
    """The path classes (whole values) holding the most differing pixels, with how many
    pixels each class has within the region `differing` was taken from."""
    values, counts = np.unique(path[differing], return_counts=True)
    order = np.argsort(-counts, kind="stable")[:top]
    return [
        {
            "class": class_name(int(values[i])),
            "bits": int(values[i]),
            "differing": int(counts[i]),
            "pixels": int(np.count_nonzero(path == values[i])),
        }
        for i in order
    ]


def _candidates(path: INT) -> list[tuple[tuple[str, ...], BOOL]]:
    """Every bit's pixels, and every pair's (both bits set)."""
    single: list[tuple[tuple[str, ...], BOOL]] = [
        ((n,), (path & b) != 0) for n, b in PATH_BITS.items() if n not in FIRST_SURFACE
    ]
    pairs: list[tuple[tuple[str, ...], BOOL]] = [
        ((a[0][0], b[0][0]), a[1] & b[1])
        for a, b in combinations(single, 2)
        if BIT_STEPS[a[0][0]] != BIT_STEPS[b[0][0]]
    ]
    return single + pairs


def locate(differing: BOOL, path: INT, region: BOOL | None = None) -> Located | None:
    """The step the differing pixels point to within `region` (default: everywhere); None
    when no pixel differs there."""
    within = np.ones_like(differing) if region is None else region
    d = differing & within
    n = int(np.count_nonzero(d))
    if not n:
        return None
    scored = []
    for names, where in _candidates(path):
        p = int(np.count_nonzero(where & within))
        hit = int(np.count_nonzero(where & d))
        if p and hit >= RECALL_MIN * n:
            scored.append(((hit / p, hit / n), names, hit, p))
    singles = [x for x in scored if len(x[1]) == 1]
    pairs = [x for x in scored if len(x[1]) == 2]
    if singles and pairs and max(pairs)[0][0] < max(singles)[0][0] + PAIR_GAIN:
        scored = singles
    elif pairs:
        scored = pairs
    if not scored:
        return _spread(d, path, n)
    top = max(k for k, *_ in scored)
    tied = sorted((x for x in scored if x[0] == top), key=lambda x: _rank(x[1]))
    (precision, recall), names, hit, p = tied[0]
    steps = list(dict.fromkeys(_step(x[1]) for x in tied))
    if "SECONDARY_MISS" in names and _sky_matches(differing, path):
        # The background seen directly is right: a bounced ray's may still be (a program
        # that returns black after a bounce), or the bounce before it is wrong.
        steps = list(dict.fromkeys([*steps, "reflection", "fresnel"]))
    found = Located(
        steps[0],
        _sentence(names, (hit, n, precision), steps),
        names,
        n,
        p,
        recall,
        precision,
        tuple(steps[1:]),
    )
    outside = ~_pixels(names, path)
    second = _second(d & outside, path, within & outside, n)
    if second is None or precision < EXACT_PRECISION or BIT_STEPS[second[0]] in steps:
        return found
    return _with_second(found, _head(names, (hit, n, precision)), second)


def _sky_matches(differing: BOOL, path: INT) -> bool:
    """The pixels that see the background directly (at least SKY_MIN of them) nearly all
    match (under SKY_DIFFERING of them differ)."""
    sky = (path & PATH_BITS["CAMERA_MISS"]) != 0
    n = int(np.count_nonzero(sky))
    return n >= SKY_MIN and int(np.count_nonzero(sky & differing)) < SKY_DIFFERING * n


def _pixels(names: tuple[str, ...], path: INT) -> BOOL:
    out = np.ones(path.shape, bool)
    for x in names:
        out &= (path & PATH_BITS[x]) != 0
    return out


def _second(rest: BOOL, path: INT, region: BOOL, n: int) -> tuple[str, int, float] | None:
    """The bit whose pixels (within `region`) are exactly the differing pixels `rest` that the
    class named leaves, where they are SECOND_SHARE of all n: (bit, pixels, precision)."""
    m = int(np.count_nonzero(rest))
    if m < SECOND_SHARE * n:
        return None
    best: tuple[str, int, float] | None = None
    for name, bit in PATH_BITS.items():
        where = ((path & bit) != 0) & region
        p, hit = int(np.count_nonzero(where)), int(np.count_nonzero(where & rest))
        if name in FIRST_SURFACE or hit < RECALL_MIN * m or hit < EXACT_PRECISION * p:
            continue
        if best is None or hit / p > best[2]:
            best = (name, m, hit / p)
    return best


def _with_second(found: Located, head: str, second: tuple[str, int, float]) -> Located:
    """found (its sentence's `head`), told with the second class of differing pixels: two
    steps are wrong, or one that both kinds of path take (the surface's hit point or normal)."""
    name, m, precision = second
    step = BIT_STEPS[name]
    sentence = (
        f"{head}, and the other {m:,} exactly those whose path {BIT_PHRASES[name]} "
        f"({precision:.0%} of such pixels differ): the {found.step} and the {step} are both "
        "wrong, or a step both kinds of path take: the hit point or its normal"
    )
    more = (*found.alternatives, step, "normal")
    return dataclasses.replace(found, sentence=sentence, alternatives=more)


def _rank(names: tuple[str, ...]) -> int:
    return min(SPECIFIC_FIRST.index(x) for x in names)


def _step(names: tuple[str, ...]) -> str:
    """The step of a bit; of a pair, that of its more specific bit."""
    return BIT_STEPS[min(names, key=SPECIFIC_FIRST.index)]


def _head(names: tuple[str, ...], counts: tuple[int, int, float]) -> str:
    """ "the differing pixels are exactly those whose path … (hit of n; p% of such pixels
    differ)": what the counts say, before the step is blamed."""
    hit, n, precision = counts
    how = "exactly" if precision >= EXACT_PRECISION else "mostly"
    what = " and ".join(BIT_PHRASES[x] for x in names)
    return (
        f"the differing pixels are {how} those whose path {what} ({hit:,} of {n:,}; "
        f"{precision:.0%} of such pixels differ)"
    )


def _sentence(names: tuple[str, ...], counts: tuple[int, int, float], steps: list[str]) -> str:
    exact = counts[2] >= EXACT_PRECISION
    named = f"the {steps[0]}"
    if len(steps) > 1:
        named = f"the {', the '.join(steps[:-1])} or the {steps[-1]} (the image cannot tell which)"
    # Where most such paths come out right, no step they all take is wrong as a whole.
    blame = (
        (f"{named} is wrong" if len(steps) == 1 else f"the error lies in a step every such "
         f"path takes: {named}")
        if exact
        else f"the error lives on such paths, in {named} or a step only some of them take"
    )  # fmt: skip
    return f"{_head(names, counts)}: {blame}"


def on_silhouettes(differing: BOOL, edges: BOOL | None) -> Located | None:
    """The differing pixels told by where they lie rather than by path: nearly all on the
    spheres' silhouettes (the edges effect's pixels) means the spheres are drawn a little
    elsewhere, which the camera rays or the intersection test decide; None otherwise."""
    n = int(np.count_nonzero(differing))
    if edges is None or not n:
        return None
    hit, p = int(np.count_nonzero(differing & edges)), int(np.count_nonzero(edges))
    if hit < RECALL_MIN * n:
        return None
    sentence = (
        f"the differing pixels lie on the spheres' silhouettes ({hit:,} of {n:,}; "
        f"{hit / p:.0%} of the silhouettes' pixels differ): the spheres are drawn a little "
        "elsewhere, which the camera rays or the intersection test decide"
    )
    steps = ("the camera", "the intersection")
    return Located(steps[0], sentence, ("SILHOUETTE",), n, p, hit / n, hit / p, steps[1:])


def outlines_elsewhere(share: float, least: float) -> Located:
    """The image's edges lie on few of the model's sphere outlines (a share under `least`):
    its spheres are drawn elsewhere or at another size, which the camera rays or the
    intersection test decide, and every other effect differs through that."""
    sentence = (
        f"the image's edges lie on {share:.0%} of the outlines of the spheres the model draws "
        f"(an image with the model's spheres in place: {least:.0%} or more): its spheres are "
        "drawn elsewhere or at another size, which the camera rays or the intersection test "
        "decide; no shading cause can be read off such an image"
    )
    steps = ("the camera", "the intersection")
    return Located(steps[0], sentence, ("OUTLINES",), 0, 0, 0.0, share, steps[1:])


def _spread(d: BOOL, path: INT, n: int) -> Located:
    top = classes(d, path, 3)
    listed = ", ".join(f"{c['class']} ({c['differing']:,})" for c in top)
    sentence = (
        f"the {n:,} differing pixels are spread over several steps: no single kind of path "
        f"holds {RECALL_MIN:.0%} of them (largest: {listed})"
    )
    return Located("spread over several steps", sentence, (), n, 0, 0.0, 0.0)
