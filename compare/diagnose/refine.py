"""Refining a fitted value (constant_fit.py, fresnel_fit.py): the best of a batch of
candidates around it, rendered together, and the roundest value the image cannot tell from
it (a student types 1.5, 1e-3 or 0.9, not 1.4962); and the values an 8-bit image stands for,
which the fits read (light_fit.py, colour_fit.py)."""

from __future__ import annotations

import numpy as np

from compare.diagnose.candidate import Candidate
from compare.diagnose.score import objective
from compare.diagnose.trials import Trials
from compare.judge.arrays import F32
from compare.judge.images import linear_to_srgb, srgb_to_linear


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


def code_readings(test: F32, encoding: str) -> list[np.ndarray]:
    """The image's values as a rounding writer and as a truncating one stored them: an 8-bit
    code c holds [c - 0.5, c + 0.5) / 255 or [c, c + 1) / 255 (the lineage truncates), read at
    the middle; a float image as it is. The last image's are kept: the light and colour fits
    read them every round."""
    last = _LAST_READINGS.get(encoding)
    if last is not None and last[0] is test:
        return last[1]
    values = test.astype(np.float64)
    if encoding == "float":
        out = [values]
    elif encoding == "srgb":
        up = srgb_to_linear(np.clip(linear_to_srgb(test) + 0.5 / 255, 0, 1).astype(np.float32))
        out = [values, up.astype(np.float64)]
    else:
        out = [values, values + 0.5 / 255]
    _LAST_READINGS[encoding] = (test, out)
    return out


# encoding -> (the image, its readings): one image per encoding, replaced by the next.
_LAST_READINGS: dict[str, tuple[F32, list[np.ndarray]]] = {}
