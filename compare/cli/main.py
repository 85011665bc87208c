"""`rtval`: the validation suite's command line. Each command lives in its own module
(compare/cli/<command>.py); this one builds the parser and maps errors to exit codes."""

from __future__ import annotations

import os
import signal
import sys

from compare import interrupts as interrupt
from compare.cli import (
    allocator,
    cache,
    check,
    compare,
    diagnose,
    export,
    grade,
    reference,
    report,
    stress,
    ztest,
)
from compare.cli.common import EXIT_USAGE, Parser, error_words, resolve_scene_arguments
from compare.errors import ToolError
from compare.judge.images import ImageError
from compare.judge.rubric import RubricError
from mitsuba_ref.drjit_env import MitsubaUnavailable
from scene_model.scene import SceneError

EXIT_SCENE = 3
EXIT_IO = 4


def build_parser() -> Parser:
    parser = Parser(
        prog="rtval",
        description="Holds the course paper's ray tracer against Mitsuba 3 and reports where and "
        "why they differ.",
        epilog="Exit codes: 0 ok (compare/check: pass), 1 warn or renderer failure, 2 fail, "
        "3 invalid scene (compare/check: size mismatch), 4 unreadable input or unwritable "
        "output, 64 bad arguments.",
    )
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=Parser
    )
    report.register(sub)
    export.register(sub)
    reference.register(sub)
    compare.register(sub)
    ztest.register(sub)
    check.register(sub)
    stress.register(sub)
    grade.register(sub)
    diagnose.register(sub)
    cache.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    allocator.use_one_arena()  # before any thread of ours starts (allocator.py)
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        # SIGTERM and SIGHUP unwind like SIGINT: every atomic writer removes its temporary
        # file and children are killed, instead of the process vanishing mid-write.
        with interrupt.stop_guard():
            resolve_scene_arguments(args)
            code = int(args.func(args))
        sys.stdout.flush()  # here, not at exit, so that a reader gone is a BrokenPipeError below
        return code
    except BrokenPipeError:  # `rtval ... | head`: the reader has gone; say nothing more
        # (before OSError, of which it is one)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # as a shell reports a command ended by SIGPIPE
    except SceneError as e:
        print(f"rtval: error: {error_words(e)}", file=sys.stderr)
        return EXIT_SCENE
    except (ImageError, OSError, RubricError) as e:
        print(f"rtval: error: {error_words(e)}", file=sys.stderr)
        return EXIT_IO
    except ValueError as e:  # invalid combinations of options found below argparse
        print(f"rtval: error: {error_words(e)}", file=sys.stderr)
        return EXIT_USAGE
    except (ToolError, MitsubaUnavailable) as e:
        print(f"rtval: error: {error_words(e)}", file=sys.stderr)
        return 1
    except interrupt.Stopped as e:
        print(f"rtval: interrupted ({signal.Signals(e.signum).name})", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        print("rtval: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
