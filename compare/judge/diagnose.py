"""Explains a foreign image as the nearest demo model: which mode, which quirks present or
absent, which effects switched off, which recursion depth and which named mistakes
(mistakes.json) reproduce it, effect by effect.

The search renders candidates through an injected `render` (this module starts no process)
and compares them with a cheap distance: per effect region, the mean number of 8-bit levels
by which a pixel differs beyond one level (so a truncating and a rounding writer of the same
values are at distance 0), plus how far the region's mean colour is off. It starts from the
nearest of the three modes, tries one change at a time (a quirk toggled, an effect off, the
depth one up or down, a mistake added or removed), keeps the change that lowers the summed
per-effect distance most and clearly explains some effect, and repeats with the changes that
helped, instead of all 2^10 quirk combinations. The result is retold from the mode it differs
least from in the quirks this scene shows. FLIP (evaluate_pair) is computed only for the
start and the result, for the report's numbers.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from compare.judge.candidate import SWITCHABLE_EFFECTS, Candidate
from compare.judge.effects import BOOL, EFFECTS, effect_masks
from compare.judge.evaluate import evaluate_pair
from compare.judge.images import F32, Image, linear_to_srgb
from compare.judge.mistakes import catalogue
from compare.judge.quirks import QUIRKS
from compare.judge.target_model import MODE_QUIRKS, TargetModel
from scene_model.scene import Scene

Renderer = Callable[[TargetModel | Candidate], Image]

# An effect region is reproduced when its mean excess is at most MATCH_MEAN levels and at most
# MATCH_SHARE of its pixels are off by more than OFF_LEVELS levels. Silhouettes hold the pixels
# where a pixel-centre ray grazes a sphere, so float32 and float64 programs disagree there more.
MATCH_MEAN = 0.05
OFF_LEVELS = 3.0
MATCH_SHARE = 0.005
MATCH_SHARE_EDGES = 0.05
# A change is kept when it lowers the objective (summed per-effect mean excess) by this much;
# an effect is explained by a change that lowers its own distance by EXPLAINS (and 10 %).
MIN_GAIN = 1e-3
EXPLAINS = 0.02
MAX_RENDERS = 200  # no new full sweep of every change starts beyond this many renders
# Mistakes that move every pixel's tone: the nearest mode is chosen with and without them, so
# that a gamma-encoded paper image is not taken for physical mode (it starts from paper).
TONE_MISTAKES = ("double_gamma",)
SEARCH_QUIRKS = tuple(range(1, 10))  # Q10 only matters with --spp > 1


class DiagnoseError(ValueError):
    """The image cannot be diagnosed against this scene (e.g. a renderer without AOVs)."""


@dataclass(frozen=True)
class Change:
    """One switch tried on top of a candidate."""

    kind: str  # "quirk" | "effect" | "depth" | "mistake"
    key: str  # "2" | "shadows" | "+1" | "no_offset"
    present: bool  # quirk/mistake added, effect switched off, depth raised

    def apply(self, c: Candidate, scene: Scene) -> Candidate:
        if self.kind == "quirk":
            return c.with_quirk(int(self.key), self.present)
        if self.kind == "effect":
            return c.with_effect(self.key, not self.present)
        if self.kind == "mistake":
            return c.with_mistake(self.key, self.present)
        depth = scene.max_depth if c.max_depth is None else c.max_depth
        new = depth + (1 if self.present else -1)
        return c.with_depth(None if new == scene.max_depth else new)

    def short(self, c: Candidate, scene: Scene) -> str:
        """The change in a word or two, for a gradebook column ("looks like +Q2")."""
        sign = "" if self.present else "-"
        if self.kind == "quirk":
            return f"{'+' if self.present else '-'}Q{self.key}"
        if self.kind == "effect":
            return f"--no-{self.key}" if self.present else f"+{self.key}"
        if self.kind == "depth":
            d = self.apply(c, scene).max_depth
            return f"max depth {scene.max_depth if d is None else d}"
        return f"{sign}{self.key}"

    def label(self, c: Candidate, scene: Scene) -> str:
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
            d = self.apply(c, scene).max_depth
            d = scene.max_depth if d is None else d
            cut = " (the mistake depth_cut)" if d == scene.max_depth - 1 else ""
            return f"max depth {d}{cut} (the scene asks {scene.max_depth})"
        m = catalogue()[self.key]
        return (
            f"the mistake {m.name} ({m.explanation})"
            if self.present
            else (f"without the mistake {m.name}")
        )


@dataclass(frozen=True)
class Step:
    """A change the search kept, with the cheap distance per effect before and after."""

    change: str  # Change.label
    cause: str  # Change.short: "+Q2", "-Q8", "--no-shadows", "max depth 4", "no_offset"
    candidate: str  # the candidate after it
    before: dict[str, float]
    after: dict[str, float]
    explains: tuple[str, ...]  # effects whose distance it lowered clearly


@dataclass(frozen=True)
class EffectFinding:
    effect: str
    pixels: int
    start_flip: float  # FLIP of the image against the start mode in this effect's pixels
    final_flip: float  # ... against the diagnosis
    start_distance: float  # mean 8-bit levels beyond one
    final_distance: float
    off_share: float  # share of the effect's pixels off by more than OFF_LEVELS after all
    explained_by: tuple[str, ...]  # labels of the steps that explain it
    matched: bool  # the result reproduces it (within the MATCH_* limits)
    state: str  # "as start" | "explained" | "partly explained" | "unexplained"
    sentence: str


@dataclass
class Diagnosis:
    scene: str
    image: str
    start: str  # the nearest mode's candidate name
    mode_objectives: dict[str, float]  # each mode tried: summed per-effect distance
    result: str  # the diagnosis' candidate name
    rtdemo_args: list[str]  # the rtdemo options that render it
    mode: str
    quirks_present: list[int]
    quirks_absent: list[int]
    quirks_invisible: list[int]  # toggling them changed no pixel: this scene cannot tell
    effects_off: list[str]
    max_depth: int
    mistakes: list[str]
    steps: list[Step]
    effects: dict[str, EffectFinding]
    unexplained: list[str]
    summary: str
    sentences: list[str]
    renders: int
    seconds: float
    candidate: Candidate = field(repr=False)

    @property
    def exact(self) -> bool:
        return not self.unexplained

    @property
    def causes(self) -> list[str]:
        """What differs from the start mode, shortly: ["+Q2"], ["no_offset"], []."""
        return [s.cause for s in self.steps]

    def reason(self) -> str:
        """One line for a gradebook: "looks like classic+Q2 (+Q2)", with the regions that
        nothing explains."""
        text = f"looks like {self.result}"
        if self.causes:
            text += f" ({', '.join(self.causes)})"
        if self.unexplained:
            text += f"; unexplained: {', '.join(self.unexplained)}"
        return text

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("candidate")
        d["causes"] = self.causes
        d["reason"] = self.reason()
        return d


I16 = NDArray[np.int16]


def _encoded(rgb: F32, encoding: str) -> I16:
    """Values in whole 8-bit levels in the image's own encoding: linear for a PPM read as
    linear, display (sRGB) otherwise. NaN counts as 0, as the paper's PPM writer stores it.
    Rounding a candidate moves it by at most half a level, which the one level that `excess`
    forgives covers (a truncating writer is at most one level below)."""
    if encoding == "linear":
        c = np.clip(np.nan_to_num(rgb, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    else:
        c = linear_to_srgb(np.nan_to_num(rgb, nan=0.0, posinf=1.0))
    out: I16 = np.rint(c * 255.0).astype(np.int16)
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

    pixels: dict[str, float]  # mean levels beyond one
    tone: dict[str, float]  # how far the mean colour is off, levels beyond one
    off: dict[str, float]  # share of pixels off by more than OFF_LEVELS
    digest: bytes  # of the encoded candidate: equal digests, equal images

    def per_effect(self) -> dict[str, float]:
        # The tone term: where float rounding decides each pixel (acne), two programs with the
        # same mistake differ pixel by pixel but agree on average, so the mistake still
        # explains its region.
        return {k: self.pixels[k] + self.tone[k] for k in self.pixels}


def _score(enc: I16, target: I16, regions: _Regions, target_colour: NDArray[np.float64]) -> _Score:
    excess = np.maximum(np.abs(enc - target).max(axis=2), 1) - 1
    tone = np.maximum(np.abs(regions.colour(enc) - target_colour).max(axis=1) - 1.0, 0.0)
    names = regions.names
    return _Score(
        dict(zip(names, regions.mean(excess).tolist(), strict=True)),
        dict(zip(names, tone.tolist(), strict=True)),
        dict(zip(names, regions.mean(excess > OFF_LEVELS).tolist(), strict=True)),
        hashlib.blake2b(enc.tobytes(), digest_size=16).digest(),
    )


def _objective(per: dict[str, float]) -> float:
    return float(sum(per.values()))  # every effect counts alike, whatever its size


def _matched(effect: str, mean: float, share: float) -> bool:
    limit = MATCH_SHARE_EDGES if effect == "edges" else MATCH_SHARE
    return mean <= MATCH_MEAN and share <= limit


def _explained(before: dict[str, float], after: dict[str, float]) -> tuple[str, ...]:
    """The effects whose distance a change lowers clearly (by EXPLAINS levels and 10 %)."""
    return tuple(k for k in before if before[k] - after[k] > max(EXPLAINS, 0.1 * before[k]))


def _changes(c: Candidate, scene: Scene) -> list[Change]:
    out = [Change("quirk", str(q), q not in c.quirks) for q in SEARCH_QUIRKS]
    out += [Change("effect", e, e not in c.effects_off) for e in SWITCHABLE_EFFECTS]
    depth = scene.max_depth if c.max_depth is None else c.max_depth
    if depth > 0:
        out.append(Change("depth", "-1", False))
    if depth < 64:
        out.append(Change("depth", "+1", True))
    # Mistakes that another switch already renders (same_as) are found through that switch.
    out += [
        Change("mistake", m.name, m.name not in c.mistakes)
        for m in catalogue().values()
        if m.same_as is None
    ]
    return out


def _aliases(c: Candidate, scene: Scene) -> list[str]:
    """Named mistakes that the candidate's switches amount to (catalogue `same_as`)."""
    out = []
    depth = scene.max_depth if c.max_depth is None else c.max_depth
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
) -> Diagnosis:
    """The nearest demo candidate to `image` (linear RGB as read by images.read_image) and
    the evidence per effect. `render` must return the candidate at the image's size with the
    id and depth AOVs (the first render's give the effect masks). With `start`, the search
    begins there instead of at the nearest of the three modes. `parallel` renders run at once
    (render must then be thread-safe). When the changes that helped stop helping and some
    effect is still not reproduced, every change is tried once more (while fewer than
    `max_renders` renders were made); the search ends when that finds nothing either. Nothing depends on time, so a loaded machine gives
    the same diagnosis, later."""
    t0 = time.perf_counter()
    say = progress or (lambda _m: None)
    target = _encoded(image.rgb, image.encoding)
    encoding = "linear" if image.encoding == "linear" else "srgb"
    score_of: dict[Candidate, _Score] = {}
    # Renders kept for the FLIP numbers: the modes (one becomes the start). A 640x480 render
    # with AOVs is 10 MB, so the search keeps none; the result is rendered once more.
    kept: dict[Candidate, Image] = {}
    keep: set[Candidate] = set()
    masks: dict[str, BOOL] = {}
    regions: list[_Regions] = []  # one, once the first render gives the masks
    target_colour: list[NDArray[np.float64]] = []

    def evaluate(cands: list[Candidate]) -> None:
        todo = [c for c in dict.fromkeys(cands) if c not in score_of]
        if not todo:
            return

        def one(c: Candidate) -> tuple[Candidate, Image]:
            return c, render(c)

        with ThreadPoolExecutor(max_workers=max(1, parallel)) as pool:
            for c, im in pool.map(one, todo):
                if im.rgb.shape != image.rgb.shape:
                    raise DiagnoseError(
                        f"the renderer made {im.shape[1]}x{im.shape[0]} for "
                        f"{image.shape[1]}x{image.shape[0]} ({c.name})"
                    )
                if not regions:
                    if "id" not in im.aovs or "depth" not in im.aovs:
                        raise DiagnoseError(f"render of {c.name} has no id/depth AOVs")
                    found = effect_masks(scene, im.aovs["id"], im.aovs["depth"])
                    masks.update({k: v for k, v in found.items() if v.any()})
                    regions.append(_Regions(masks))
                    target_colour.append(regions[0].colour(target))
                score_of[c] = _score(
                    _encoded(im.rgb, encoding), target, regions[0], target_colour[0]
                )
                if c in keep:
                    kept[c] = im

    def per(c: Candidate) -> dict[str, float]:
        return score_of[c].per_effect()

    # 1. The nearest mode (or the given start).
    if start is not None:
        first = start if isinstance(start, Candidate) else Candidate.from_model(start)
        starts = [first]
    else:
        starts = [Candidate.of_mode(m) for m in ("classic", "paper", "physical")]
    toned = [c.with_mistake(m, True) for c in starts for m in TONE_MISTAKES]
    say(
        f"diagnose: rendering {', '.join(c.name for c in starts)} (and with {', '.join(TONE_MISTAKES)})"
    )
    keep.update(starts)
    evaluate(starts + toned)
    mode_objectives = {c.name: _objective(per(c)) for c in starts}
    # Each mode counts as near as its best with a tone mistake; the search starts from the
    # plain mode, so that the mistake is found (and named) as a step of its own.
    nearest = {
        c: min(_objective(per(x)) for x in [c, *(c.with_mistake(m, True) for m in TONE_MISTAKES)])
        for c in starts
    }
    current = min(starts, key=lambda c: nearest[c])
    begin = current
    say(
        "diagnose: nearest mode "
        + current.name
        + " ("
        + ", ".join(f"{k} {v:.3f}" for k, v in mode_objectives.items())
        + " levels beyond one, summed over effects)"
    )

    for c in [c for c in kept if c != current]:
        del kept[c]
    # 2. Greedy: one change at a time; later rounds retry only the changes that helped.
    steps: list[Step] = []
    promising: set[tuple[str, str]] | None = None  # None: try every change this round
    round_no = 0
    while True:
        round_no += 1
        full = promising is None
        all_changes = _changes(current, scene)
        tried = [
            ch
            for ch in all_changes
            if promising is None or (ch.kind, ch.key) in promising or ch.kind == "depth"
        ]
        cands = [ch.apply(current, scene) for ch in tried]
        evaluate(cands)
        base = per(current)
        base_obj = _objective(base)
        gains = []
        for c in cands:
            # Only a change that clearly explains some effect counts: small drops spread over
            # every effect are noise fitting (e.g. acne patterns that float rounding decides).
            gains.append(base_obj - _objective(per(c)) if _explained(base, per(c)) else 0.0)
        if full:
            promising = {
                (ch.kind, ch.key) for ch, g in zip(tried, gains, strict=True) if g > MIN_GAIN
            }
        say(
            f"diagnose: round {round_no}: {len(tried)} changes of {current.name}, "
            f"{sum(g > MIN_GAIN for g in gains)} help ({len(score_of)} renders, "
            f"{time.perf_counter() - t0:.1f} s)"
        )
        best = int(np.argmax(gains)) if gains else -1
        if best < 0 or gains[best] <= MIN_GAIN:
            # Stuck with the changes that helped: a full sweep, unless this was one or every
            # effect is already reproduced (nothing left to explain).
            sc = score_of[current]
            done = all(_matched(k, sc.pixels[k], sc.off[k]) for k in sc.pixels)
            if full or done or len(score_of) >= max_renders or round_no > 40:
                break
            promising = None
            continue
        chosen, after_c = tried[best], cands[best]
        after = per(after_c)
        explains = _explained(base, after)
        steps.append(
            Step(
                chosen.label(current, scene),
                chosen.short(current, scene),
                after_c.name,
                base,
                after,
                explains,
            )
        )
        say(
            f"diagnose: keep {chosen.label(current, scene)}: {base_obj:.3f} -> {_objective(after):.3f}"
        )
        current = after_c
    # Which quirks this scene cannot tell: their toggle leaves the result's pixels unchanged.
    toggles = {q: current.with_quirk(q, q not in current.quirks) for q in SEARCH_QUIRKS}
    evaluate(list(toggles.values()))
    invisible = {q for q, c in toggles.items() if score_of[c].digest == score_of[current].digest}
    invisible.add(10)  # every candidate is one ray per pixel, where Q10 changes nothing

    # The same result written from the mode it differs least from (paper-Q2 --no-shadows is
    # classic --no-shadows when Q4 and Q9 change no pixel); the steps are then retold from
    # that mode, each change in the order that helps most.
    simpler = _simplest(current, invisible)
    if simpler.mode != begin.mode:
        say(f"diagnose: {current.name} is {simpler.name} here; retelling the steps from it")
        begin = Candidate.of_mode(simpler.mode)
        remaining = _differences(begin, simpler, scene)
        steps, cur = [], begin
        evaluate([begin])
        while remaining:
            options = [ch.apply(cur, scene) for ch in remaining]
            evaluate(options)
            i = min(range(len(options)), key=lambda j: _objective(per(options[j])))
            before, after = per(cur), per(options[i])
            label = remaining[i].label(cur, scene)
            steps.append(
                Step(
                    label,
                    remaining[i].short(cur, scene),
                    options[i].name,
                    before,
                    after,
                    _explained(before, after),
                )
            )
            cur = options[i]
            del remaining[i]
    current = simpler
    evaluate([current])

    # 3. The report's numbers: FLIP per effect against the start and the result.
    say("diagnose: FLIP per effect for the start and the result")

    def image_of(c: Candidate) -> Image:
        return kept[c] if c in kept else render(c)

    ev_start = evaluate_pair(image_of(begin).rgb, image.rgb, masks=masks)
    ev_final = (
        ev_start
        if current == begin
        else evaluate_pair(image_of(current).rgb, image.rgb, masks=masks)
    )
    start_per, final_per = per(begin), per(current)  # pixels + tone
    findings: dict[str, EffectFinding] = {}
    unexplained: list[str] = []
    for k in EFFECTS:
        if k not in masks:
            continue
        share = score_of[current].off[k]
        ok = _matched(k, score_of[current].pixels[k], share)
        by = tuple(s.change for s in steps if k in s.explains)
        f_start = ev_start.per_effect[k].metrics.flip_ldr
        f_final = ev_final.per_effect[k].metrics.flip_ldr
        rest = f"{share:.1%} of its pixels still off by more than {OFF_LEVELS:g} levels"
        if not ok and not by:
            state = "unexplained"
            unexplained.append(k)
            sentence = (
                f"{k}: nothing explains it (FLIP {f_start:.3f} against {begin.name}, {rest}): "
                "a new bug, not a quirk or a named mistake"
            )
        elif not ok:
            state = "partly explained"
            sentence = (
                f"{k}: partly explained by {' and '.join(by)}: FLIP {f_start:.3f} -> "
                f"{f_final:.3f}, {rest} (pixel patterns such as acne depend on float rounding)"
            )
        elif by:
            state = "explained"
            sentence = f"{k}: explained by {' and '.join(by)}: FLIP {f_start:.3f} -> {f_final:.3f}"
        else:
            state = "as start"
            sentence = f"{k}: as {begin.name} (FLIP {f_final:.3f})"
        findings[k] = EffectFinding(
            k,
            int(masks[k].sum()),
            f_start,
            f_final,
            start_per[k],
            final_per[k],
            share,
            by,
            ok,
            state,
            sentence,
        )

    summary = _summary(begin, steps, findings, unexplained)
    sentences = [summary] + [f.sentence for f in findings.values()]
    if invisible:
        sentences.append(
            "not visible in this scene (toggling them changes no pixel): "
            + ", ".join(f"Q{q}" for q in sorted(invisible))
        )
    depth = scene.max_depth if current.max_depth is None else current.max_depth
    seconds = time.perf_counter() - t0
    say(f"diagnose: {current.name} after {len(score_of)} renders in {seconds:.1f} s")
    return Diagnosis(
        scene=scene.name,
        image=image.path,
        start=begin.name,
        mode_objectives=mode_objectives,
        result=current.name,
        rtdemo_args=current.rtdemo_args(),
        mode=current.mode,
        quirks_present=sorted(set(current.quirks) - invisible),
        quirks_absent=sorted(set(range(1, 11)) - set(current.quirks) - invisible),
        quirks_invisible=sorted(invisible),
        effects_off=[e for e in SWITCHABLE_EFFECTS if e in current.effects_off],
        max_depth=depth,
        mistakes=current.ordered_mistakes() + _aliases(current, scene),
        steps=steps,
        effects=findings,
        unexplained=unexplained,
        summary=summary,
        sentences=sentences,
        renders=len(score_of),
        seconds=seconds,
        candidate=current,
    )


