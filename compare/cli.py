"""`rtval`: the validation suite's command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.images import ImageError
from compare.tools import ToolError
from mitsuba_ref.scene import SceneError

EXIT_USAGE = 2
EXIT_SCENE = 3
EXIT_IO = 4


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, e.g. 320x240, got {text!r}")
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise argparse.ArgumentTypeError(f"each side must be 1-16384, got {text!r}")
    return w, h


def _cmd_report(args: argparse.Namespace) -> int:
    from compare.report import build_report

    index = build_report(args.scene, args.reports_dir, size=args.size,
                         progress=lambda m: print(m, file=sys.stderr))
    print(index)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rtval",
        description="Holds the course paper's ray tracer against Mitsuba 3 and reports where and why they differ.",
        epilog="Exit codes: 0 ok, 2 bad arguments, 3 invalid scene, 4 unreadable input or unwritable output.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("report", help="render a scene with every renderer and write reports/<scene>/index.html",
                       description="Renders SCENE with every renderer and writes reports/<scene>/index.html, report.json and images.")
    p.add_argument("scene", nargs="?", default="scenes/paper.json", help="scene file (default: scenes/paper.json)")
    p.add_argument("--reports-dir", type=Path, default=Path("reports"), help="where reports go (default: reports)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="override the camera's image size")
    p.set_defaults(func=_cmd_report)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except SceneError as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except (ImageError, OSError) as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return EXIT_IO
    except ToolError as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("rtval: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
