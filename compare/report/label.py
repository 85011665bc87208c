"""A report's --label: one line of text, short enough to draw. It lands in titles, tables,
figures and report.json, each escaped there; 120 KB of it took 239 s and 5 GB to draw."""

from __future__ import annotations

import unicodedata

MAX_LABEL = 200


def label_problem(label: str) -> str | None:
    """Why a label cannot be used, or None."""
    if len(label) > MAX_LABEL:
        return f"{len(label)} characters; a label has at most {MAX_LABEL}"
    if any(unicodedata.category(c) in ("Cc", "Cs") for c in label):
        return "a label is one line of text, without control characters"
    return None
