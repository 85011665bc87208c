"""The grading rubric: a TOML file a teacher edits.

    [rubric]
    against = "classic"      # the target model (target_model.py): mitsuba, classic+Q2, ...
    pass_score = 60          # overall score needed to pass (0-100)
    flip_at_zero = 0.5       # an effect's score is 100 (1 - FLIP / flip_at_zero)

    [effects.reflection]     # any of: background emitter direct shadow reflection refraction edges
    min_ssim = 0.5
    max_flip = 0.15
    weight = 2.0             # multiplies the effect's pixel share in the overall score (0-1000)

    [program]                # a class of programs (compare/grading/programs.py, docs/sandbox.md)
    build = "g++ -O2 -o rt *.cpp"
    run = "./rt {scene} {out}"   # the placeholders of rtval check --renderer
    output = "untitled.ppm"  # or: the fixed file it writes instead of {out}
    output_format = "ppm"    # what {out} is: exr, pfm, png, ppm

    [program.limits]         # per build and per run; the flags win
    build_timeout = 120      # seconds
    run_timeout = 60
    cpu = 600                # CPU seconds per process
    memory = "2G"            # address space per process
    file_size = "256M"       # the largest file it may write
    processes = 128
    open_files = 256

Every error names the file and the line.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from compare.judge.effects import EFFECTS
from compare.judge.scoring import FLIP_AT_ZERO_SCORE, EffectRule
from compare.judge.target_model import ModelError, parse_model
from compare.sizes import parse_size
from safe_files.paths import read_bounded

# Weights up to this keep the weighted sums of effect scores finite for any image size.
MAX_WEIGHT = 1000.0

DEFAULT_RUBRIC_TEXT = """\
# rtval default rubric: every effect needs mean FLIP <= 0.10 and SSIM >= 0.5 to pass;
# the overall score (pixel-weighted effect scores) must reach 60 to pass.
[rubric]
pass_score = 60
flip_at_zero = 0.5
"""


_Fail = Callable[[str, str | None, str | None], "RubricError"]  # message, key, section


class RubricError(ValueError):
    """An invalid or unreadable rubric; the message names the file and the line.

    Parameters
    ----------
    message : str
        What is wrong, naming the file (and the line, for an invalid one).
    """


@dataclass(frozen=True)
class Rubric:
    """A grading rubric, checked (the module's docstring shows the TOML it is read from).

    Attributes
    ----------
    pass_score : float
        The overall score needed to pass, 0 to 100; default 60.
    flip_at_zero : float
        The mean FLIP that scores 0; default FLIP_AT_ZERO_SCORE (0.5).
    effects : dict[str, EffectRule]
        The [effects.NAME] rules by effect; one not listed gets ``EffectRule()`` (`rule`).
        Default empty.
    source : str
        Where it was read from: a path, or "default rubric" (the default).
    digest : str
        The first 16 hex digits of its text's SHA-256; default "".
    against : str or None
        The target model's canonical name; default None: the command's default.
    program : dict[str, Any] or None
        The [program] table, checked, its "limits" a dict; default None: the class hands
        in images, not programs.
    """

    pass_score: float = 60.0
    flip_at_zero: float = FLIP_AT_ZERO_SCORE
    effects: dict[str, EffectRule] = field(default_factory=dict)
    source: str = "default rubric"
    digest: str = ""
    against: str | None = None
    program: dict[str, Any] | None = None

    def rule(self, effect: str) -> EffectRule:
        return self.effects.get(effect, EffectRule())


def _line_of(text: str, key: str | None, section: str | None) -> int:
    """1-based line of `key = ...` inside [section], or of the [section] header (key None)."""
    lines = text.splitlines()
    start = 0
    if section:
        pattern = re.compile(
            r"^\s*\[\s*" + re.escape(section).replace(r"\.", r"\s*\.\s*") + r"\s*\]"
        )
        start = next((i for i, line in enumerate(lines) if pattern.match(line)), 0)
    if key is None:
        return start + 1
    for i in range(start, len(lines)):
        if re.match(r"^\s*" + re.escape(key) + r"\s*=", lines[i]):
            return i + 1
    return start + 1


def parse_rubric(text: str, source: str = "<rubric>") -> Rubric:
    """Parse and check a rubric's TOML text: every table, key, type and range.

    Parameters
    ----------
    text : str
        The rubric, TOML (the module's docstring shows its tables).
    source : str, optional
        Its name in error messages and `Rubric.source`; default "<rubric>".

    Returns
    -------
    Rubric

    Raises
    ------
    RubricError
        Invalid TOML; an unknown table, key, effect or target model; a value of the wrong
        type or out of range; or every effect given weight 0. The message names `source`
        and the line.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise RubricError(f"{source}: invalid TOML: {e}") from None
    except RecursionError:  # tomllib recurses per nested array or inline table
        raise RubricError(f"{source}: invalid TOML: nested too deeply") from None

    def fail(msg: str, key: str | None, section: str | None) -> RubricError:
        return RubricError(f"{source}: line {_line_of(text, key, section)}: {msg}")

    for key in raw:
        if key not in ("rubric", "effects", "program"):
            raise fail(
                f"unknown table or key '{key}' (expected [rubric], [effects.NAME], [program])",
                key,
                None,
            )
    values, against = _rubric_table(raw.get("rubric", {}), fail)
    effects = _effect_rules(raw.get("effects", {}), fail)
    if all(name in effects and effects[name].weight == 0 for name in EFFECTS):
        raise fail("every effect has weight 0: at least one must count", None, "effects")
    return Rubric(
        pass_score=values.get("pass_score", 60.0),
        flip_at_zero=values.get("flip_at_zero", FLIP_AT_ZERO_SCORE),
        effects=effects,
        source=source,
        digest=hashlib.sha256(text.encode()).hexdigest()[:16],
        against=against,
        program=_program(raw["program"], fail) if "program" in raw else None,
    )


def _rubric_table(top: dict[str, Any], fail: _Fail) -> tuple[dict[str, float], str | None]:
    """[rubric]: its numbers (pass_score, flip_at_zero) and the model named by `against`."""
    values: dict[str, float] = {}
    against = None
    for key, value in top.items():
        if key == "against":
            if not isinstance(value, str):
                raise fail(f"against must be a string, got {value!r}", key, "rubric")
            try:
                against = parse_model(value).name
            except ModelError as e:
                raise fail(str(e), key, "rubric") from None
            continue
        if key not in ("pass_score", "flip_at_zero"):
            raise fail(
                f"unknown key '{key}' in [rubric] (expected against, pass_score, flip_at_zero)",
                key,
                "rubric",
            )
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise fail(f"{key} must be a number (finite), got {value!r}", key, "rubric")
        values[key] = float(value)
    if not 0 <= values.get("pass_score", 60) <= 100:
        raise fail("pass_score must be from 0 to 100", "pass_score", "rubric")
    if not values.get("flip_at_zero", FLIP_AT_ZERO_SCORE) > 0:
        raise fail("flip_at_zero must be > 0", "flip_at_zero", "rubric")
    return values, against


def _effect_rules(tables: dict[str, Any], fail: _Fail) -> dict[str, EffectRule]:
    """[effects.NAME]: each effect's rule, every value checked for its range."""
    effects: dict[str, EffectRule] = {}
    for name, table in tables.items():
        section = f"effects.{name}"
        if name not in EFFECTS:
            raise fail(
                f"unknown effect '{name}' (expected one of {', '.join(EFFECTS)})", None, section
            )
        if not isinstance(table, dict):
            raise fail(f"[{section}] must be a table", None, section)
        rule: dict[str, float] = {}
        for key, value in table.items():
            if key not in ("min_ssim", "max_flip", "weight"):
                raise fail(
                    f"unknown key '{key}' in [{section}] (expected min_ssim, max_flip, weight)",
                    key,
                    section,
                )
            lo = -1.0 if key == "min_ssim" else 0.0  # SSIM ranges over [-1, 1]
            hi = {"min_ssim": 1.0, "weight": MAX_WEIGHT}.get(key, math.inf)
            # `not lo <= v < hi` also refuses NaN (TOML has nan and inf), which compares false
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (lo <= value <= hi and math.isfinite(value))
            ):
                span = f"from {lo:g} to {hi:g}" if hi < math.inf else f">= {lo:g}"
                raise fail(f"{key} must be a number {span} (finite), got {value!r}", key, section)
            rule[key] = float(value)
        effects[name] = EffectRule(**rule)
    return effects


PROGRAM_KEYS = ("build", "run", "output", "output_format")
# [program.limits]: key -> its kind (seconds, a size such as "2G", a count)
PROGRAM_LIMITS = {
    "build_timeout": "seconds",
    "run_timeout": "seconds",
    "cpu": "seconds",
    "memory": "size",
    "file_size": "size",
    "processes": "count",
    "open_files": "count",
    "disk": "size",
}


def limit_value(key: str, value: Any) -> float | int:
    """A program limit (a [program.limits] value or a flag's) checked for its kind."""

    kind = PROGRAM_LIMITS[key]
    if kind == "size":
        if isinstance(value, bool) or not isinstance(value, (str, int)):
            raise ValueError(f'{key} must be a size such as "2G", got {value!r}')
        return parse_size(value)
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "count":
        ok = ok and isinstance(value, int)
    if not (ok and 0 < value < 1e7):  # also refuses NaN
        what = "a whole number from 1" if kind == "count" else "a number of seconds > 0"
        raise ValueError(f"{key} must be {what}, got {value!r}")
    return value  # type: ignore[no-any-return]


def _program(table: Any, fail: Any) -> dict[str, Any]:
    """[program] and [program.limits], their keys and types checked (the commands themselves
    are parsed when grading starts, with the flags)."""
    if not isinstance(table, dict):
        raise fail("[program] must be a table", None, "program")
    for key, value in table.items():
        if key == "limits":
            continue
        if key not in PROGRAM_KEYS:
            raise fail(
                f"unknown key '{key}' in [program] (expected {', '.join(PROGRAM_KEYS)}, limits)",
                key,
                "program",
            )
        if not isinstance(value, str) or not value.strip():
            raise fail(f"{key} must be a non-empty string, got {value!r}", key, "program")
    limits = table.get("limits", {})
    if not isinstance(limits, dict):
        raise fail("[program.limits] must be a table", None, "program.limits")
    for key, value in limits.items():
        if key not in PROGRAM_LIMITS:
            raise fail(
                f"unknown key '{key}' in [program.limits] (expected {', '.join(PROGRAM_LIMITS)})",
                key,
                "program.limits",
            )
        try:
            limit_value(key, value)
        except ValueError as e:
            raise fail(str(e), key, "program.limits") from None
    return {**table, "limits": dict(limits)}


def read_rubric(path: str | Path | None) -> tuple[str, str]:
    """(text, source) of the rubric at `path` (None: the default rubric). A regular file of
    at most 1 MiB of UTF-8: never a FIFO or a device, read once."""
    if path is None:
        return DEFAULT_RUBRIC_TEXT, "default rubric"

    p = Path(path)
    try:
        text = read_bounded(p, 1 << 20).decode("utf-8")
    except OSError as e:  # the message names the path
        raise RubricError(f"cannot read the rubric: {e}") from None
    except UnicodeDecodeError as e:
        raise RubricError(f"{p}: the rubric is not UTF-8 text: {e}") from None
    return text, str(p)


def load_rubric(path: str | Path | None) -> Rubric:
    """Read and check the rubric at `path`, or the default rubric.

    Parameters
    ----------
    path : str, Path or None
        A regular file of at most 1 MiB of UTF-8 TOML, read once (never a FIFO or a
        device). None: the default rubric (pass_score 60, flip_at_zero 0.5, the default
        EffectRule for every effect).

    Returns
    -------
    Rubric

    Raises
    ------
    RubricError
        The file cannot be read (missing, not a regular file, over 1 MiB, not UTF-8) or
        the rubric is invalid (parse_rubric).
    """
    return parse_rubric(*read_rubric(path))
