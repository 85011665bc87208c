"""`rtval check`: the regression check against stored baselines."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.cli.common import add_cache_argument, size_type


def run_check(args: argparse.Namespace) -> int:
    from compare.apps import check

    results = check.run_check(
        scenes=args.scenes,
        modes=args.modes.split(","),
        backends=args.backends.split(","),
        baseline_dir=Path(args.baseline),
        size=args.size,
        update=args.update,
        rtdemo=args.rtdemo,
        cache_dir=args.cache,
        progress=lambda m: print(m, file=sys.stderr),
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
    from compare.apps.check import DEFAULT_MODES, DEFAULT_SCENES, DEFAULT_SIZE

    p = sub.add_parser(
        "check",
        help="regression check of the demo against stored baselines",
        description="Renders the demo on the scene set for every backend and mode asked for "
        "and compares each render with its baseline under per-scene tolerances "
        "(BASELINE/tolerances.json). A missing baseline fails. Exit 0 pass, 1 warn, "
        "2 fail.",
    )
    p.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES), help="scene files")
    p.add_argument(
        "--modes", default=",".join(DEFAULT_MODES), help="comma-separated modes (default all)"
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
