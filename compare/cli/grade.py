"""`rtval grade`: grading a class."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.cli.common import add_cache_argument, positive_int, size_type


def run_grade(args: argparse.Namespace) -> int:
    from compare.apps import grade
    from compare.render.progress import Progress

    out = Path(args.out)
    if args.explain:
        print(grade.explain(out, args.explain))
        return 0
    if not args.submissions or not args.scene:
        raise ValueError("grade needs SUBMISSIONS and at least one --scene (or --explain ID)")
    scenes = [
        Path(s) if Path(s).suffix == ".json" else Path("scenes") / f"{s}.json" for s in args.scene
    ]
    results = grade.run_grading(
        Path(args.submissions),
        scenes,
        out,
        rubric_path=args.rubric,
        executor=args.executor,
        scheduler=args.scheduler,
        jobs=args.jobs,
        size=args.size,
        against=args.against,
        diagnose=not args.no_diagnose,
        cache_dir=args.cache,
        progress=Progress(sys.stderr),
    )
    passed = sum(r["status"] == "pass" for r in results)
    print(f"{passed} passed, {len(results) - passed} failed")
    print(out / "gradebook.csv")
    return 0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "grade",
        help="grade a folder of submissions: per-student pages and a gradebook",
        description="Grades every submission (an image named after the student, or a folder of "
        "images named after the scenes) against a target model (--against) with a rubric; "
        "writes OUT/gradebook.csv, gradebook.json and OUT/students/ID/index.html. "
        "Re-runs skip what is done.",
    )
    p.add_argument("submissions", nargs="?", help="folder of submissions")
    p.add_argument(
        "--scene", action="append", help="scene name (scenes/NAME.json) or file; repeatable"
    )
    p.add_argument(
        "--against",
        metavar="MODEL",
        default=None,
        help="target model: classic (default, or the rubric's `against`), paper, physical, "
        "MODE+Qn/-Qn, mitsuba, mitsuba-path. Demo models are judged by exact match",
    )
    p.add_argument("--out", default="grades", help="output folder (default grades)")
    p.add_argument(
        "--rubric",
        default=None,
        help="rubric TOML (default: the built-in rubric, see compare/rubric.py)",
    )
    p.add_argument(
        "--executor",
        choices=("local", "dask"),
        default="local",
        help="process pool (default) or Dask",
    )
    p.add_argument(
        "--scheduler", default=None, help="Dask scheduler address, e.g. tcp://127.0.0.1:8786"
    )
    p.add_argument("--jobs", type=positive_int, default=2, help="local processes (default 2)")
    p.add_argument(
        "--size",
        type=size_type,
        default=None,
        metavar="WxH",
        help="model render size (default: the scene's)",
    )
    p.add_argument(
        "--no-diagnose",
        action="store_true",
        help="do not diagnose failing submissions (by default each one against a demo model "
        "is explained as the nearest demo model, quirks and named mistakes: README, Grading)",
    )
    p.add_argument(
        "--explain", metavar="ID", help="print how student ID's score came about, then exit"
    )
    add_cache_argument(p)
    p.set_defaults(func=run_grade)
