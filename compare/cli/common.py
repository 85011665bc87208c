"""What every rtval command shares: the parser class and argument types."""

from __future__ import annotations

import argparse
import difflib
import math
import os
import re
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from compare.judge.target_model import ModelError, TargetModel, parse_model
from scene_model.builtin import scene_path

EXIT_USAGE = 64  # EX_USAGE: kept apart from compare's 0-4 verdict codes


_INVALID_CHOICE = re.compile(r"invalid choice: '([^']*)' \(choose from (.*)\)$")


def did_you_mean(word: str, known: Iterable[str]) -> str:
    """ " (did you mean X?)" for the known word closest to a mistyped one; "" when none is
    close."""
    close = difflib.get_close_matches(word, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


class Parser(argparse.ArgumentParser):
    """Bad arguments exit with 64, so that 2 always means "fail" for compare and check. A
    mistyped command, choice or option is answered with the closest known one."""

    def error(self, message: str) -> NoReturn:
        m = _INVALID_CHOICE.search(message)
        if m:
            choices = re.findall(r"'([^']*)'", m.group(2))
            message += did_you_mean(m.group(1), choices)
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        sys.exit(EXIT_USAGE)

    def parse_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> argparse.Namespace:
        """As argparse's, but an unknown option is refused by the command it was given to
        (its usage, and the closest of its own options)."""
        parsed, extras = self.parse_known_args(args, namespace)
        if not extras:
            return parsed
        owner = self._command_parser(parsed) or self
        known = [o for a in owner._actions for o in a.option_strings]
        words = [f"{w}{did_you_mean(w, known) if w.startswith('-') else ''}" for w in extras]
        owner.error(f"unrecognized arguments: {' '.join(words)}")

    def _command_parser(self, parsed: argparse.Namespace) -> argparse.ArgumentParser | None:
        """The sub-command's parser that `parsed` went through, if any."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = getattr(parsed, action.dest or "", None)
                parser = action.choices.get(chosen) if isinstance(chosen, str) else None
                return parser if isinstance(parser, argparse.ArgumentParser) else None
        return None


def size_type(text: str, smallest: int = 1) -> tuple[int, int]:
    """WIDTHxHEIGHT, each side `smallest`-16384."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT, e.g. 320x240, got {text!r}"
        ) from None
    if not (smallest <= w <= 16384 and smallest <= h <= 16384):
        raise argparse.ArgumentTypeError(f"each side must be {smallest}-16384, got {text!r}")
    return w, h


# A report measures SSIM (an 11 x 11 window, and a 5-pixel border left out) in every effect.
REPORT_MIN_SIDE = 32


def report_size_type(text: str) -> tuple[int, int]:
    """WIDTHxHEIGHT for a report: each side REPORT_MIN_SIDE-16384."""
    return size_type(text, REPORT_MIN_SIDE)


def _number(
    convert: Callable[[str], Any], expected: str, ok: Callable[[Any], bool]
) -> Callable[[str], Any]:
    """An argparse type: a number `convert` reads and `ok` accepts; else "expected <expected>"."""

    def parse(text: str) -> Any:
        try:
            v = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        if not ok(v):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return v

    return parse


positive_int = _number(int, "a positive integer", lambda v: v > 0)
positive_float = _number(float, "a positive number", lambda v: 0 < v < math.inf)
# Mitsuba's samplers take 32-bit seeds.
seed_type = _number(int, "an integer 0..4294967295", lambda v: 0 <= v < 2**32)


def target_model_type(text: str) -> TargetModel:
    """--against MODEL: parsed once, here (a bad model is a usage error before any render)."""
    try:
        return parse_model(text)
    except ModelError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def resolve_scene_arguments(args: argparse.Namespace) -> None:
    """Every command's scene arguments (`scene`, `scenes`), named once: a file or a built-in
    scene (scene_model/builtin.py). Raises SceneError: exit 3, as for a scene that is bad."""
    for name in ("scene", "scenes"):
        value = getattr(args, name, None)
        if isinstance(value, str):
            setattr(args, name, str(scene_path(value)))
        elif isinstance(value, list):
            setattr(args, name, [str(scene_path(v)) for v in value])


def error_words(e: BaseException) -> str:
    """An error as a sentence for a person: an OSError as "PATH: reason" (never Python's
    "[Errno 2] ... 'PATH'"), anything else as its own message."""
    if isinstance(e, OSError) and e.strerror and e.filename is not None:
        more = f" -> {os.fsdecode(e.filename2)}" if e.filename2 is not None else ""
        return f"{os.fsdecode(e.filename)}{more}: {e.strerror}"
    if isinstance(e, OSError) and e.strerror:
        return e.strerror
    return str(e)


def check_output_folders(outputs: Iterable[tuple[str, str | Path | None]]) -> None:
    """Before any work: the folder of each output (option, path) exists. Otherwise the
    refusal would come after every render, naming the temporary file beside the output."""
    for option, path in outputs:
        if path is not None and not Path(path).absolute().parent.is_dir():
            raise OSError(
                f"{option} {path}: cannot write: folder '{Path(path).parent}' does not exist"
            )


def stderr_progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def add_cache_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--cache",
        metavar="DIR",
        default=None,
        help="the render cache shared by every command (default: $RTVAL_CACHE, else "
        "$XDG_CACHE_HOME/rtval, else ~/.cache/rtval); see `rtval cache`",
    )
