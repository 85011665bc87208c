"""The Fresnel curve's constants fitted as values: once a seed curve of the sweep helped
(switches.FRESNEL_SEEDS), its mix is refined on a grid that narrows three times, its power
tried one up and down and at Schlick's 5, and the result snapped to the roundest value that
fits as well (a student types 0.9, not 0.893). About fifteen renders, in batches of up to
four, so that the renders of one batch run in parallel."""

from __future__ import annotations

from compare.diagnose.candidate import Candidate
from compare.diagnose.refine import best_of, snapped
from compare.diagnose.trials import Trials

# The mix grid: each round tries two steps either side of the best mix so far, the step
# shrinking; the steps divide 0.1, so that the grid holds the round values a student types.
MIX_STEPS = (0.1, 0.02, 0.01)
POWERS = range(0, 9)  # rtdemo accepts 0 to 16; a student's curve has a small power


def fitted_curve(trials: Trials, c: Candidate) -> Candidate:
    """c (whose fresnel is a seed) with the curve's mix and power fitted to the image: the
    mix, then the power one up or down or Schlick's 5, then the mix again where the power
    changed."""
    assert c.fresnel is not None
    best = _fitted_mix(trials, c, MIX_STEPS)
    assert best.fresnel is not None
    mix, power = best.fresnel
    powers = ({power - 1, power + 1, 5} & set(POWERS)) - {power}
    best = best_of(trials, best, [best.with_fresnel((mix, p)) for p in sorted(powers)])
    if best.fresnel != (mix, power):
        best = _fitted_mix(trials, best, MIX_STEPS[1:])
    assert best.fresnel is not None
    mix, power = best.fresnel
    rounder = [best.with_fresnel((round(mix, digits), power)) for digits in (1, 2)]
    return snapped(trials, best, rounder)


def _fitted_mix(trials: Trials, c: Candidate, steps: tuple[float, ...]) -> Candidate:
    best = c
    for step in steps:
        best = best_of(trials, best, [_with_mix(best, step * k) for k in (-2, -1, 1, 2)])
    return best


def _with_mix(c: Candidate, offset: float) -> Candidate:
    assert c.fresnel is not None
    mix, power = c.fresnel
    return c.with_fresnel((round(min(1.0, max(0.0, mix + offset)), 4), power))
