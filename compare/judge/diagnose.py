"""Explains a foreign image as the nearest demo model: which mode, which quirks present or
absent, which effects switched off, which recursion depth and which named mistakes
(mistakes.json) reproduce it, effect by effect.

The search renders candidates through an injected `render` (this module starts no process)
and compares them with a cheap distance: per effect region, the mean number of 8-bit levels
by which a pixel differs beyond one level (so a truncating and a rounding writer of the same
values are at distance 0). It starts from the nearest of the three modes, tries one change at
a time (a quirk toggled, an effect off, the depth one up or down, a mistake added or removed),
keeps the change that lowers the summed per-effect distance most, and repeats with the
changes that helped, instead of all 2^10 quirk combinations. FLIP (evaluate_pair) is computed
only for the start and the result, for the report's numbers.
"""

from __future__ import annotations

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
MAX_ROUNDS = 6
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

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("candidate")
        return d


def _encoded(rgb: F32, encoding: str) -> NDArray[np.float32]:
    """Values in 8-bit levels in the image's own encoding: linear for a PPM read as linear,
    display (sRGB) otherwise. NaN counts as 0, as the paper's PPM writer stores it."""
    if encoding == "linear":
        c = np.clip(np.nan_to_num(rgb, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
        return (c * 255.0).astype(np.float32)
    return (linear_to_srgb(np.nan_to_num(rgb, nan=0.0, posinf=1.0)) * 255.0).astype(np.float32)


def _excess(a: NDArray[np.float32], b: NDArray[np.float32]) -> NDArray[np.float32]:
    """Per pixel: the largest channel difference in levels beyond the one level that
    truncation against rounding may take."""
    out: NDArray[np.float32] = np.maximum(np.abs(a - b).max(axis=2) - 1.0, 0.0).astype(np.float32)
    return out


def _per_effect(excess: NDArray[np.float32], masks: dict[str, BOOL]) -> dict[str, float]:
    return {k: float(excess[m].mean()) for k, m in masks.items()}


def _means(enc: NDArray[np.float32], masks: dict[str, BOOL]) -> dict[str, NDArray[np.float64]]:
    return {k: enc[m].mean(axis=0, dtype=np.float64) for k, m in masks.items()}


def _tone(a: dict[str, NDArray[np.float64]], b: dict[str, NDArray[np.float64]]) -> dict[str, float]:
    """Per effect: how far the region's mean colour is off, in levels beyond one. Where float
    rounding decides each pixel (acne), two programs with the same mistake differ pixel by
    pixel but agree on average; this term lets such a mistake explain its region."""
    return {k: max(0.0, float(np.abs(a[k] - b[k]).max()) - 1.0) for k in a}


def _objective(per: dict[str, float]) -> float:
    return float(sum(per.values()))  # every effect counts alike, whatever its size


def _off_share(excess: NDArray[np.float32], mask: BOOL) -> float:
    return float((excess[mask] > OFF_LEVELS).mean())


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
    budget_s: float = 10.0,
) -> Diagnosis:
    """The nearest demo candidate to `image` (linear RGB as read by images.read_image) and
    the evidence per effect. `render` must return the candidate at the image's size with the
    id and depth AOVs (the first render's give the effect masks). With `start`, the search
    begins there instead of at the nearest of the three modes. `parallel` renders run at once
    (render must then be thread-safe). After `budget_s` no new round starts."""
    t0 = time.perf_counter()
    say = progress or (lambda _m: None)
    target = _encoded(image.rgb, image.encoding)
    excess_of: dict[Candidate, NDArray[np.float32]] = {}
    kept: dict[Candidate, Image] = {}
    masks: dict[str, BOOL] = {}
    tone_of: dict[Candidate, dict[str, float]] = {}
    target_means: dict[str, NDArray[np.float64]] = {}

    def evaluate(cands: list[Candidate]) -> None:
        todo = [c for c in dict.fromkeys(cands) if c not in excess_of]
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
                if not masks:
                    if "id" not in im.aovs or "depth" not in im.aovs:
                        raise DiagnoseError(f"render of {c.name} has no id/depth AOVs")
                    found = effect_masks(scene, im.aovs["id"], im.aovs["depth"])
                    masks.update({k: v for k, v in found.items() if v.any()})
                enc = _encoded(im.rgb, "linear" if image.encoding == "linear" else "srgb")
                excess_of[c] = _excess(enc, target)
                if not target_means:
                    target_means.update(_means(target, masks))
                tone_of[c] = _tone(_means(enc, masks), target_means)
                kept[c] = im

    def per(c: Candidate) -> dict[str, float]:
        pixels = _per_effect(excess_of[c], masks)
        return {k: pixels[k] + tone_of[c][k] for k in pixels}

    # 1. The nearest mode (or the given start).
    if start is not None:
        first = start if isinstance(start, Candidate) else Candidate.from_model(start)
        starts = [first]
    else:
        starts = [Candidate.of_mode(m) for m in ("classic", "paper", "physical")]
    say(f"diagnose: rendering {', '.join(c.name for c in starts)}")
    evaluate(starts)
    mode_objectives = {c.name: _objective(per(c)) for c in starts}
    current = min(starts, key=lambda c: _objective(per(c)))
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
    invisible: set[int] = set()
    promising: set[tuple[str, str]] | None = None
    full_sweep_done_after_stall = False
    for round_no in range(1, MAX_ROUNDS + 1):
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
        for ch, c in zip(tried, cands, strict=True):
            if ch.kind == "quirk" and np.array_equal(excess_of[c], excess_of[current]):
                invisible.add(int(ch.key))
            # Only a change that clearly explains some effect counts: small drops spread over
            # every effect are noise fitting (e.g. acne patterns that float rounding decides).
            gains.append(base_obj - _objective(per(c)) if _explained(base, per(c)) else 0.0)
        if promising is None:
            promising = {
                (ch.kind, ch.key) for ch, g in zip(tried, gains, strict=True) if g > MIN_GAIN
            }
        say(
            f"diagnose: round {round_no}: {len(tried)} changes of {current.name}, "
            f"{sum(g > MIN_GAIN for g in gains)} help ({len(excess_of)} renders, "
            f"{time.perf_counter() - t0:.1f} s)"
        )
        best = int(np.argmax(gains)) if gains else -1
        if best < 0 or gains[best] <= MIN_GAIN:
            # Stuck with the promising set: one full sweep, if time allows, then stop.
            if (
                full_sweep_done_after_stall
                or round_no == 1
                or time.perf_counter() - t0 > 0.4 * budget_s
            ):
                break
            full_sweep_done_after_stall = True
            promising = {(ch.kind, ch.key) for ch in all_changes}
            continue
        chosen, after_c = tried[best], cands[best]
        after = per(after_c)
        explains = _explained(base, after)
        steps.append(Step(chosen.label(current, scene), after_c.name, base, after, explains))
        say(
            f"diagnose: keep {chosen.label(current, scene)}: {base_obj:.3f} -> {_objective(after):.3f}"
        )
        current = after_c
        for c in [c for c in kept if c not in (begin, current)]:
            del kept[c]  # a 640x480 render with AOVs is 10 MB: keep only what FLIP needs
        if time.perf_counter() - t0 > budget_s:
            say("diagnose: time budget spent; stopping the search")
            break
    invisible -= {q for q in range(1, 11) if any(f"Q{q} " in s.change for s in steps)}

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
            steps.append(Step(label, options[i].name, before, after, _explained(before, after)))
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
    start_per, final_per = per(begin), per(current)
    findings: dict[str, EffectFinding] = {}
    unexplained: list[str] = []
    for k in EFFECTS:
        if k not in masks:
            continue
        share = _off_share(excess_of[current], masks[k])
        ok = _matched(k, final_per[k], share)
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

    summary = _summary(begin, current, steps, findings, unexplained, scene)
    sentences = [summary] + [f.sentence for f in findings.values()]
    if invisible:
        sentences.append(
            "not visible in this scene (toggling them changes no pixel): "
            + ", ".join(f"Q{q}" for q in sorted(invisible))
        )
    depth = scene.max_depth if current.max_depth is None else current.max_depth
    seconds = time.perf_counter() - t0
    say(f"diagnose: {current.name} after {len(excess_of)} renders in {seconds:.1f} s")
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
        renders=len(excess_of),
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
    current: Candidate,
    steps: list[Step],
    findings: dict[str, EffectFinding],
    unexplained: list[str],
    scene: Scene,
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
    del scene, current
    return text
