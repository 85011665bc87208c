"""The diagnosis (diagnose.py) as a record and in words: per effect, whether the result
reproduces it (the exact match of the start and of the result, as the verdict judges a model),
FLIP before and after, the step that explains it, and one sentence; a summary line for the
whole image.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass, field
from typing import Any

from compare.diagnose.candidate import Candidate
from compare.diagnose.gates import EXPLAINED_SHARE, Gate
from compare.diagnose.switches import aliases
from compare.judge.exact_match import ExactMatch
from compare.judge.target_model import QUIRK_COUNT, SWITCHABLE_EFFECTS
from scene_model.scene import Scene

# EXPLAINED_SHARE (gates.py): an effect is explained when the result makes at least this share
# of the pixels that differed from the start match. Measured (tests/test_diagnose.py, 160x120
# and 640x480): every named cause of the student variants makes 93-100 % match; the best
# candidates for programs nothing explains make 0-19 % match (glass never multiplied by its
# colour; a refracted ray that hits nothing): half is far from both. Two switches that explain
# one effect only together must match it exactly (search.joint_partial): a ray that never
# leaves glass plus a hard-coded ior 1.2 made most of "a refracted ray that hits nothing" match.


# The nearest mode wins outright only by a clear margin: more than MODE_CLOSE_SHARE of all
# pixels and MODE_CLOSE_RATIO of its own count; a mode within it is searched from as well, and
# the image cannot tell it from the nearest.
MODE_CLOSE_SHARE = 0.02
MODE_CLOSE_RATIO = 0.1


@dataclass(frozen=True)
class Step:
    """A switch of the result, with the distance per effect before and after it."""

    change: str  # Switch.change: "+Q2 (eta = 1/ior also when leaving glass)"
    cause: str  # Switch.cause: "+Q2", "-Q8", "--no-shadows", "max depth 10", "no_offset"
    candidate: str  # the candidate after it
    before: dict[str, float]
    after: dict[str, float]
    explains: tuple[str, ...]  # effects whose pixels it makes match (and that are explained)
    kind: str = "step"  # Switch.cause_kind: quirk, mistake, camera, image, step, constant
    step: str = ""  # Switch.step: the step of the algorithm it changes
    # Other changes the image cannot tell from this one (a constant in place of a quirk).
    alternatives: tuple[str, ...] = ()
    alternative_names: tuple[str, ...] = ()  # their Switch.cause: "light_blocks_itself"


@dataclass(frozen=True)
class EffectFinding:
    effect: str
    pixels: int
    start_flip: float  # FLIP of the image against the start mode in this effect's pixels
    final_flip: float  # ... against the diagnosis
    start_distance: float  # mean 8-bit levels beyond one
    final_distance: float
    start_differing: int  # pixels that do not match the start exactly (as the verdict judges)
    final_differing: int  # ... the diagnosis
    allowed: int  # differing pixels an exact match allows in this effect
    nearest_share: float  # the most of start_differing any candidate tried matches (centres)
    explained_by: tuple[str, ...]  # labels of the steps that explain it
    matched: bool  # the diagnosis reproduces it: an exact match
    state: str  # "as start" | "explained" | "partly explained" | "unexplained"
    sentence: str
    # Where the pixels still differing lie: x0, y0, x1, y1 (inclusive), None when none do.
    box: tuple[int, int, int, int] | None = None

    @property
    def fixed_share(self) -> float:
        """The share of the pixels that differed from the start that the diagnosis matches."""
        if not self.start_differing:
            return 1.0
        return max(0.0, 1.0 - self.final_differing / self.start_differing)


@dataclass
class Diagnosis:
    scene: str
    image: str
    start: str  # the nearest mode's candidate name
    mode_objectives: dict[str, float]  # each mode tried: pixels of the image that differ
    result: str  # the diagnosis' candidate name
    rtdemo_args: list[str]  # the rtdemo options that render it (from scene_changes' copy)
    scene_changes: dict[str, Any]  # what a copy of the scene changes: background, ior
    mirrored: str  # "", "left-right", "upside down", "left-right and upside down"
    mode: str
    quirks_present: list[int]
    quirks_absent: list[int]
    quirks_invisible: list[int]  # toggling them changed no pixel: this scene cannot tell
    quirks_untested: list[int]  # the renderer cannot render them (an older rtdemo)
    effects_off: list[str]
    max_depth: int
    depth_or_more: bool  # every deeper limit searched gives the same image
    mistakes: list[str]
    steps: list[Step]
    effects: dict[str, EffectFinding]
    unexplained: list[str]
    matches: bool  # the result is an exact match of the image in every effect
    summary: str
    sentences: list[str]
    renders: int
    seconds: float
    candidate: Candidate = field(repr=False)
    # The start, every step's candidate and the result, by name (the evidence pictures').
    candidates: dict[str, Candidate] = field(default_factory=dict, repr=False)
    # Candidates not judged: their render ran past the time limit or the ray budget, "NAME: why".
    skipped: list[str] = field(default_factory=list)
    # What the image's writer did to the values or pixels, fitted on the image (transforms.py).
    image_transforms: list[str] = field(default_factory=list)
    image_transform_specs: list[list[Any]] = field(default_factory=list)  # of_spec's
    # The causes as the JSON's `causes` list: name, kind, effects, evidence, sentence.
    cause_list: list[dict[str, Any]] = field(default_factory=list)
    # Where the pixels nothing explains lie (localise.py): the whole image's step ("overall",
    # the JSON's `localisation`) and, per unexplained effect, its step and path classes.
    where: dict[str, Any] = field(default_factory=dict)

    @property
    def exact(self) -> bool:
        return self.matches

    @property
    def causes(self) -> list[str]:
        """What differs from the start mode, shortly: ["+Q2"], ["mirrored left-right"], []."""
        head = [f"mirrored {self.mirrored}"] if self.mirrored else []
        return head + self.image_transforms + [s.cause for s in self.steps]

    def modes_as_near(self) -> list[str]:
        """The other modes whose renders differ from the image about as much as the start's
        (within the clear margin): the image cannot tell the start from them."""
        counts = self.mode_objectives
        if self.start not in counts:
            return []
        total = sum(f.pixels for k, f in self.effects.items() if k != "edges")
        margin = max(MODE_CLOSE_SHARE * total, MODE_CLOSE_RATIO * counts[self.start])
        return [
            m for m, n in counts.items() if m != self.start and n - counts[self.start] <= margin
        ]

    def reason(self) -> str:
        """One line for a gradebook: "looks like classic+Q2 (+Q2)", with the regions that
        nothing explains."""
        text = f"looks like {self.result}"
        if self.causes:
            text += f" ({', '.join(self.causes)})"
        if self.unexplained:
            text += f"; not explained: {', '.join(self.unexplained)}"
        return text

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("candidate")
        d.pop("candidates")
        d["causes"] = d.pop("cause_list")
        d["unexplained_where"] = [
            {
                "effect": k,
                "differing": self.effects[k].final_differing,
                "pixels": self.effects[k].pixels,
                "share": self.effects[k].final_differing / max(1, self.effects[k].pixels),
                "box": self.effects[k].box,
                "against": self.result,
                **self.where.get("effects", {}).get(k, {}),
            }
            for k in self.unexplained
        ]
        d["localisation"] = d.pop("where").get("overall", [])
        d["reason"] = self.reason()
        for k, f in self.effects.items():
            d["effects"][k]["fixed_share"] = f.fixed_share
        return d

    def record(self) -> dict[str, Any]:
        """as_dict() with the candidates, for from_record (JSON-ready)."""
        cands = {"candidate": self.candidate, **self.candidates}
        return {
            **self.as_dict(),
            "record_candidates": {k: _candidate_fields(c) for k, c in cands.items()},
            "record_where": self.where,
        }

    @staticmethod
    def from_record(raw: dict[str, Any]) -> Diagnosis:
        """The Diagnosis a record() was made of (ValueError, KeyError or TypeError when it
        is not one)."""
        cands = {k: _candidate(v) for k, v in raw["record_candidates"].items()}
        fields = {f.name for f in dataclasses.fields(Diagnosis)} - {"candidate", "candidates"}
        d = {k: raw[k] for k in fields - {"cause_list", "where"}}
        d["cause_list"] = list(raw["causes"])
        d["where"] = dict(raw["record_where"])
        d["steps"] = [
            Step(
                **{
                    **st,
                    "explains": tuple(st["explains"]),
                    "alternatives": tuple(st.get("alternatives", ())),
                    "alternative_names": tuple(st.get("alternative_names", ())),
                }
            )
            for st in d["steps"]
        ]
        d["effects"] = {
            k: EffectFinding(
                **{
                    **{n: v for n, v in e.items() if n != "fixed_share"},
                    "explained_by": tuple(e["explained_by"]),
                    "box": None if e.get("box") is None else tuple(e["box"]),
                }
            )
            for k, e in d["effects"].items()
        }
        main = cands.pop("candidate")
        return Diagnosis(**d, candidate=main, candidates=cands)


def _candidate_fields(c: Candidate) -> dict[str, Any]:
    return {
        "mode": c.mode,
        "quirks": sorted(c.quirks),
        "effects_off": sorted(c.effects_off),
        "max_depth": c.max_depth,
        "mistakes": sorted(c.mistakes),
        "background": list(c.background) if c.background is not None else None,
        "ior": c.ior,
        "ior_sphere": c.ior_sphere,
        "bias": c.bias,
        "fresnel": list(c.fresnel) if c.fresnel is not None else None,
        "camera": c.camera,
        "light": list(c.light) if c.light is not None else None,
        "colour": [c.colour[0], list(c.colour[1])] if c.colour is not None else None,
    }


def _candidate(raw: dict[str, Any]) -> Candidate:
    bg = raw["background"]
    return Candidate(
        str(raw["mode"]),
        frozenset(int(q) for q in raw["quirks"]),
        frozenset(str(e) for e in raw["effects_off"]),
        None if raw["max_depth"] is None else int(raw["max_depth"]),
        frozenset(str(m) for m in raw["mistakes"]),
        None if bg is None else (float(bg[0]), float(bg[1]), float(bg[2])),
        None if raw["ior"] is None else float(raw["ior"]),
        None if raw.get("bias") is None else float(raw["bias"]),
        _fresnel(raw.get("fresnel")),
        None if raw.get("camera") is None else str(raw["camera"]),
        ior_sphere=None if raw.get("ior_sphere") is None else str(raw["ior_sphere"]),
        light=_vec3(raw.get("light")),
        colour=_colour(raw.get("colour")),
    )


def _colour(raw: Any) -> tuple[str, tuple[float, float, float]] | None:
    rgb = None if raw is None else _vec3(raw[1])
    return None if raw is None or rgb is None else (str(raw[0]), rgb)


def _vec3(raw: Any) -> tuple[float, float, float] | None:
    return None if raw is None else (float(raw[0]), float(raw[1]), float(raw[2]))


def _fresnel(raw: Any) -> tuple[float, int] | None:
    return None if raw is None else (float(raw[0]), int(raw[1]))


@dataclass(frozen=True)
class ImageCause:
    """A transform of the image's writer, fitted and gated (search.transformed)."""

    family: str  # transforms.Transform.family
    name: str  # in words: "channels written as B, G, R (not R, G, B)"
    effects: tuple[str, ...]  # the effects it explains
    gates: dict[str, Gate]  # their evidence: pixels and FLIP before and after
    spec: list[str | float] = field(default_factory=list)  # transforms.of_spec makes it again


