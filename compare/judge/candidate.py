"""A candidate explanation of an image: a demo model (mode and the quirks present), with
effects switched off, a recursion depth and named mistakes (mistakes.py) on top. It is what
`rtval diagnose` renders and compares; `rtdemo_args()` is the rtdemo command line for it."""

from __future__ import annotations

from dataclasses import dataclass, field

from compare.judge.mistakes import catalogue
from compare.judge.target_model import MODE_QUIRKS, TargetModel

SWITCHABLE_EFFECTS = ("shadows", "reflection", "refraction")  # rtdemo's --no-<effect>


@dataclass(frozen=True)
class Candidate:
    mode: str
    quirks: frozenset[int]  # present quirks
    effects_off: frozenset[str] = frozenset()  # a subset of SWITCHABLE_EFFECTS
    max_depth: int | None = None  # None: the scene's
    mistakes: frozenset[str] = field(default_factory=frozenset)

    @staticmethod
    def of_mode(mode: str) -> Candidate:
        return Candidate(mode, MODE_QUIRKS[mode])

    @staticmethod
    def from_model(model: TargetModel) -> Candidate:
        if not model.is_demo or model.mode is None:
            raise ValueError(f"{model.name} is not a demo model")
        return Candidate(model.mode, model.quirks)

    @property
    def model(self) -> TargetModel:
        return TargetModel("demo", self.mode, self.quirks)

    @property
    def name(self) -> str:
        parts = [self.model.name]
        parts += [f"--no-{e}" for e in SWITCHABLE_EFFECTS if e in self.effects_off]
        if self.max_depth is not None:
            parts.append(f"--max-depth {self.max_depth}")
        if self.mistakes:
            parts.append("--mistake " + ",".join(self.ordered_mistakes()))
        return " ".join(parts)

    def ordered_mistakes(self) -> list[str]:
        return [m for m in catalogue() if m in self.mistakes]

    def rtdemo_args(self) -> list[str]:
        """rtdemo render options for this candidate."""
        args = self.model.rtdemo_args()
        args += [f"--no-{e}" for e in SWITCHABLE_EFFECTS if e in self.effects_off]
        if self.max_depth is not None:
            args += ["--max-depth", str(self.max_depth)]
        if self.mistakes:
            args += ["--mistake", ",".join(self.ordered_mistakes())]
        return args

    def with_quirk(self, quirk: int, present: bool) -> Candidate:
        q = self.quirks | {quirk} if present else self.quirks - {quirk}
        return Candidate(self.mode, frozenset(q), self.effects_off, self.max_depth, self.mistakes)

    def with_effect(self, effect: str, on: bool) -> Candidate:
        off = self.effects_off - {effect} if on else self.effects_off | {effect}
        return Candidate(self.mode, self.quirks, frozenset(off), self.max_depth, self.mistakes)

    def with_depth(self, depth: int | None) -> Candidate:
        return Candidate(self.mode, self.quirks, self.effects_off, depth, self.mistakes)

    def with_mistake(self, name: str, present: bool) -> Candidate:
        m = self.mistakes | {name} if present else self.mistakes - {name}
        return Candidate(self.mode, self.quirks, self.effects_off, self.max_depth, frozenset(m))
