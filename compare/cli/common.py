"""What every rtval command shares: the parser class and argument types."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable
from typing import Any

from compare.judge.target_model import ModelError, TargetModel, parse_model
from scene_model.builtin import scene_path

EXIT_USAGE = 64  # EX_USAGE: kept apart from compare's 0-4 verdict codes


class Parser(argparse.ArgumentParser):
    """Bad arguments exit with 64, so that 2 always means "fail" for compare and check."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        sys.exit(EXIT_USAGE)


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