@dataclass(frozen=True)
class Found:
    """What the search found, before it is judged effect by effect."""

    begin: Candidate  # the mode the result is told from
    result: Candidate
    steps: list[Step]
    invisible: set[int]  # quirks whose toggle changes no pixel here
    untested: set[int]  # quirks the renderer cannot render
    or_more: bool  # the result's depth: every deeper limit fits as well
    mirrored: str
    candidates: dict[str, Candidate]  # the start, each step's and the result, by name
    skipped: tuple[str, ...] = ()  # candidates over the time limit or ray budget, with why
    images: tuple[ImageCause, ...] = ()  # the writer's transforms found (transforms.py)


@dataclass(frozen=True)
class Evidence:
    """One effect, judged for the start and the result."""

    start: ExactMatch
    final: ExactMatch
    flips: tuple[float, float]  # mean FLIP in the effect: start, result
    distances: tuple[float, float]  # mean 8-bit levels beyond one: start, result
    near: tuple[int, float]  # (candidates tried, the best share of start's differing matched)
    gate: Gate | None = None  # the result against the start (gates.py); None: as start
    box: tuple[int, int, int, int] | None = None  # where the result's differing pixels lie


def finding(k: str, found: Found, ev: Evidence) -> EffectFinding:
    """Effect k's finding: its state, the steps that explain it and its sentence."""
    e0, e1 = ev.start.per_effect[k], ev.final.per_effect[k]
    steps = found.steps
    # An effect no single step is needed for, but that the result fixes, is the steps' work
    # together.
    by = tuple(st.change for st in steps if k in st.explains) or tuple(st.change for st in steps)
    # A cause is named only where every gate holds (gates.py): the result matches the pixels
    # that differed, not through its own noise, FLIP halves, no effect got worse.
    named = ev.gate is not None and ev.gate.passed and bool(steps)
    if e0.passed:
        state = "as start"
    elif e1.passed:
        state = "explained" if named else "unexplained"
    else:
        state = "partly explained" if named else "unexplained"
    return EffectFinding(
        k,
        e1.pixels,
        ev.flips[0],
        ev.flips[1],
        ev.distances[0],
        ev.distances[1],
        e0.differing,
        e1.differing,
        e1.allowed,
        ev.near[1],
        by if state in ("explained", "partly explained") else (),
        e1.passed,
        state,
        _sentence(k, state, by, found.begin, ev),
        ev.box,
    )


