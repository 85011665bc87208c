"""The Pareto front of speed against error: the renders no other render beats on both."""

from __future__ import annotations

import math
from typing import Any


def pareto_front(rows: list[dict[str, Any]], error: str) -> list[dict[str, Any]]:
    """Rows (each with "seconds" and `error`) not beaten by a faster-or-equal one with a lower
    error, ordered by time. Rows with a non-finite or non-positive time or error are left out
    (a log chart cannot draw them, and a time of 0 is not a measurement)."""
    usable = [
        r
        for r in rows
        if all(
            isinstance(r.get(k), (int, float)) and math.isfinite(r[k]) and r[k] > 0
            for k in ("seconds", error)
        )
    ]
    front: list[dict[str, Any]] = []
    best = math.inf
    for r in sorted(usable, key=lambda r: (r["seconds"], r[error])):
        if r[error] < best:
            front.append(r)
            best = r[error]
    return front
