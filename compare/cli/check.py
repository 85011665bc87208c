"""`rtval check`: the regression check against stored baselines."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.cli.common import add_cache_argument, size_type


def run_check(args: argparse.Namespace) -> int:
    from compare.apps import check
    from compare.render.progress import Progress

    if args.against and args.update:
        raise ValueError("--update rewrites baselines; it cannot be combined with --against")
    modes = args.modes.split(",") if args.modes else None
    results = check.run_check(
        scenes=args.scenes,
        modes=modes,
        backends=args.backends.split(","),
        baseline_dir=Path(args.baseline),
        size=args.size,
        update=args.update,
        rtdemo=args.rtdemo,
        against=args.against,
        cache_dir=args.cache,
        progress=Progress(sys.stderr),
    )
    print(check.table(results))
    if args.json:
        check.write_json(results, Path(args.json))
    if args.junit:
        check.write_junit(results, Path(args.junit))
    updated = [r.name for r in results if r.updated]
    if updated:
        print(f"updated baselines: {', '.join(updated)}", file=sys.stderr)
    return check.exit_code(results)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from compare.apps.check import DEFAULT_SCENES, DEFAULT_SIZE

    p = sub.add_parser(
        "check",
        help="regression check of the demo against stored baselines",
        description="Renders the demo on the scene set for every backend and mode asked for "
        "and compares each render with its baseline under per-scene tolerances "
        "(BASELINE/tolerances.json), or with --against MODEL against a target model. "
        "A missing baseline fails. Exit 0 pass, 1 warn, 2 fail.",
    )
    p.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES), help="scene files")
    p.add_argument(
        "--modes",
        default=None,
        help="comma-separated modes (default all; with a demo --against, the model itself)",
    )
    p.add_argument(
        "--against",
        metavar="MODEL",
        default=None,
        help="judge each render against a target model instead of its baseline (demo models: "
        "exact match; mitsuba: the default rubric)",
    )
    p.add_argument("--backends", default="cpu", help="comma-separated backends (default cpu)")
    p.add_argument(
        "--baseline", default="tests/baselines", help="baseline folder (default tests/baselines)"
    )
    p.add_argument(
        "--size",
        type=size_type,
        default=DEFAULT_SIZE,
        metavar="WxH",
        help=f"render size (default {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]})",
    )
    p.add_argument(
        "--update", action="store_true", help="rewrite new or failing baselines, say which"
    )
    p.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    p.add_argument("--junit", metavar="OUT.xml", help="write the results as JUnit XML")
    p.add_argument(
        "--rtdemo", default=None, help="the rtdemo executable to check (default: the installed one)"
    )
    add_cache_argument(p)
    p.set_defaults(func=run_check)