def _sentence(k: str, state: str, by: tuple[str, ...], begin: Candidate, ev: Evidence) -> str:
    """One effect's finding in words."""
    f0, f1 = ev.flips
    start_differing, final = ev.start.per_effect[k].differing, ev.final
    if state == "as start":
        return f"{k}: as {begin.name} (FLIP {f1:.3f})"
    if state == "unexplained" and start_differing <= ev.start.per_effect[k].allowed:
        return (
            f"{k}: matches {begin.name}, but {final.sentence(k)}: the changes that explain the "
            "other effects cost it"
        )
    if state == "explained":
        return (
            f"{k}: explained by {' and '.join(by)}: {start_differing:,} px differed from "
            f"{begin.name}, the result matches; FLIP {f0:.3f} -> {f1:.3f}"
        )
    if state == "partly explained":
        return (
            f"{k}: partly explained by {' and '.join(by)}: {final.sentence(k)} "
            f"({start_differing:,} from {begin.name}); FLIP {f0:.3f} -> {f1:.3f}"
        )
    why = ev.gate.why_not() if ev.gate is not None else ""
    against = final if not final.per_effect[k].passed else ev.start
    return (
        f"{k}: not explained: {against.sentence(k)}; FLIP {f1:.3f}; "
        f"{why or _nearest(ev.near)}: a new bug, not a quirk or a named mistake"
    )


