"""The public catalogue of named common mistakes (compare/diagnose/mistakes.json).

Each is a run-time switch of rtdemo (`--mistake NAME[,NAME]`), so that `rtval diagnose` can
render what a student's program with that mistake would show. rtdemo embeds the same JSON file
at build time (demo_cpp/CMakeLists.txt) for its `--help` and its option check, so the names and
explanations live in one place. docs/paper-model.md describes each one.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cache
from importlib import resources

CATALOGUE_FORMAT = "rtval-mistakes/1"


@dataclass(frozen=True)
class Mistake:
    """A named common mistake: an rtdemo switch (``--mistake NAME``) and what it does.

    Attributes
    ----------
    name : str
        Its name, as rtdemo's ``--mistake`` takes it ("no_offset").
    explanation : str
        What the program does wrong and what the image shows.
    effects : tuple[str, ...]
        The effect masks where it shows first.
    same_as : str or None
        Another switch that renders the same image (shadow_past_light is "+Q5"): diagnose
        searches that switch and names the mistake beside it. Default None.
    step : str
        The step of the algorithm it lives in ("camera", "direct light", ...; the steps of
        docs/diagnosis.md), "" where switches.MISTAKE_STEPS words it. Default "".
    looks_like : str
        What the image shows, for a student. Default "".
    source : str
        Where real programs or people made it. Default "".
    symptom : str
        What the image shows, where several mistakes render the same image ("direct light
        lost"): the diagnosis names the symptom, not one of them. Default "".
    """

    name: str
    explanation: str
    effects: tuple[str, ...]
    same_as: str | None = None
    step: str = ""
    looks_like: str = ""
    source: str = ""
    symptom: str = ""


@cache
def catalogue() -> dict[str, Mistake]:
    """Every named mistake, read once from mistakes.json.

    Returns
    -------
    dict[str, Mistake]
        Every mistake by name, in the file's order; the same dict on every call (cached),
        not to be changed.

    Raises
    ------
    ValueError
        mistakes.json is not in the CATALOGUE_FORMAT ("rtval-mistakes/1") format.
    """
    raw = json.loads(resources.files("compare.diagnose").joinpath("mistakes.json").read_text())
    if raw.get("format") != CATALOGUE_FORMAT:
        raise ValueError(f"mistakes.json: format is not {CATALOGUE_FORMAT}")
    out: dict[str, Mistake] = {}
    for entry in raw["mistakes"]:
        out[entry["name"]] = Mistake(
            entry["name"],
            entry["explanation"],
            tuple(entry["effect"].split(",")),
            entry.get("same_as"),
            entry.get("step", ""),
            entry.get("looks_like", ""),
            entry.get("source", ""),
            entry.get("symptom", ""),
        )
    return out


def parse_mistakes(text: str) -> frozenset[str]:
    """`no_offset,double_gamma` -> the set; raises ValueError naming an unknown one."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    known = catalogue()
    for n in names:
        if n not in known:
            raise ValueError(f"unknown mistake {n!r} (known: {', '.join(known)})")
    if not names:
        raise ValueError("empty mistake list")
    return frozenset(names)
