"""Target models: the algorithm an image is judged against.

    mitsuba           the converged Mitsuba Whitted reference (physics, as the report defines it)
    mitsuba-path      Mitsuba's own path tracer, converged
    paper | classic | physical [+Qn | -Qn ...]
                      a demo model: rtdemo in that mode, with quirks added (+Q2: the quirk is
                      present) or removed (-Q8: fixed) on top of the mode's own set

Examples: `classic`, `classic+Q2` (classic, but eta = 1/ior also when leaving glass),
`paper-Q8` (the paper's program with the exact Fresnel term). docs/paper-model.md lists the
quirks and what each mode holds.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

MITSUBA_MODELS = ("mitsuba", "mitsuba-path")
DEMO_MODES = ("paper", "classic", "physical")
QUIRK_COUNT = 13
SWITCHABLE_EFFECTS = ("shadows", "reflection", "refraction")  # rtdemo's --no-<effect>
# The quirks each mode has (docs/paper-model.md); the C++ twin is quirks_for() in quirks.cpp,
# held equal by tests/test_rtdemo_cli.py.
MODE_QUIRKS: dict[str, frozenset[int]] = {
    "paper": frozenset(range(1, QUIRK_COUNT + 1)),
    "classic": frozenset(range(1, QUIRK_COUNT + 1)) - {2, 4, 9, 11, 12, 13},
    "physical": frozenset(),
}
_TOGGLE = re.compile(r"([+-])[Qq](\d+)")
SYNTAX = "mitsuba, mitsuba-path, or MODE[+Qn|-Qn...] with MODE paper, classic or physical"


class ModelError(ValueError):
    """A target model that cannot be parsed; the message gives the syntax."""


@dataclass(frozen=True)
class TargetModel:
    kind: str  # "mitsuba" | "mitsuba-path" | "demo"
    mode: str | None = None  # for demo models
    quirks: frozenset[int] = frozenset()  # present quirks, for demo models

    @property
    def is_demo(self) -> bool:
        return self.kind == "demo"

    @property
    def name(self) -> str:
        """Canonical text: the mode, then +Qn for added and -Qn for removed quirks."""
        if not self.is_demo:
            return self.kind
        assert self.mode is not None
        base = MODE_QUIRKS[self.mode]
        added = "".join(f"+Q{q}" for q in sorted(self.quirks - base))
        removed = "".join(f"-Q{q}" for q in sorted(base - self.quirks))
        return f"{self.mode}{added}{removed}"

    def rtdemo_args(self) -> list[str]:
        """rtdemo render options that render this model (demo models only)."""
        if not self.is_demo:
            raise ModelError(f"{self.name} is not a demo model")
        assert self.mode is not None
        base = MODE_QUIRKS[self.mode]
        args = ["--mode", self.mode]
        fixed = sorted(base - self.quirks)
        added = sorted(self.quirks - base)
        if fixed:
            args += ["--fix", ",".join(f"Q{q}" for q in fixed)]
        if added:
            args += ["--quirk", ",".join(f"Q{q}" for q in added)]
        return args

    def with_quirk(self, quirk: int, present: bool) -> TargetModel:
        quirks = self.quirks | {quirk} if present else self.quirks - {quirk}
        return TargetModel("demo", self.mode, frozenset(quirks))


def parse_model(text: str) -> TargetModel:
    """`classic+Q2-Q8` -> TargetModel; raises ModelError naming the bad part."""
    t = text.strip().lower()
    if t in MITSUBA_MODELS:
        return TargetModel(t)
    m = re.fullmatch(r"([a-z]+)((?:[+-]q\d+)*)", t)
    if not m or m.group(1) not in DEMO_MODES:
        raise ModelError(f"unknown model {text!r} (expected {SYNTAX})")
    quirks = set(MODE_QUIRKS[m.group(1)])
    for sign, number in _TOGGLE.findall(m.group(2)):
        q = int(number)
        if not 1 <= q <= QUIRK_COUNT:
            raise ModelError(f"model {text!r}: no quirk Q{q} (Q1 to Q{QUIRK_COUNT})")
        if sign == "+":
            quirks.add(q)
        else:
            quirks.discard(q)
    return TargetModel("demo", m.group(1), frozenset(quirks))
