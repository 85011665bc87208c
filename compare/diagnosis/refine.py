"""Refining a fitted value (constant_fit.py, fresnel_fit.py): the best of a batch of
candidates around it, rendered together, and the roundest value the image cannot tell from
it (a student types 1.5, 1e-3 or 0.9, not 1.4962)."""

from __future__ import annotations

from compare.diagnosis.candidate import Candidate
from compare.diagnosis.score import objective
from compare.diagnosis.trials import Trials


def best_of(trials: Trials, best: Candidate, options: list[Candidate]) -> Candidate:
    """The candidate of the lowest objective, best kept on a tie."""
    options = [o for o in dict.fromkeys(options) if o != best]
    trials.evaluate(options)
    for o in options:
        if objective(trials.per(o)) < objective(trials.per(best)):
            best = o
    return best


def snapped(trials: Trials, c: Candidate, rounder: list[Candidate]) -> Candidate:
    """The first of `rounder` that fits as well as c (the image cannot tell them apart), else
    c; c itself where it is one of them (a round value already)."""
    options = [r for r in rounder if r != c]
    if len(options) < len(rounder):
        return c
    trials.evaluate(options)
    for r in options:
        if trials.fits_as_well(r, c):
            return r
    return c
