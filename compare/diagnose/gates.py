"""What must hold before the diagnosis names a cause for an effect (docs/diagnosis.md,
"Evidence"). A student reads the cause, so a false one is the worst answer; an effect that
fails any gate is "not explained", with the pixels that still differ.

For effect k, with D the pixels of k where the image differs from the start (the verdict's
exact match of the start):

  match    the candidate matches at least EXPLAINED_SHARE of D by the verdict's exact match,
           counting a pixel matched only within the candidate's spread (its perturbed
           renders' bounds) only where that spread is no wider than the start's there, or
           where one of the candidate's renders itself stores the image's value: a noisy
           candidate (acne that float rounding decides) cannot absorb a smooth error that
           merely lies between its renders;
  flip     the mean FLIP over D falls to at most FLIP_FALL of the start's (over D, not all of
           k: a few wrong pixels of a large effect barely move k's mean), or to what the
           candidate's matching pixels of k show (FLOOR_FACTOR times it), where FLIP sees
           the error at all (VISIBLE) and the match covers less than WHOLE_MATCH of D;
  others   no effect differs from the candidate in more pixels than from the start, beyond
           its exact-match allowance (search.py drops the change that does it);
  followed where a change alters the picture (its render and the render without it lie
           apart, where its own renders agree), the image follows it: in the effect it
           explains where the result matches the largest share of those pixels (of at least
           FOLLOWED_MIN), that share is FOLLOWED_SHARE or more (search.py drops a change the
           image contradicts, however much it helps elsewhere, unless the result's own
           chaos covers what is not followed).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from compare.judge.arrays import F32
from compare.judge.effects import BOOL
from compare.judge.exact_match import Bounds, ExactMatch

# An effect is explained when the candidate makes at least this share of the pixels that
# differed from the start match (record.EXPLAINED_SHARE says where it was measured).
EXPLAINED_SHARE = 0.5
FLIP_FALL = 0.5  # FLIP over the effect must at least halve
# ... or come down to what matching pixels show: FLIP sees a level of 8-bit rounding in a dark
# region (a float64 program's), so an error of a few levels that the candidate matches
# exactly need not halve. Measured on a MAX_RAY_DEPTH 10 program at 160x120: its 26 deep
# refraction pixels 0.033 -> 0.032, matched pixels of the glass 0.03.
FLOOR_FACTOR = 1.5
# An error FLIP hardly sees (the start's FLIP over D within VISIBLE times that of matching
# pixels: one or two levels at a silhouette) is judged by exact match alone.
VISIBLE = 2.0
# A candidate whose exact match covers this share of D needs no FLIP besides: measured on
# MAX_RAY_DEPTH 10 at 640x480 (tests/corpus), its 33 deep reflection pixels all match, FLIP
# over them 0.083 -> 0.080 (their neighbours' float noise stays).
WHOLE_MATCH = 0.9
# A spread wider than the start's by more than this (8-bit codes; for a float image, this many
# 255ths) is the candidate's own noise, not a cover for the image.
SPREAD_SLACK = 2.0
Pair = tuple[Bounds, Bounds]
# Where a true cause changes the picture, the image shows the change: a shadow loop that skips
# glass is not "shadows off", whose opaque shadows the image keeps (81 % followed), nor is a
# wrong normal "direct light lost", whose lit pixels it keeps lit here and there (80 %).
FOLLOWED_SHARE = 0.9
# Fewer changed pixels than this (where the candidate's renders agree) are no evidence: a
# numpy program's acne against rtdemo's leaves 17 such pixels of its 5,326 (160x120).
FOLLOWED_MIN = 50


@dataclass(frozen=True)
class Gate:
    """Effect k judged for one candidate against the start."""

    effect: str
    differed: int  # pixels of k that differ from the start (D)
    matched: int  # ... that the candidate matches by exact match
    absorbed: int  # ... of them matched only by a spread wider than the start's
    flips: tuple[float, float]  # mean FLIP over D: start, candidate
    floor: float  # mean FLIP over k's other pixels that the candidate matches: a match's FLIP
    worse: bool  # the candidate leaves more of k differing than the start (beyond allowance)

    @property
    def claimed(self) -> int:
        return self.matched - self.absorbed

    @property
    def share(self) -> float:
        return self.claimed / self.differed if self.differed else 0.0

    @property
    def flip_falls(self) -> bool:
        if self.claimed >= WHOLE_MATCH * self.differed:  # the verdict's own rule: FLIP's
            return True  # spatial filter carries neighbouring 1-level noise onto each pixel
        if self.flips[0] <= VISIBLE * self.floor:  # FLIP cannot judge what it does not see
            return True
        return self.flips[1] <= max(FLIP_FALL * self.flips[0], FLOOR_FACTOR * self.floor)

    @property
    def passed(self) -> bool:
        """Every gate holds: the effect may be called explained by the candidate."""
        return (
            self.differed > 0
            and self.claimed >= EXPLAINED_SHARE * self.differed
            and self.flip_falls
            and not self.worse
        )

    def why_not(self) -> str:
        """The first gate that fails, in words for the sentence ("" when every one holds)."""
        if not self.differed:
            return ""
        if self.claimed < EXPLAINED_SHARE * self.differed:
            if self.absorbed and self.matched >= EXPLAINED_SHARE * self.differed:
                return (
                    f"the nearest candidate covers {self.absorbed:,} of the {self.differed:,} "
                    "px only through its own noise (its perturbed renders spread wider than "
                    "the start's there)"
                )
            return ""
        if not self.flip_falls:
            return (
                f"the nearest candidate matches {self.share:.0%} of the {self.differed:,} px but "
                f"FLIP falls only {self.flips[0]:.3f} -> {self.flips[1]:.3f} (half is needed)"
            )
        return ""


def _mean(flip: F32, where: BOOL) -> float:
    return float(flip[where].mean()) if where.any() else 0.0


def spread_width(pair: Pair) -> np.ndarray:
    """H x W: the widest channel of the spread bounds (what the perturbed renders allow)."""
    spread = pair[1]
    out: np.ndarray = np.nan_to_num(spread.hi - spread.lo, nan=0.0, posinf=1e9).max(axis=-1)
    return out


def absorbed_pixels(
    start: tuple[ExactMatch, Pair],
    cand: tuple[ExactMatch, Pair],
    produced: Callable[[BOOL], BOOL],
    float_image: bool,
) -> BOOL:
    """H x W: pixels that differ from the start and that the candidate matches only within a
    spread wider than the start's there, where none of its renders stores the image's value
    (`produced`, called only when some pixel is in question)."""
    e0, p0 = start
    e1, p1 = cand
    slack = SPREAD_SLACK / 255.0 if float_image else SPREAD_SLACK
    out: BOOL = ~e0.matches & e1.unstable & (spread_width(p1) > spread_width(p0) + slack)
    if out.any():
        out &= ~produced(out)
    return out


def gates(
    start: ExactMatch,
    cand: ExactMatch,
    absorbed: BOOL,
    flips: Callable[[], tuple[F32, F32]],
    masks: dict[str, BOOL],
) -> dict[str, Gate]:
    """Per effect, the gates of `cand` against `start` (both the verdict's exact match);
    `flips` makes the FLIP maps of the image against each, called only where the FLIP gate
    decides (a match of half to WHOLE_MATCH of D): elsewhere the numbers are NaN."""
    out = {}
    maps: list[tuple[F32, F32]] = []
    for k, mask in masks.items():
        if k not in start.per_effect or k not in cand.per_effect:
            continue
        d = ~start.matches & mask
        e0, e1 = start.per_effect[k], cand.per_effect[k]
        n, matched, lost = int(d.sum()), int((d & cand.matches).sum()), int((d & absorbed).sum())
        nan = float("nan")
        f0 = f1 = floor = nan
        if EXPLAINED_SHARE * n <= matched - lost < WHOLE_MATCH * n:
            maps = maps or [flips()]
            f0, f1 = _mean(maps[0][0], d), _mean(maps[0][1], d)
            floor = _mean(maps[0][1], mask & ~d & cand.matches)
        out[k] = Gate(
            k, n, matched, lost, (f0, f1), floor, e1.differing - e0.differing > e1.allowed
        )
    return out


def changed_pixels(a: Pair, b: Pair, float_image: bool) -> BOOL:
    """H x W: pixels where two candidates' spreads lie apart in some channel by more than a
    code, and a's spread is narrow (SPREAD_SLACK): they render them differently whatever the
    float rounding. Where a's own renders scatter (acne, which float rounding decides pixel
    by pixel and another program's rounding decides otherwise), a pixel is no evidence."""
    slack = 1.0 / 255.0 if float_image else 1.0
    sa, sb = a[1], b[1]
    with np.errstate(invalid="ignore"):
        apart = (sa.lo > sb.hi + slack) | (sb.lo > sa.hi + slack)
    steady = spread_width(a) <= SPREAD_SLACK * slack
    out: BOOL = np.any(apart, axis=-1) & steady & ~np.any(sa.nan | sb.nan, axis=-1)
    return out


@dataclass(frozen=True)
class Followed:
    """In one effect a change alters, how much of the change the image shows."""

    effect: str  # the effect judged (followed() says which)
    changed: int  # its pixels the change alters
    matched: int  # ... that the result matches

    @property
    def holds(self) -> bool:
        return self.changed < FOLLOWED_MIN or self.matched >= FOLLOWED_SHARE * self.changed


def followed(changed: BOOL, matches: BOOL, masks: dict[str, BOOL]) -> Followed | None:
    """Of the effects in `masks` where a change alters at least FOLLOWED_MIN pixels
    (`changed`), the one where the result matches the largest share of them, with its
    counts; else the one it alters most; None where it alters none. The best, not the
    largest: a second mistake nothing reproduces may share the largest effect's pixels
    (maede97's glass, whose lit surfaces seen through it shade with the wrong sphere)."""
    found = [
        Followed(
            k, int(np.count_nonzero(changed & m)), int(np.count_nonzero(changed & m & matches))
        )
        for k, m in masks.items()
    ]
    found = [f for f in found if f.changed]
    if not found:
        return None
    enough = [f for f in found if f.changed >= FOLLOWED_MIN]
    if not enough:
        return max(found, key=lambda f: f.changed)
    return max(enough, key=lambda f: f.matched / f.changed)