def _nearest(near: tuple[int, float]) -> str:
    tried, share = near
    if share < EXPLAINED_SHARE:
        return (
            f"the nearest of the {tried} candidates tried makes {share:.0%} of them match "
            f"({EXPLAINED_SHARE:.0%} would explain it)"
        )
    # e.g. silhouettes that another bug happens to share, at the cost of the rest
    return (
        f"a candidate that makes {share:.0%} of them match leaves the rest of the image further off"
    )


def summary(found: Found, findings: dict[str, EffectFinding], start: ExactMatch) -> str:
    """The whole image in one line: what matches the start, what each step explains, and what
    nothing explains."""
    begin, mirrored = found.begin, found.mirrored
    head = f"mirrored {mirrored} (diagnosed un-mirrored); " if mirrored else ""
    for cause in found.images:
        head += f"the image was written with {cause.name} (diagnosed through it); "
    off = [k for k in findings if not start.per_effect[k].passed]
    if not off:
        text = f"matches {begin.name} in every effect (exact match)"
    elif len(off) == len(findings):
        text = f"nearest to {begin.name}, which no effect matches"
    else:
        text = f"matches {begin.name} except {', '.join(off)}"
    for st in found.steps:
        nums = ", ".join(
            f"{k} FLIP {findings[k].start_flip:.3f} -> {findings[k].final_flip:.3f}"
            for k in st.explains
            if k in findings
        )
        text += f"; explained by {st.change}" + _alike(st) + (f": {nums}" if nums else "")
    partly = [k for k, f in findings.items() if f.state == "partly explained"]
    if partly:
        text += "; still differing: " + ", ".join(
            f"{k} {findings[k].final_differing:,} px" for k in partly
        )
    unexplained = [k for k, f in findings.items() if f.state == "unexplained"]
    if unexplained:
        text += (
            "; not explained: "
            + ", ".join(
                f"{k} ({findings[k].final_differing:,} px, "
                f"{findings[k].final_differing / findings[k].pixels:.0%})"
                for k in unexplained
            )
            + ": a new bug, not a quirk or a named mistake"
        )
    return head + text


