"""`rtval stress`: the stress atlas."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.cli.common import add_cache_argument, size_type


def run_stress(args: argparse.Namespace) -> int:
    from compare.render.cache import RenderCache
    from compare.render.progress import Progress
    from compare.stress import atlas as stress
    from scene_model.builtin import built_in, built_in_names

    stress_scenes = [built_in(n) for n in built_in_names() if n.startswith("stress/")]
    files = [Path(p) for p in args.scenes] if args.scenes else stress_scenes
    data = stress.run_stress(
        files,
        Path(args.out),
        size=args.size,
        cache=RenderCache(args.cache),
        progress=Progress(sys.stderr),
    )
    print(stress.table(data))
    print(Path(args.out) / "index.html")
    return 0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "stress",
        help="render the stress scenes with every method; NaN, error and stability atlas",
        description="Renders each stress scene with every demo mode and backend and both Mitsuba "
        "references; reports NaN/Inf, error against the Whitted reference and stability "
        "under tiny nudges; writes an atlas to OUT/index.html.",
    )
    p.add_argument(
        "scenes",
        nargs="*",
        help="scene files or built-in names (default: every built-in stress/ scene)",
    )
    p.add_argument("--out", default="reports/stress", help="output folder (default reports/stress)")
    p.add_argument(
        "--size",
        type=size_type,
        default=(160, 120),
        metavar="WxH",
        help="render size (default 160x120)",
    )
    add_cache_argument(p)
    p.set_defaults(func=run_stress)
