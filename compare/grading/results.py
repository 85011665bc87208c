"""What grading one student gives: a result per scene and one per student, as stored in
OUT/results/<slug>.json (README "Grading a class"; `rtval grade --explain` reads it back).

to_json() writes exactly the fields (and field order) the results files have always had;
from_json() is the strict inverse: a stored result missing a field, or with a field of the
wrong type, is not a result (the student is graded again). Reading a stored result never
follows a link, never opens anything but a regular file and never reads more than
MAX_RESULT_BYTES: a planted link to /dev/zero or a FIFO at that name is a bad result, not a
hang or an exhausted machine.
"""

from __future__ import annotations

import json
import os
import stat
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from safe_files.paths import UnsafePathError, describe_mode, read_bounded

# A result with a diagnosis is ~16 KB; a class of programs keeps 2 x 64 KiB of logs per run.
MAX_RESULT_BYTES = 16 << 20

_SCENE_KEYS = ("scene", "model", "diagnosis", "status", "score", "reason")
_JUDGED_KEYS = ("verdict", "sentences", "nan_pixels", "diagnosis_detail")


class MalformedResult(ValueError):
    """JSON that is not a result (the message names the field)."""


class BadResult(ValueError):
    """A file at a result's name that is not a stored result: `why` says what it is."""

    def __init__(self, path: Path, why: str) -> None:
        super().__init__(f"{path}: {why}")
        self.path = path
        self.why = why


@dataclass(frozen=True)
class SceneResult:
    """One scene of one submission. A scene that was judged (its image read and compared)
    has a verdict (scoring.Score.as_dict(), with the exact match's facts); one that was not
    (missing, unreadable, wrong size, a program that gave no image) has only a reason."""

    scene: str
    model: str
    status: str  # pass | fail | error | missing
    score: float
    reason: str
    diagnosis: str = ""  # the gradebook's cell: what a failing image looks like
    verdict: dict[str, Any] | None = None  # None: not judged
    sentences: tuple[str, ...] = ()
    nan_pixels: int = 0
    diagnosis_detail: dict[str, Any] | None = None  # the page's evidence

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {k: getattr(self, k) for k in _SCENE_KEYS}
        if self.verdict is not None:
            out |= {
                "verdict": self.verdict,
                "sentences": list(self.sentences),
                "nan_pixels": self.nan_pixels,
                "diagnosis_detail": self.diagnosis_detail,
            }
        return out

    @classmethod
    def from_json(cls, d: Any) -> SceneResult:
        if not isinstance(d, dict):
            raise MalformedResult("a scene is not an object")
        judged = "verdict" in d
        return cls(
            scene=_field(d, "scene", str),
            model=_field(d, "model", str),
            status=_field(d, "status", str),
            score=float(_field(d, "score", (int, float))),
            reason=_field(d, "reason", str),
            diagnosis=_field(d, "diagnosis", str),
            verdict=_field(d, "verdict", dict) if judged else None,
            sentences=tuple(_field(d, "sentences", list)) if judged else (),
            nan_pixels=_field(d, "nan_pixels", int) if judged else 0,
            diagnosis_detail=_field(d, "diagnosis_detail", (dict, type(None))) if judged else None,
        )


@dataclass(frozen=True)
class StudentResult:
    """One student: every scene, the mean score and why it fails. `resumed` and `warnings`
    are for this run's progress lines only and are never stored."""

    student: str
    key: str  # task_key: the inputs this result was made from
    status: str  # pass | fail
    score: float
    model: str  # the models judged against, comma-separated
    reasons: str
    diagnosis: str
    scenes: tuple[SceneResult, ...]
    rubric: str  # the rubric's source
    seconds: float
    page: str  # relative to OUT
    program: dict[str, Any] | None = None  # a program submission's build and runs
    resumed: bool = False
    warnings: tuple[str, ...] = field(default=(), compare=False)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "student": self.student,
            "key": self.key,
            "status": self.status,
            "score": self.score,
            "model": self.model,
            "reasons": self.reasons,
            "diagnosis": self.diagnosis,
            "scenes": [s.to_json() for s in self.scenes],
            "rubric": self.rubric,
            "seconds": self.seconds,
            "page": self.page,
        }
        if self.program is not None:
            out["program"] = self.program
        return out

    def dumps(self) -> str:
        """The results file's text (numpy scalars in a verdict are written as numbers)."""
        return json.dumps(self.to_json(), indent=2, default=float)

    @classmethod
    def from_json(cls, d: Any) -> StudentResult:
        if not isinstance(d, dict):
            raise MalformedResult("not a JSON object")
        return cls(
            student=_field(d, "student", str),
            key=_field(d, "key", str),
            status=_field(d, "status", str),
            score=float(_field(d, "score", (int, float))),
            model=_field(d, "model", str),
            reasons=_field(d, "reasons", str),
            diagnosis=_field(d, "diagnosis", str),
            scenes=tuple(SceneResult.from_json(s) for s in _field(d, "scenes", list)),
            rubric=_field(d, "rubric", str),
            seconds=float(_field(d, "seconds", (int, float))),
            page=_field(d, "page", str),
            program=_field(d, "program", dict) if "program" in d else None,
        )

    def as_resumed(self) -> StudentResult:
        return replace(self, resumed=True)


def _field(d: dict[str, Any], key: str, kind: type | tuple[type, ...]) -> Any:
    if key not in d:
        raise MalformedResult(f"no field '{key}'")
    value = d[key]
    if not isinstance(value, kind) or (kind in (int, (int, float)) and isinstance(value, bool)):
        raise MalformedResult(f"field '{key}' has the wrong type")
    return value


def read_result(path: Path) -> StudentResult | None:
    """The result stored at `path`; None when there is none. A file that is there but is
    not a result (a link, a FIFO, a device, too large, truncated, not JSON, a field missing)
    raises BadResult naming the file and why."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as e:
        raise BadResult(path, f"cannot read: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):  # a link is never followed, whatever it points to
        raise BadResult(path, f"is {describe_mode(st.st_mode)}, not a stored result")
    try:
        raw = read_bounded(path, MAX_RESULT_BYTES)
    except UnsafePathError as e:  # grew past the bound, or swapped for a special file
        raise BadResult(path, str(e).removeprefix(f"{path}: ")) from None
    try:
        return StudentResult.from_json(json.loads(raw))
    except MalformedResult as e:
        raise BadResult(path, str(e)) from None
    except (ValueError, RecursionError) as e:
        raise BadResult(path, f"not valid JSON ({e})") from None


def discard_special(path: Path) -> None:
    """Removes what is at a result's name when it is not a regular file (a link itself, never
    what it points to; a FIFO; a socket), so that a result can be written there. A folder
    stays, and writing the result then fails naming it."""
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return
    if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
        os.unlink(path)
