"""Explains a foreign image as the nearest demo model: which mode, which quirks present or
absent, which effects switched off, which recursion depth, which scene constants (background,
glass ior) and which named mistakes (mistakes.json) reproduce it, effect by effect.

The search renders candidates through an injected `render` (this module starts no process)
and scores each by the share of each effect's pixels that are not what the candidate
computes (exact_match.py's rule, counted quickly: a code that neither a truncating nor a
rounding writer of the candidate's value stores), plus a smooth term for how far they are off
(the mean number of 8-bit levels beyond one, and the region's mean colour), so that a change
that moves pixels towards the image counts before they match.

It first decides whether the image is mirrored (left-right or upside down: a program that
draws its columns or rows the wrong way round) and un-mirrors it. Then it starts from the mode
that matches most pixels of the whole image, tries one change at a time
(a quirk toggled, an effect off, another depth, background or ior, a mistake added or
removed), keeps the change that lowers the summed per-effect distance most and clearly helps
some effect, and repeats with the changes that helped, instead of all 2^13 quirk combinations.
The result is retold from the mode it differs least from in the quirks this scene shows, and
every change that makes no effect's pixels match is dropped: an effect counts as explained
only when the result makes at least EXPLAINED_SHARE of the pixels that differed from the
start match (README, "What does this image implement?"). Claims of a match are the exact
match of the candidate's renders with the camera turned as exact matching turns a model
(`turns`), so they agree with the verdict. FLIP (metrics.flip_ldr_map) gives the report's
numbers for the start and the result.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from compare.judge.candidate import RGB, SWITCHABLE_EFFECTS, Candidate, rgb_text
from compare.judge.effects import BOOL, EFFECTS, effect_masks
from compare.judge.exact_match import ExactMatch, exact_match
from compare.judge.images import F32, Image, linear_to_srgb
from compare.judge.metrics import flip_ldr_map
from compare.judge.mistakes import catalogue
from compare.judge.quirks import QUIRKS
from compare.judge.target_model import MODE_QUIRKS, QUIRK_COUNT, TargetModel
from scene_model.scene import Scene

Renderer = Callable[[TargetModel | Candidate], Image]

BASE_QUIRKS = tuple(range(1, 10))  # Q10 only matters with --spp > 1
LATER_QUIRKS = (11, 12, 13)  # searched where rtdemo renders them (CandidateRenderer says)
SEARCH_QUIRKS = BASE_QUIRKS + LATER_QUIRKS
# One unit of distance per effect is the whole region differing; LEVELS_PER_UNIT levels of
# mean excess weigh as much (so a change that halves how far pixels are off counts before
# they match).
LEVELS_PER_UNIT = 4.0
# An effect is explained when the result makes at least this share of the pixels that differed
# from the start match. Measured (tests/test_diagnose.py, 160x120 and 640x480): every named
# cause of the student variants makes 93-100 % match; the best candidates for programs nothing
# explains make 0-19 % match (glass never multiplied by its colour; a refracted ray that hits
# nothing): half is far from both.
EXPLAINED_SHARE = 0.5
# A change is kept when it lowers the objective by MIN_GAIN and some effect's distance by
# EXPLAINS (and 10 %): small drops spread over every effect are noise fitting.
MIN_GAIN = 1e-3
EXPLAINS = 2e-3
MAX_RENDERS = 200  # no new full sweep of every change starts beyond this many renders
MAX_SEARCH_DEPTH = 32
BACKGROUNDS: tuple[RGB, ...] = ((1.0, 1.0, 1.0), (2.0, 2.0, 2.0))  # black: black_background
IORS = (1.1, 1.2, 1.33, 1.5)
# Mistakes that move every pixel's tone: the nearest mode is chosen with and without them, so
# that a gamma-encoded paper image is not taken for physical mode (it starts from paper).
TONE_MISTAKES = ("double_gamma",)
# The image is taken as mirrored when a flipped copy is at most MIRROR_RATIO as far from the
# nearest mode as the image itself, by at least MIRROR_MIN (a share of all pixels). A scene
# symmetric about the flip gives both the same distance, so it can never trigger.
MIRRORS = {"lr": "left-right", "ud": "upside down", "lrud": "left-right and upside down"}
# The nearest mode is the one matching most pixels, unless none matches this share of them.
MODE_MATCH_MIN = 0.05
MIRROR_RATIO = 0.5
MIRROR_MIN = 0.02
HALF_FLOAT, HALF_FLOAT_FLOOR = 2.0**-11, 2.0**-14  # the search's float tolerance (module doc)


class DiagnoseError(ValueError):
    """The image cannot be diagnosed against this scene (e.g. a renderer without AOVs)."""


def unmirror(rgb: F32, mirrored: str) -> F32:
    """The image as the program computed it, before it was drawn mirrored ("" : as is)."""
    key = next((k for k, v in MIRRORS.items() if v == mirrored), mirrored)
    out = rgb[:, ::-1] if "lr" in key else rgb
    out = out[::-1] if "ud" in key else out
    return np.ascontiguousarray(out)


def _depth(c: Candidate, scene: Scene) -> int:
    return scene.max_depth if c.max_depth is None else c.max_depth


def _glass_iors(scene: Scene) -> set[float]:
    return {s.ior for s in scene.spheres if s.transparency > 0}


@dataclass(frozen=True)
class Change:
    """One switch tried on top of a candidate."""

    kind: str  # "quirk" | "effect" | "depth" | "mistake" | "background" | "ior"
    key: str  # "2" | "shadows" | "10" (the new depth) | "no_offset" | "1,1,1" | "1.5"
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
        if self.kind == "ior":
            return c.with_ior(float(self.key) if self.present else None)
        d = int(self.key)
        return c.with_depth(None if d == scene.max_depth else d)

    def _rgb(self) -> RGB:
        r, g, b = (float(v) for v in self.key.split(","))
        return (r, g, b)

    def short(self, c: Candidate, scene: Scene, *, or_more: bool = False) -> str:
        """The change in a word or two, for a gradebook column ("looks like +Q2"); or_more: a
        depth that every deeper limit reproduces as well."""
        if self.kind == "quirk":
            return f"{'+' if self.present else '-'}Q{self.key}"
        if self.kind == "effect":
            return f"--no-{self.key}" if self.present else f"+{self.key}"
        if self.kind == "depth":
            return f"max depth {self.key}" + (" or more" if or_more else "")
        if self.kind == "background":
            return f"background {rgb_text(self._rgb())}" if self.present else "scene background"
        if self.kind == "ior":
            return f"ior {float(self.key):g}" if self.present else "scene ior"
        return f"{'' if self.present else '-'}{self.key}"

    def label(self, c: Candidate, scene: Scene, *, or_more: bool = False) -> str:
        """What the change does, in words, e.g. "+Q2 (eta = 1/ior also when leaving glass)"."""
        if self.kind == "quirk":
            q = int(self.key)
            return f"{'+' if self.present else '-'}Q{q} ({QUIRKS[q]}" + (
                ")" if self.present else " fixed)"
            )
        if self.kind == "effect":
            return (
                f"--no-{self.key} ({self.key} switched off)"
                if self.present
                else (f"{self.key} switched back on")
            )
        if self.kind == "depth":
            d = int(self.key)
            cut = " (the mistake depth_cut)" if d == scene.max_depth - 1 else ""
            more = f" or more (every limit from {d} to {MAX_SEARCH_DEPTH} gives this image)"
            return f"max depth {d}{more if or_more else cut} (the scene asks {scene.max_depth})"
        if self.kind == "background":
            theirs = rgb_text(scene.background)
            return (
                f"background {rgb_text(self._rgb())} hard-coded (the scene's is {theirs})"
                if self.present
                else f"the scene's background {theirs}"
            )
        if self.kind == "ior":
            theirs = ", ".join(f"{v:g}" for v in sorted(_glass_iors(scene)))
            return (
                f"ior {float(self.key):g} hard-coded for every glass sphere (the scene's: {theirs})"
                if self.present
                else f"the scene's ior {theirs}"
            )
        m = catalogue()[self.key]
        return (
            f"the mistake {m.name} ({m.explanation})"
            if self.present
            else (f"without the mistake {m.name}")
        )


@dataclass(frozen=True)
class Step:
    """A change of the result, with the distance per effect before and after it."""

    change: str  # Change.label
    cause: str  # Change.short: "+Q2", "-Q8", "--no-shadows", "max depth 10", "no_offset"
    candidate: str  # the candidate after it
    before: dict[str, float]
    after: dict[str, float]
    explains: tuple[str, ...]  # effects whose pixels it makes match (and that are explained)


@dataclass(frozen=True)
class EffectFinding:
    effect: str
    pixels: int
    start_flip: float  # FLIP of the image against the start mode in this effect's pixels
    final_flip: float  # ... against the diagnosis
    start_distance: float  # mean 8-bit levels beyond one
    final_distance: float
    start_differing: int  # pixels that do not match the start exactly (as the verdict judges)
    final_differing: int  # ... the diagnosis
    allowed: int  # differing pixels an exact match allows in this effect
    nearest_share: float  # the most of start_differing any candidate tried matches (centres)
    explained_by: tuple[str, ...]  # labels of the steps that explain it
    matched: bool  # the diagnosis reproduces it: an exact match
    state: str  # "as start" | "explained" | "partly explained" | "unexplained"
    sentence: str

    @property
    def fixed_share(self) -> float:
        """The share of the pixels that differed from the start that the diagnosis matches."""
        if not self.start_differing:
            return 1.0
        return max(0.0, 1.0 - self.final_differing / self.start_differing)


@dataclass
class Diagnosis:
    scene: str
    image: str
    start: str  # the nearest mode's candidate name
    mode_objectives: dict[str, float]  # each mode tried: pixels of the image that differ
    result: str  # the diagnosis' candidate name
    rtdemo_args: list[str]  # the rtdemo options that render it (from scene_changes' copy)
    scene_changes: dict[str, Any]  # what a copy of the scene changes: background, ior
    mirrored: str  # "", "left-right", "upside down", "left-right and upside down"
    mode: str
    quirks_present: list[int]
    quirks_absent: list[int]
    quirks_invisible: list[int]  # toggling them changed no pixel: this scene cannot tell
    quirks_untested: list[int]  # the renderer cannot render them (an older rtdemo)
    effects_off: list[str]
    max_depth: int
    depth_or_more: bool  # every deeper limit searched gives the same image
    mistakes: list[str]
    steps: list[Step]
    effects: dict[str, EffectFinding]
    unexplained: list[str]
    matches: bool  # the result is an exact match of the image in every effect
    summary: str
    sentences: list[str]
    renders: int
    seconds: float
    candidate: Candidate = field(repr=False)

    @property
    def exact(self) -> bool:
        return self.matches

    @property
    def causes(self) -> list[str]:
        """What differs from the start mode, shortly: ["+Q2"], ["mirrored left-right"], []."""
        head = [f"mirrored {self.mirrored}"] if self.mirrored else []
        return head + [s.cause for s in self.steps]

    def reason(self) -> str:
        """One line for a gradebook: "looks like classic+Q2 (+Q2)", with the regions that
        nothing explains."""
        text = f"looks like {self.result}"
        if self.causes:
            text += f" ({', '.join(self.causes)})"
        if self.unexplained:
            text += f"; not explained: {', '.join(self.unexplained)}"
        return text

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("candidate")
        d["causes"] = self.causes
        d["reason"] = self.reason()
        for k, f in self.effects.items():
            d["effects"][k]["fixed_share"] = f.fixed_share
        return d


I16 = NDArray[np.int16]


def _levels(rgb: F32, codes: str) -> F32:
    """255 x the value an 8-bit writer stores, in the image's own encoding: linear for a PPM
    read as linear, display (sRGB) otherwise. NaN counts as 0, as the paper's PPM writer
    stores it."""
    if codes == "linear":
        c = np.clip(np.nan_to_num(rgb, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    else:
        c = linear_to_srgb(np.nan_to_num(rgb, nan=0.0, posinf=1.0))
    out: F32 = (c * np.float32(255.0)).astype(np.float32)
    return out


def _encoded(rgb: F32, codes: str) -> I16:
    """Whole 8-bit levels (rounded). Rounding a candidate moves it by at most half a level,
    which the one level that `excess` forgives covers (a truncating writer is at most one
    level below)."""
    out: I16 = np.rint(_levels(rgb, codes)).astype(np.int16)
    return out


def _quick_differing(levels: F32, target: I16, rgb: F32, test: F32, encoding: str) -> BOOL:
    """H x W: pixels the search counts as not matching the candidate: an 8-bit code that
    neither a truncating nor a rounding writer of the candidate's value stores (a float image:
    off by more than half-float precision). exact_match's rule without its slack of 2^-16 in
    the value; the search's count only, every claim is exact_match's."""
    if encoding == "float":
        with np.errstate(invalid="ignore"):
            ok = np.abs(test - rgb) <= HALF_FLOAT * np.maximum(np.abs(rgb), HALF_FLOAT_FLOOR)
        ok |= np.isnan(test) & np.isnan(rgb)
    else:
        ok = (target >= np.floor(levels)) & (target <= np.floor(levels + np.float32(0.5)))
    out: BOOL = ~(ok[..., 0] & ok[..., 1] & ok[..., 2])
    return out


class _Regions:
    """The effect masks as one label per pixel, so that per-region means are one bincount."""

    def __init__(self, masks: dict[str, BOOL]) -> None:
        self.names = list(masks)
        n = len(self.names)
        labels = np.full(next(iter(masks.values())).size, n, np.intp)  # n: in no region
        for i, m in enumerate(masks.values()):
            labels[m.ravel()] = i
        self.labels = labels
        self.counts = np.bincount(labels, minlength=n + 1)[:n].astype(np.float64)

    def mean(self, values: NDArray[Any]) -> NDArray[np.float64]:
        n = len(self.names)
        sums = np.bincount(self.labels, weights=values.ravel(), minlength=n + 1)[:n]
        out: NDArray[np.float64] = sums / self.counts
        return out

    def colour(self, enc: I16) -> NDArray[np.float64]:
        """Mean colour per region, regions x 3, in levels."""
        return np.stack([self.mean(enc[..., ch]) for ch in range(3)], axis=1)


@dataclass(frozen=True)
class _Score:
    """A candidate against the image, per effect region."""

    differing: dict[str, int]  # pixels that are not an exact match of the candidate's render
    share: dict[str, float]  # ... as a share of the region
    pixels: dict[str, float]  # mean levels beyond one
    tone: dict[str, float]  # how far the mean colour is off, levels beyond one
    digest: bytes  # of the encoded candidate: equal digests, equal images

    def per_effect(self) -> dict[str, float]:
        # The tone term: where float rounding decides each pixel (acne), two programs with the
        # same mistake differ pixel by pixel but agree on average.
        return {
            k: self.share[k] + (self.pixels[k] + self.tone[k]) / LEVELS_PER_UNIT
            for k in self.pixels
        }


def _objective(per: dict[str, float]) -> float:
    return float(sum(per.values()))  # every effect counts alike, whatever its size


def _explained(
    before: dict[str, float], after: dict[str, float], open_effects: set[str]
) -> tuple[str, ...]:
    """The effects still to explain whose distance a change lowers clearly (by EXPLAINS and
    10 %). An effect already within the exact-match allowance has nothing left to explain:
    moving its last stray pixels is float noise (a float64 program's rounding)."""
    return tuple(
        k
        for k in before
        if k in open_effects and before[k] - after[k] > max(EXPLAINS, 0.1 * before[k])
    )


def _excess(enc: I16, target: I16) -> I16:
    """Per pixel, the levels by which its worst channel differs beyond one (a reduction over
    the last axis of 3 is slower in numpy than two elementwise maxima)."""
    d = np.abs(enc - target)
    out: I16 = np.maximum(np.maximum(np.maximum(d[..., 0], d[..., 1]), d[..., 2]), 1) - 1
    return out


def _flip_codes(target: I16, key: str) -> I16:
    out = target[:, ::-1] if "lr" in key else target
    return out[::-1] if "ud" in key else out


def _mirror_distance(enc: I16, target: I16) -> float:
    """Share of all pixels off by more than one level, plus their mean excess / LEVELS_PER_UNIT."""
    excess = _excess(enc, target)
    return float((excess > 0).mean() + excess.mean() / LEVELS_PER_UNIT)


class _Search:
    """The state of one diagnosis: the image (un-mirrored once that is decided), the effect
    regions, and every candidate's score."""

    def __init__(
        self,
        image: Image,
        scene: Scene,
        render: Renderer,
        parallel: int,
        turns: Sequence[tuple[float, float]],
        grows: Sequence[int] = (),
    ) -> None:
        self.image, self.scene, self.render, self.parallel = image, scene, render, parallel
        self.turns, self.grows = list(turns), list(grows)
        self.exact_memo: dict[Candidate, ExactMatch] = {}
        self.codes = "linear" if image.encoding == "linear" else "srgb"
        self.test = image.rgb
        self.target = _encoded(image.rgb, self.codes)
        self.scores: dict[Candidate, _Score] = {}
        self.kept: dict[Candidate, Image] = {}  # renders kept for re-scoring and FLIP
        self.keep: set[Candidate] = set()
        self.masks: dict[str, BOOL] = {}
        self.regions: _Regions | None = None
        self.target_colour: NDArray[np.float64] | None = None
        self.allowance: dict[str, int] = {}  # differing pixels an exact match allows

    def set_test(self, rgb: F32) -> None:
        """Judge against `rgb` from now on (the un-mirrored image): every kept render is
        scored again, every other score is dropped."""
        self.test = rgb
        self.target = _encoded(rgb, self.codes)
        assert self.regions is not None
        self.target_colour = self.regions.colour(self.target)
        self.scores = {c: self._score(im.rgb) for c, im in self.kept.items()}

    def evaluate(self, cands: Sequence[Candidate]) -> None:
        todo = [c for c in dict.fromkeys(cands) if c not in self.scores]
        if not todo:
            return

        def one(c: Candidate) -> tuple[Candidate, Image]:
            return c, self.render(c)

        with ThreadPoolExecutor(max_workers=max(1, self.parallel)) as pool:
            for c, im in pool.map(one, todo):
                self._check(c, im)
                self.scores[c] = self._score(im.rgb)
                if c in self.keep:
                    self.kept[c] = im

    def _check(self, c: Candidate, im: Image) -> None:
        if im.rgb.shape != self.image.rgb.shape:
            h, w = self.image.shape
            raise DiagnoseError(
                f"the renderer made {im.shape[1]}x{im.shape[0]} for {w}x{h} ({c.name})"
            )
        if self.regions is None:
            if "id" not in im.aovs or "depth" not in im.aovs:
                raise DiagnoseError(f"render of {c.name} has no id/depth AOVs")
            found = effect_masks(self.scene, im.aovs["id"], im.aovs["depth"])
            self.masks.update({k: v for k, v in found.items() if v.any()})
            self.regions = _Regions(self.masks)
            self.target_colour = self.regions.colour(self.target)
            first = exact_match(
                [im.rgb], self.test, self.image.encoding, model="", masks=self.masks
            )
            self.allowance = {k: e.allowed for k, e in first.per_effect.items()}

    def _score(self, rgb: F32) -> _Score:
        assert self.regions is not None and self.target_colour is not None
        levels = _levels(rgb, self.codes)
        enc = np.rint(levels).astype(np.int16)
        excess = _excess(enc, self.target)
        tone = np.maximum(
            np.abs(self.regions.colour(enc) - self.target_colour).max(axis=1) - 1.0, 0.0
        )
        off = _quick_differing(levels, self.target, rgb, self.test, self.image.encoding)
        names = self.regions.names
        share = self.regions.mean(off)
        return _Score(
            {
                k: round(float(v * n))
                for k, v, n in zip(names, share, self.regions.counts, strict=True)
            },
            dict(zip(names, share.tolist(), strict=True)),
            dict(zip(names, self.regions.mean(excess).tolist(), strict=True)),
            dict(zip(names, tone.tolist(), strict=True)),
            hashlib.blake2b(enc.tobytes(), digest_size=16).digest(),
        )

    def exact_of(self, c: Candidate) -> ExactMatch:
        """The verdict's own judging (exact_match.py) of the image against the candidate,
        rendered at pixel centres, with the camera turned by each of `turns` and its spheres
        grown by each of `grows`: the perturbed renders the verdict judges with."""
        if c not in self.exact_memo:
            centre = self.kept[c] if c in self.kept else self.render(c)
            perturbed = [c.turned(t) for t in self.turns] + [c.grown(g) for g in self.grows]
            turned = self.render_all(perturbed)
            self.exact_memo[c] = exact_match(
                [centre.rgb] + [im.rgb for im in turned],
                self.test,
                self.image.encoding,
                model=c.name,
                masks=self.masks,
            )
        return self.exact_memo[c]

    def exact_differing(self, c: Candidate) -> dict[str, int]:
        return {k: e.differing for k, e in self.exact_of(c).per_effect.items()}

    def best_fixed(self, begin: Candidate, effect: str) -> float:
        """The largest share of begin's differing pixels in `effect` that a candidate tried
        makes match (pixel-centre renders) without more pixels of the whole image differing
        than begin's: how near the search came."""
        d0 = self.differing(begin)[effect]
        if not d0:
            return 1.0
        limit = self.whole_differing(begin)
        return max(
            0.0,
            *(
                1 - sc.differing[effect] / d0
                for sc in self.scores.values()
                if sum(sc.differing.values()) <= limit
            ),
        )

    def per(self, c: Candidate) -> dict[str, float]:
        return self.scores[c].per_effect()

    def whole(self, c: Candidate) -> float:
        """The distance of the whole image: each effect weighted by its pixels."""
        assert self.regions is not None
        per = self.per(c)
        counts = self.regions.counts
        return float(sum(per[k] * n for k, n in zip(self.regions.names, counts, strict=True)))

    def whole_differing(self, c: Candidate) -> int:
        """Pixels of the whole image (every effect) that differ from the candidate."""
        return sum(self.scores[c].differing.values())

    def total_pixels(self) -> int:
        assert self.regions is not None
        return int(self.regions.counts.sum())

    def differing(self, c: Candidate) -> dict[str, int]:
        return self.scores[c].differing

    def allowed(self, effect: str) -> int:
        """Differing pixels an exact match allows in this effect (as exact_match says)."""
        return self.allowance[effect]

    def open_effects(self, c: Candidate) -> set[str]:
        """Effects with more pixels differing from the candidate's centre render than an exact
        match allows."""
        return {k for k, n in self.scores[c].differing.items() if n > self.allowed(k)}

    def matched(self, c: Candidate) -> bool:
        """Every effect within the exact-match allowance of the candidate's centre render."""
        return not self.open_effects(c)

    def fits_as_well(self, a: Candidate, b: Candidate) -> bool:
        """a leaves no more pixels of any effect differing than b, up to the exact-match
        allowance (both scored): the image cannot tell them apart."""
        da, db = self.differing(a), self.differing(b)
        return all(da[k] <= db[k] + self.allowed(k) for k in da)

    def render_all(self, cands: Sequence[Candidate]) -> list[Image]:
        """Renders that no score keeps (the turned renders of exact matching)."""
        with ThreadPoolExecutor(max_workers=max(1, self.parallel)) as pool:
            return list(pool.map(self.render, cands))

    def mirror_distances(self, cands: Sequence[Candidate]) -> dict[str, float]:
        """Per orientation ("" as is, and each of MIRRORS), the nearest candidate's distance."""
        encs = [_encoded(self.kept[c].rgb, self.codes) for c in cands]
        return {
            key: min(_mirror_distance(e, _flip_codes(self.target, key)) for e in encs)
            for key in ("", *MIRRORS)
        }


def _changes(c: Candidate, scene: Scene, quirks: Sequence[int], *, full: bool) -> list[Change]:
    """Every change of `c` to try; `full` adds the jumps in depth."""
    out = [Change("quirk", str(q), q not in c.quirks) for q in quirks]
    out += [Change("effect", e, e not in c.effects_off) for e in SWITCHABLE_EFFECTS]
    out += [Change("depth", str(d), d > _depth(c, scene)) for d in _depths(c, scene, full)]
    # Mistakes that another switch already renders (same_as) are found through that switch.
    out += [
        Change("mistake", m.name, m.name not in c.mistakes)
        for m in catalogue().values()
        if m.same_as is None
    ]
    return out + _constant_changes(c, scene)


def _depths(c: Candidate, scene: Scene, full: bool) -> list[int]:
    """One level up and down; in a full sweep also jumps of 2, 4, 8, ... each way and the
    deepest searched, so that `MAX_RAY_DEPTH 10` in a depth-5 scene is one step."""
    d = _depth(c, scene)
    steps = [1, 2, 4, 8] if full else [1]
    out = {d + s for s in steps} | {d - s for s in steps}
    if full:
        out.add(MAX_SEARCH_DEPTH)
    return sorted(x for x in out if 0 <= x <= MAX_SEARCH_DEPTH and x != d)


def _constant_changes(c: Candidate, scene: Scene) -> list[Change]:
    out = []
    for rgb in BACKGROUNDS:
        if rgb != tuple(scene.background) and rgb != c.background:
            out.append(Change("background", ",".join(f"{v:g}" for v in rgb), True))
    if c.background is not None:
        out.append(Change("background", "scene", False))
    theirs = _glass_iors(scene)
    if theirs:
        out += [Change("ior", f"{v:g}", True) for v in IORS if {v} != theirs and v != c.ior]
        if c.ior is not None:
            out.append(Change("ior", "scene", False))
    return out


def _aliases(c: Candidate, scene: Scene) -> list[str]:
    """Named mistakes that the candidate's switches amount to (catalogue `same_as`)."""
    out = []
    depth = _depth(c, scene)
    for m in catalogue().values():
        if (
            (m.same_as == "+Q5" and 5 in c.quirks and 5 not in MODE_QUIRKS[c.mode])
            or (m.same_as == "--no-shadows" and "shadows" in c.effects_off)
            or (m.same_as == "--max-depth N-1" and depth == scene.max_depth - 1)
        ):
            out.append(m.name)
    return out


def diagnose(
    image: Image,
    scene: Scene,
    render: Renderer,
    *,
    start: TargetModel | Candidate | None = None,
    progress: Callable[[str], None] | None = None,
    parallel: int = 1,
    max_renders: int = MAX_RENDERS,
    turns: Sequence[tuple[float, float]] | None = None,
    search_quirks: Sequence[int] | None = None,
) -> Diagnosis:
    """The nearest demo candidate to `image` (linear RGB as read by images.read_image) and
    the evidence per effect. `render` must return the candidate at the image's size with the
    id and depth AOVs (the first render's give the effect masks). With `start`, the search
    begins there instead of at the nearest of the three modes. `parallel` renders run at once
    (render must then be thread-safe). `turns` are the camera turns (in pixels) exact matching
    renders a model with, and `search_quirks` the quirks the renderer can toggle: both default
    to the renderer's attributes of those names (CandidateRenderer has them), else to none and
    SEARCH_QUIRKS. When the changes that helped stop helping and some effect is still not
    reproduced, every change is tried once more (while fewer than `max_renders` renders were
    made). Nothing depends on time, so a loaded machine gives the same diagnosis, later."""
    t0 = time.perf_counter()
    say = progress or (lambda _m: None)
    turns = list(turns if turns is not None else getattr(render, "turns", ()))
    quirks = tuple(
        search_quirks
        if search_quirks is not None
        else getattr(render, "search_quirks", SEARCH_QUIRKS)
    )
    s = _Search(image, scene, render, parallel, turns, list(getattr(render, "grows", ())))
    starts = (
        [start if isinstance(start, Candidate) else Candidate.from_model(start)]
        if start is not None
        else [Candidate.of_mode(m) for m in ("classic", "paper", "physical")]
    )
    mirrored, begin = _begin(s, starts, say)
    modes = {c.name: float(s.whole_differing(c)) for c in starts}
    found = _explain(s, begin, quirks, max_renders, t0, say)
    findings, summary = _report(s, found.begin, found.result, found.steps, mirrored, say)
    seconds = time.perf_counter() - t0
    say(f"diagnose: {found.result.name} after {len(s.scores)} renders in {seconds:.1f} s")
    return _diagnosis(s, found, findings, summary, mirrored, modes, seconds)


def _begin(
    s: _Search, starts: list[Candidate], say: Callable[[str], None]
) -> tuple[str, Candidate]:
    """Renders the starts (each also with the tone mistakes), decides whether the image is
    mirrored (judging the un-mirrored image from then on) and picks the nearest start."""
    toned = [c.with_mistake(m, True) for c in starts for m in TONE_MISTAKES]
    say(
        f"diagnose: rendering {', '.join(c.name for c in starts)} "
        f"(and with {', '.join(TONE_MISTAKES)})"
    )
    s.keep.update(starts + toned)
    s.evaluate(starts + toned)
    mirrored = _mirrored(s, starts + toned, say)
    begin = _nearest(s, starts, say)
    s.kept = {c: im for c, im in s.kept.items() if c == begin}
    s.keep = {begin}
    return mirrored, begin


@dataclass(frozen=True)
class _Found:
    begin: Candidate  # the mode the result is told from
    result: Candidate
    steps: list[Step]
    invisible: set[int]
    untested: set[int]
    or_more: bool  # the result's depth: every deeper limit fits as well


def _explain(
    s: _Search,
    begin: Candidate,
    quirks: Sequence[int],
    max_renders: int,
    t0: float,
    say: Callable[[str], None],
) -> _Found:
    """The search, then the result without what explains nothing, retold from the mode it
    differs least from in the quirks the scene shows."""
    current = _shallowest(s, _greedy(s, begin, quirks, max_renders, t0, say))
    # Changes that explain nothing go first, so that they cannot decide the mode below.
    current, _ = _justified(s, begin, current, say, False)
    invisible = _invisible(s, current, quirks)
    untested = set(range(1, QUIRK_COUNT + 1)) - set(quirks) - {10}
    simpler = _simplest(current, invisible | untested)
    if simpler.mode != begin.mode:
        say(f"diagnose: {current.name} is {simpler.name} here; retelling the steps from it")
        begin = Candidate.of_mode(simpler.mode)
        s.evaluate([begin])
    or_more = _depth_or_more(s, simpler)
    current, steps = _justified(s, begin, simpler, say, or_more)
    or_more = or_more and _depth(current, s.scene) == _depth(simpler, s.scene)
    return _Found(begin, current, steps, invisible, untested, or_more)


def _diagnosis(
    s: _Search,
    found: _Found,
    findings: dict[str, EffectFinding],
    summary: str,
    mirrored: str,
    modes: dict[str, float],
    seconds: float,
) -> Diagnosis:
    c, scene = found.result, s.scene
    hidden = found.invisible | found.untested
    sentences = [summary] + [f.sentence for f in findings.values()]
    if found.invisible:
        sentences.append(
            "not visible in this scene (toggling them changes no pixel): "
            + ", ".join(f"Q{q}" for q in sorted(found.invisible))
        )
    if found.untested:
        sentences.append(
            "not searched (this rtdemo cannot render them): "
            + ", ".join(f"Q{q}" for q in sorted(found.untested))
        )
    return Diagnosis(
        scene=scene.name,
        image=s.image.path,
        start=found.begin.name,
        mode_objectives=modes,
        result=c.name,
        rtdemo_args=c.rtdemo_args(),
        scene_changes=c.scene_changes(),
        mirrored=mirrored,
        mode=c.mode,
        quirks_present=sorted(set(c.quirks) - hidden),
        quirks_absent=sorted(set(range(1, QUIRK_COUNT + 1)) - c.quirks - hidden),
        quirks_invisible=sorted(found.invisible),
        quirks_untested=sorted(found.untested),
        effects_off=[e for e in SWITCHABLE_EFFECTS if e in c.effects_off],
        max_depth=_depth(c, scene),
        depth_or_more=found.or_more,
        mistakes=(["mirrored"] if mirrored else []) + c.ordered_mistakes() + _aliases(c, scene),
        steps=found.steps,
        effects=findings,
        unexplained=[k for k, f in findings.items() if f.state == "unexplained"],
        matches=all(f.matched for f in findings.values()),
        summary=summary,
        sentences=sentences,
        renders=len(s.scores),
        seconds=seconds,
        candidate=c,
    )


def _mirrored(s: _Search, cands: list[Candidate], say: Callable[[str], None]) -> str:
    """ "" or the MIRRORS word for the flip that fits the nearest candidate far better than
    the image as it is; the search then judges the un-mirrored image."""
    dist = s.mirror_distances(cands)
    key = min(MIRRORS, key=lambda k: dist[k])
    if not (dist[key] <= MIRROR_RATIO * dist[""] and dist[""] - dist[key] >= MIRROR_MIN):
        return ""
    say(
        f"diagnose: the image is mirrored {MIRRORS[key]} (distance {dist['']:.3f} as it is, "
        f"{dist[key]:.3f} un-mirrored); diagnosing the un-mirrored image"
    )
    s.set_test(unmirror(s.image.rgb, key))
    return MIRRORS[key]


def _nearest(s: _Search, starts: list[Candidate], say: Callable[[str], None]) -> Candidate:
    """The start whose pixels match the image most often, over the whole image: a program
    with one wrong effect is placed by the effects it gets right, not by how near another
    mode comes in the wrong one. Where no start matches MODE_MATCH_MIN of the pixels (every
    tone is off), the one whose pixels are least far off. Each mode counts as near as its
    best with a tone mistake; the search starts from the plain mode, so that the mistake is
    found (and named) as a step of its own."""

    def best(c: Candidate) -> Candidate:
        return min([c, *(c.with_mistake(m, True) for m in TONE_MISTAKES)], key=s.whole_differing)

    total = s.total_pixels()
    by_count = min(s.whole_differing(best(c)) for c in starts) < (1 - MODE_MATCH_MIN) * total
    key = (lambda c: s.whole_differing(best(c))) if by_count else (lambda c: s.whole(best(c)))
    nearest = min(starts, key=key)
    say(
        f"diagnose: nearest mode {nearest.name} ("
        + ", ".join(f"{c.name} {s.whole_differing(best(c)):,}" for c in starts)
        + f" of {total:,} px differ"
        + ("" if by_count else "; none matches, the nearest by how far pixels are off")
        + ")"
    )
    return nearest


def _greedy(
    s: _Search,
    current: Candidate,
    quirks: Sequence[int],
    max_renders: int,
    t0: float,
    say: Callable[[str], None],
) -> Candidate:
    """One change at a time; later rounds retry only the changes that helped (and the depth
    one up or down), a full sweep again only while some effect is still not reproduced."""
    promising: set[tuple[str, str]] | None = None  # None: try every change this round
    for round_no in range(1, 41):
        full = promising is None
        tried = [
            ch
            for ch in _changes(current, s.scene, quirks, full=full)
            if promising is None or (ch.kind, ch.key) in promising or ch.kind == "depth"
        ]
        cands = [ch.apply(current, s.scene) for ch in tried]
        s.evaluate(cands)
        base, still = s.per(current), s.open_effects(current)
        # Only a change that clearly explains some effect counts: small drops spread over
        # every effect are noise fitting (e.g. acne patterns that float rounding decides).
        gains = [
            _objective(base) - _objective(s.per(c)) if _explained(base, s.per(c), still) else 0.0
            for c in cands
        ]
        if full:
            promising = {
                (ch.kind, ch.key) for ch, g in zip(tried, gains, strict=True) if g > MIN_GAIN
            }
        say(
            f"diagnose: round {round_no}: {len(tried)} changes of {current.name}, "
            f"{sum(g > MIN_GAIN for g in gains)} help ({len(s.scores)} renders, "
            f"{time.perf_counter() - t0:.1f} s)"
        )
        best = int(np.argmax(gains)) if gains else -1
        if best < 0 or gains[best] <= MIN_GAIN:
            # Nothing left to explain: every effect matches (within the allowance, the camera
            # turned as exact matching turns it: edge pixels of float64 programs need that).
            if full or len(s.scores) >= max_renders or s.matched(current):
                break
            if s.exact_of(current).passed:
                break
            promising = None  # stuck with the changes that helped: one full sweep
            continue
        say(
            f"diagnose: keep {tried[best].label(current, s.scene)}: "
            f"{_objective(base):.3f} -> {_objective(s.per(cands[best])):.3f}"
        )
        current = cands[best]
    return current


def _shallowest(s: _Search, c: Candidate) -> Candidate:
    """The smallest recursion limit above the scene's that fits as well as c's: limits past
    the deepest chain the image shows give the same pixels, and the search may have jumped
    past it. Bisection, assuming a deeper limit never fits worse once it fits."""
    lo, hi = s.scene.max_depth, _depth(c, s.scene)
    if hi <= lo + 1:
        return c

    def at(d: int) -> Candidate:
        return c.with_depth(None if d == s.scene.max_depth else d)

    while hi - lo > 1:
        mid = (lo + hi) // 2
        s.evaluate([at(mid)])
        lo, hi = (lo, mid) if s.fits_as_well(at(mid), c) else (mid, hi)
    return at(hi)


def _depth_or_more(s: _Search, c: Candidate) -> bool:
    """Whether the deepest limit searched fits as well as c's (the image then tells only "at
    least this deep")."""
    if _depth(c, s.scene) <= s.scene.max_depth:
        return False
    deepest = c.with_depth(MAX_SEARCH_DEPTH)
    s.evaluate([deepest])
    return s.fits_as_well(deepest, c)


def _invisible(s: _Search, c: Candidate, quirks: Sequence[int]) -> set[int]:
    """Quirks whose toggle leaves c's pixels unchanged: this scene cannot tell them (and Q10:
    every candidate is one ray per pixel, where it changes nothing)."""
    toggles = {q: c.with_quirk(q, q not in c.quirks) for q in quirks}
    s.evaluate(list(toggles.values()))
    out = {q for q, t in toggles.items() if s.scores[t].digest == s.scores[c].digest}
    return out | {10}


def _differences(a: Candidate, b: Candidate, scene: Scene) -> list[Change]:
    """The one-at-a-time changes that turn candidate a into b."""
    out = [Change("quirk", str(q), q in b.quirks) for q in sorted(a.quirks ^ b.quirks)]
    out += [
        Change("effect", e, e in b.effects_off)
        for e in SWITCHABLE_EFFECTS
        if (e in a.effects_off) != (e in b.effects_off)
    ]
    if _depth(a, scene) != _depth(b, scene):
        out.append(Change("depth", str(_depth(b, scene)), _depth(b, scene) > _depth(a, scene)))
    out += [Change("mistake", m, m in b.mistakes) for m in sorted(a.mistakes ^ b.mistakes)]
    if a.background != b.background:
        rgb = b.background or a.background
        assert rgb is not None
        out.append(Change("background", ",".join(f"{v:g}" for v in rgb), b.background is not None))
    if a.ior != b.ior:
        out.append(Change("ior", f"{b.ior or a.ior:g}", b.ior is not None))
    return out


def _simplest(c: Candidate, invisible: set[int]) -> Candidate:
    """The same candidate written from the mode it differs least from, counting only quirks
    that change pixels (paper-Q2 --no-shadows is classic --no-shadows when Q4 and Q9 are
    invisible)."""
    best, best_count = c, len(c.quirks ^ MODE_QUIRKS[c.mode])
    for mode in ("classic", "paper", "physical"):
        quirks = (c.quirks - invisible) | (MODE_QUIRKS[mode] & invisible)
        count = len(quirks ^ MODE_QUIRKS[mode])
        if count < best_count:
            best = Candidate(
                mode,
                frozenset(quirks),
                c.effects_off,
                c.max_depth,
                c.mistakes,
                c.background,
                c.ior,
            )
            best_count = count
    return best


def _retell(s: _Search, begin: Candidate, final: Candidate) -> list[tuple[Change, Candidate]]:
    """The changes from begin to final, each in the order that helps most, with the candidate
    after each."""
    remaining = _differences(begin, final, s.scene)
    out, cur = [], begin
    while remaining:
        options = [ch.apply(cur, s.scene) for ch in remaining]
        s.evaluate(options)
        i = min(range(len(options)), key=lambda j: _objective(s.per(options[j])))
        out.append((remaining[i], options[i]))
        cur = options[i]
        del remaining[i]
    return out


def _gained(s: _Search, begin: Candidate, final: Candidate) -> set[str]:
    """Effects the final makes at least EXPLAINED_SHARE of the start's differing pixels match
    (judged exactly, with the turned renders: acne that float rounding decides matches only
    within the model's own spread)."""
    d0, d1 = s.exact_differing(begin), s.exact_differing(final)
    return {k for k in d0 if d0[k] > 0 and d0[k] - d1[k] >= EXPLAINED_SHARE * d0[k]}


def _same_switch(a: Change, b: Change) -> bool:
    """Whether two changes set the same thing (a depth, a background, an ior, or one quirk,
    effect or mistake), whatever value each sets it to."""
    return a.kind == b.kind and (a.key == b.key or a.kind in ("depth", "background", "ior"))


def _needed_by(s: _Search, begin: Candidate, final: Candidate, ch: Change) -> set[str]:
    """Effects whose matching pixels undoing `ch` would lose: more than the exact-match
    allowance and a tenth of what the final gained over the start."""
    inverse = next(u for u in _differences(final, begin, s.scene) if _same_switch(u, ch))
    without = inverse.apply(final, s.scene)
    d0, d1 = s.exact_differing(begin), s.exact_differing(final)
    dw = s.exact_differing(without)
    return {k for k in d1 if dw[k] - d1[k] > max(s.allowed(k), 0.1 * max(0, d0[k] - d1[k]))}


def _justified(
    s: _Search, begin: Candidate, final: Candidate, say: Callable[[str], None], or_more: bool
) -> tuple[Candidate, list[Step]]:
    """The final without every change that makes no explained effect's pixels match, and its
    steps from begin: a mistake is named only where it explains pixels."""
    while True:
        s.evaluate([final])
        gained = _gained(s, begin, final)
        path = _retell(s, begin, final)
        needs = {ch: _needed_by(s, begin, final, ch) & gained for ch, _ in path}
        idle = [ch for ch, eff in needs.items() if not eff]
        if not idle:
            break
        for ch in idle:
            say(f"diagnose: drop {ch.label(final, s.scene)}: it makes no effect's pixels match")
        final = _without(final, begin, idle, s.scene)
    steps, cur = [], begin
    for ch, after in path:
        steps.append(
            Step(
                ch.label(cur, s.scene, or_more=or_more),
                ch.short(cur, s.scene, or_more=or_more),
                after.name,
                s.per(cur),
                s.per(after),
                tuple(k for k in s.masks if k in needs[ch]),
            )
        )
        cur = after
    return final, steps


def _without(final: Candidate, begin: Candidate, drop: list[Change], scene: Scene) -> Candidate:
    """final with the dropped changes undone (each set back to begin's value)."""
    out = final
    for u in _differences(final, begin, scene):
        if any(_same_switch(u, d) for d in drop):
            out = u.apply(out, scene)
    return out


def _report(
    s: _Search,
    begin: Candidate,
    final: Candidate,
    steps: list[Step],
    mirrored: str,
    say: Callable[[str], None],
) -> tuple[dict[str, EffectFinding], str]:
    """Per effect: the exact match of the start and of the result, as the verdict judges a
    model (each rendered also with the camera turned), FLIP before and after, and the words."""
    say("diagnose: exact match and FLIP per effect for the start and the result")
    both = list(dict.fromkeys((begin, final)))
    ims = {c: s.kept[c] if c in s.kept else s.render(c) for c in both}
    s.kept.update(ims)
    exact = {c: s.exact_of(c) for c in both}
    # FLIP alone (the judge's map, metrics.py), not evaluate_pair's SSIM and other maps.
    flip = {c: flip_ldr_map(ims[c].rgb, s.test) for c in both}
    findings = {}
    for k in EFFECTS:
        if k not in s.masks:
            continue
        e0, e1 = exact[begin].per_effect[k], exact[final].per_effect[k]
        # An effect no single step is needed for, but that the result fixes, is the steps'
        # work together.
        by = tuple(st.change for st in steps if k in st.explains) or tuple(
            st.change for st in steps
        )
        f0 = float(flip[begin][s.masks[k]].mean())
        f1 = float(flip[final][s.masks[k]].mean())
        fixed = e0.differing - e1.differing >= EXPLAINED_SHARE * e0.differing > 0
        near = (len(s.scores), s.best_fixed(begin, k))
        if e1.passed:
            state = "as start" if e0.passed else "explained"
        else:
            state = "partly explained" if fixed and steps else "unexplained"
        findings[k] = EffectFinding(
            k,
            e1.pixels,
            f0,
            f1,
            s.scores[begin].pixels[k],
            s.scores[final].pixels[k],
            e0.differing,
            e1.differing,
            e1.allowed,
            near[1],
            by if state in ("explained", "partly explained") else (),
            e1.passed,
            state,
            _sentence(k, state, by, begin, exact[final], e0.differing, (f0, f1), near),
        )
    return findings, _summary(begin, steps, findings, exact[begin], mirrored)


def _sentence(
    k: str,
    state: str,
    by: tuple[str, ...],
    begin: Candidate,
    final: ExactMatch,
    start_differing: int,
    flips: tuple[float, float],
    near: tuple[int, float],
) -> str:
    """One effect's finding; `near`: (candidates tried, the best share of begin's differing
    pixels one of them matches)."""
    f0, f1 = flips
    if state == "as start":
        return f"{k}: as {begin.name} (FLIP {f1:.3f})"
    if state == "unexplained" and start_differing <= final.per_effect[k].allowed:
        return (
            f"{k}: matches {begin.name}, but {final.sentence(k)}: the changes that explain the "
            "other effects cost it"
        )
    if state == "explained":
        return (
            f"{k}: explained by {' and '.join(by)}: {start_differing:,} px differed from "
            f"{begin.name}, the result matches; FLIP {f0:.3f} -> {f1:.3f}"
        )
    if state == "partly explained":
        return (
            f"{k}: partly explained by {' and '.join(by)}: {final.sentence(k)} "
            f"({start_differing:,} from {begin.name}); FLIP {f0:.3f} -> {f1:.3f}"
        )
    if near[1] < EXPLAINED_SHARE:
        nearest = (
            f"the nearest of the {near[0]} candidates tried makes {near[1]:.0%} of them match "
            f"({EXPLAINED_SHARE:.0%} would explain it)"
        )
    else:  # e.g. silhouettes that another bug happens to share, at the cost of the rest
        nearest = (
            f"a candidate that makes {near[1]:.0%} of them match leaves the rest of the image "
            "further off"
        )
    return (
        f"{k}: not explained: {final.sentence(k)}; FLIP {f1:.3f}; {nearest}: a new bug, not a "
        "quirk or a named mistake"
    )


def _summary(
    begin: Candidate,
    steps: list[Step],
    findings: dict[str, EffectFinding],
    start: ExactMatch,
    mirrored: str,
) -> str:
    head = f"mirrored {mirrored} (diagnosed un-mirrored); " if mirrored else ""
    off = [k for k in findings if not start.per_effect[k].passed]
    unexplained = [k for k, f in findings.items() if f.state == "unexplained"]
    parts = []
    for st in steps:
        nums = ", ".join(
            f"{k} FLIP {findings[k].start_flip:.3f} -> {findings[k].final_flip:.3f}"
            for k in st.explains
            if k in findings
        )
        parts.append(f"explained by {st.change}" + (f": {nums}" if nums else ""))
    if not off:
        text = f"matches {begin.name} in every effect (exact match)"
    elif len(off) == len(findings):
        text = f"nearest to {begin.name}, which no effect matches"
    else:
        text = f"matches {begin.name} except {', '.join(off)}"
    text += "".join(f"; {p}" for p in parts)
    partly = [k for k, f in findings.items() if f.state == "partly explained"]
    if partly:
        text += "; still differing: " + ", ".join(
            f"{k} {findings[k].final_differing:,} px" for k in partly
        )
    if unexplained:
        text += (
            "; not explained: "
            + ", ".join(
                f"{k} ({findings[k].final_differing:,} px, "
                f"{findings[k].final_differing / findings[k].pixels:.0%})"
                for k in unexplained
            )
            + ": a new bug, not a quirk or a named mistake"
        )
    return head + text