def cause_list(found: Found, findings: dict[str, EffectFinding]) -> list[dict[str, Any]]:
    """Every cause named, as the JSON's `causes`: the mirror, the writer's transforms, then
    each step, with the effects it explains and their evidence (pixels differing and FLIP,
    before and after), and a sentence naming the step of the algorithm."""
    out = []
    if found.mirrored:
        out.append(_cause(f"mirrored {found.mirrored}", "image", "image writing (pixel order)", {}))
    for c in found.images:
        ev = {
            k: {"differing": [g.differed, g.differed - g.claimed], "flip": list(g.flips)}
            for k, g in c.gates.items()
        }
        out.append(_cause(c.name, "image", "image writing", ev))
    for st in found.steps:
        ev = {
            k: {
                "differing": [findings[k].start_differing, findings[k].final_differing],
                "flip": [findings[k].start_flip, findings[k].final_flip],
            }
            for k in st.explains
            if k in findings
        }
        cause = _cause(st.cause, st.kind, st.step or st.change, ev, st.change + _alike(st))
        out.append(
            cause
            | {
                "alternatives": list(st.alternatives),
                "alternative_names": list(st.alternative_names),
            }
        )
    return out


def _cause(name: str, kind: str, step: str, ev: dict[str, Any], change: str = "") -> dict[str, Any]:
    words = [f"{step}: {change or name}"]
    for k, e in ev.items():
        (n0, n1), (f0, f1) = e["differing"], e["flip"]
        words.append(f"{k} {n0:,} px differed, {n1:,} after; FLIP {f0:.3f} -> {f1:.3f}")
    return {
        "name": name,
        "kind": kind,
        "effects": list(ev),
        "evidence": ev,
        "sentence": "; ".join(words),
    }


def _alike(st: Step) -> str:
    if not st.alternatives:
        return ""
    return f" (or, as well: {' or '.join(st.alternatives)}; the image cannot tell them apart)"


def _sentences(found: Found, findings: dict[str, EffectFinding], text: str) -> list[str]:
    out = [text] + [f.sentence for f in findings.values()]
    if found.invisible:
        out.append(
            "not visible in this scene (toggling them changes no pixel): "
            + ", ".join(f"Q{q}" for q in sorted(found.invisible))
        )
    if found.skipped:
        out.append(
            f"skipped ({len(found.skipped)} candidates ran past their time limit or ray budget, "
            "so they were not judged): " + "; ".join(found.skipped)
        )
    if found.untested:
        out.append(
            "not searched (this rtdemo cannot render them): "
            + ", ".join(f"Q{q}" for q in sorted(found.untested))
        )
    return out


def _where_sentences(where: dict[str, Any]) -> list[str]:
    """The localisation in words: the whole image's step, then each unexplained effect's
    where it names another."""
    overall = where.get("overall", [])
    out = [f"where the error lives: {o['sentence']}" for o in overall]
    named = {o["step"] for o in overall}
    for effect, e in where.get("effects", {}).items():
        if e["step"] not in named:
            out.append(f"where the error lives in the {effect}: {e['sentence']}")
    return out


def diagnosis(
    scene: Scene,
    image_path: str,
    found: Found,
    findings: dict[str, EffectFinding],
    text: str,
    facts: dict[str, Any],
) -> Diagnosis:
    """The record; facts: mode_objectives, renders, seconds and candidates (by name: the
    start, each step's and the result) of the search."""
    c = found.result
    hidden = found.invisible | found.untested
    mirrored = found.mirrored
    return Diagnosis(
        scene=scene.name,
        image=image_path,
        start=found.begin.name,
        mode_objectives=facts["mode_objectives"],
        result=c.name,
        rtdemo_args=c.rtdemo_args(),
        scene_changes=c.scene_changes(),
        mirrored=mirrored,
        mode=c.mode,
        quirks_present=sorted(set(c.quirks) - hidden),
        quirks_absent=sorted(set(range(1, QUIRK_COUNT + 1)) - c.quirks - hidden),
        quirks_invisible=sorted(found.invisible),
        quirks_untested=sorted(found.untested),
        effects_off=[e for e in SWITCHABLE_EFFECTS if e in c.effects_off],
        max_depth=c.depth(scene),
        depth_or_more=found.or_more,
        mistakes=(["mirrored"] if mirrored else []) + c.ordered_mistakes() + aliases(c, scene),
        steps=found.steps,
        effects=findings,
        unexplained=[k for k, f in findings.items() if f.state == "unexplained"],
        matches=all(f.matched for f in findings.values()),
        summary=text,
        sentences=_sentences(found, findings, text)
        + _where_sentences(facts.get("localisation", {})),
        renders=facts["renders"],
        seconds=facts["seconds"],
        candidate=c,
        candidates=facts["candidates"],
        skipped=list(found.skipped),
        image_transforms=[c.name for c in found.images],
        image_transform_specs=[list(c.spec) for c in found.images],
        cause_list=cause_list(found, findings),
        where=facts.get("localisation", {}),
    )