def _differences(a: Candidate, b: Candidate, scene: Scene) -> list[Change]:
    """The one-at-a-time changes that turn candidate a into b."""
    out = [Change("quirk", str(q), q in b.quirks) for q in sorted(a.quirks ^ b.quirks)]
    out += [
        Change("effect", e, e in b.effects_off)
        for e in SWITCHABLE_EFFECTS
        if (e in a.effects_off) != (e in b.effects_off)
    ]
    da = scene.max_depth if a.max_depth is None else a.max_depth
    db = scene.max_depth if b.max_depth is None else b.max_depth
    out += [Change("depth", "+1" if db > da else "-1", db > da)] * abs(db - da)
    out += [Change("mistake", m, m in b.mistakes) for m in sorted(a.mistakes ^ b.mistakes)]
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
            best = Candidate(mode, frozenset(quirks), c.effects_off, c.max_depth, c.mistakes)
            best_count = count
    return best


def _summary(
    begin: Candidate,
    steps: list[Step],
    findings: dict[str, EffectFinding],
    unexplained: list[str],
) -> str:
    changed = [k for k, f in findings.items() if f.explained_by]
    parts = []
    for s in steps:
        shown = [k for k in s.explains if k in findings]
        nums = ", ".join(
            f"{k} FLIP {findings[k].start_flip:.3f} -> {findings[k].final_flip:.3f}" for k in shown
        )
        parts.append(f"explained by {s.change}" + (f": {nums}" if nums else ""))
    if not steps and not unexplained:
        text = f"matches {begin.name} in every effect (within one 8-bit level)"
    elif not steps:
        text = f"nearest to {begin.name}"
    else:
        text = f"matches {begin.name} except {', '.join(changed) or 'a few pixels'}, " + "; ".join(
            parts
        )
    if unexplained:
        text += (
            f"; nothing explains {', '.join(unexplained)}: a new bug, not a quirk or a named "
            "mistake"
        )
    return text
