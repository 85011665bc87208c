"""`rtval grade`: grading a class."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from compare.cli.common import (
    add_cache_argument,
    positive_float,
    positive_int,
    size_type,
    target_model_type,
)

if TYPE_CHECKING:
    from compare.grading.programs import ProgramOptions


def run_grade(args: argparse.Namespace) -> int:
    from compare.grading import grade
    from compare.grading.class_page import summarise, summary_lines
    from compare.grading.executors import Executor
    from compare.grading.gradebook import explain
    from compare.grading.lms import (
        stage_submission,
        submission_identity,
        write_autograder_results,
    )
    from compare.grading.student_page import write_handouts
    from compare.render.cache import RenderCache
    from compare.render.progress import Progress

    out = Path(args.out)
    if args.explain:
        print(explain(out, args.explain))
        return 0
    if args.gradescope and args.submissions:
        raise ValueError("--gradescope reads ROOT/submission: give no SUBMISSIONS folder")
    if not (args.submissions or args.gradescope) or not args.scene:
        raise ValueError("grade needs SUBMISSIONS and at least one --scene (or --explain ID)")
    scenes = [Path(s) for s in args.scene]
    root = Path(args.gradescope_root)
    who = submission_identity(root) if args.gradescope else None
    if who is not None:  # which of Gradescope's fields named the student, said once
        named = f" ({who.names})" if who.names and who.names != who.student else ""
        print(f"gradescope: student {who.student}{named}, from {who.source}", file=sys.stderr)
    submissions = stage_submission(root, out, who.student) if who else Path(args.submissions)
    options = grade.GradingRun(
        rubric_path=args.rubric,
        executor=Executor(args.executor, args.scheduler, args.jobs, args.scheduler_timeout),
        size=args.size,
        against=args.against,
        diagnose=not args.no_diagnose,
        cache=RenderCache(args.cache),
        progress=Progress(sys.stderr),
        program=_program_options(args),
        test_encoding=args.test_encoding,
    )
    results = grade.run_grading(submissions, scenes, out, options)
    passed = sum(r.status == "pass" for r in results)
    print(f"{passed} passed, {len(results) - passed} failed")
    print("\n".join(summary_lines(summarise(results))))
    print(out / "gradebook.csv")
    print(out / "index.html")
    if args.handout:
        write_handouts(results, out, Path(args.handout))
        print(Path(args.handout))
    if who is not None:
        print(write_autograder_results(results, root, args.gradescope_visibility, who.student))
    return 0


def _program_options(args: argparse.Namespace) -> ProgramOptions:
    """The program flags; what they leave out comes from the rubric's [program]."""
    from compare.grading.programs import LIMIT_KEYS, ProgramOptions

    limits = {k: getattr(args, k) for k in LIMIT_KEYS if getattr(args, k) is not None}
    return ProgramOptions(
        build=args.build,
        run=args.run,
        output=args.output,
        output_format=args.output_format,
        unsandboxed=args.unsandboxed,
        allow_binaries=args.allow_binaries,
        limits=limits,
    )


def _add_program_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group(
        "programs",
        "Grade students' code: each submission (a folder, .zip or .tar.gz) is built once and "
        "run once per scene in a sandbox (docs/sandbox.md), then graded as its images. "
        "The rubric's [program] table says the same; flags win.",
    )
    g.add_argument(
        "--build", metavar="CMD", help="build command, e.g. 'g++ -O2 -o rt *.cpp' or make"
    )
    g.add_argument(
        "--run",
        metavar="CMD",
        help="run command with rtval check's placeholders: {scene} {out} {width} {height} "
        "{spp} {scene_xml}, e.g. './rt {scene} {out}'",
    )
    g.add_argument(
        "--output",
        metavar="NAME",
        help="the file the program writes in its folder instead of {out} (e.g. untitled.ppm)",
    )
    g.add_argument(
        "--output-format",
        choices=("exr", "pfm", "png", "ppm"),
        default=None,
        help="the format {out} names (default ppm)",
    )
    g.add_argument(
        "--unsandboxed",
        action="store_true",
        help="run the programs with limits but no isolation where no sandbox can be made "
        "(bwrap missing): only for code you trust",
    )
    g.add_argument(
        "--allow-binaries",
        action="store_true",
        help="accept prebuilt executables (ELF files) in a submission; by default a "
        "submission holding one is refused: only what the build makes may run",
    )
    _add_limit_arguments(g)


def _add_limit_arguments(g: argparse._ArgumentGroup) -> None:
    g.add_argument(
        "--build-timeout",
        type=positive_float,
        metavar="S",
        help="CPU seconds per build, all its processes together (default 120)",
    )
    g.add_argument(
        "--run-timeout",
        type=positive_float,
        metavar="S",
        help="CPU seconds per run, all its processes together (default 60); the wall limit "
        "is a generous 3 x this + 10 s",
    )
    g.add_argument(
        "--cpu", type=positive_float, metavar="S", help="CPU seconds per process (default 600)"
    )
    g.add_argument("--memory", metavar="SIZE", help="address space per process (default 2G)")
    g.add_argument("--file-size", metavar="SIZE", help="largest file written (default 256M)")
    g.add_argument(
        "--processes", type=positive_int, metavar="N", help="processes and threads (default 128)"
    )
    g.add_argument("--open-files", type=positive_int, metavar="N", help="per process (default 256)")
    g.add_argument(
        "--disk",
        metavar="SIZE",
        help="writable space of each build and run, its work and out folders together "
        "(default 512M; memory-backed)",
    )


def _add_lms_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--test-encoding",
        choices=("srgb", "linear"),
        default=None,
        help="how 8-bit PNG/PPM codes decode (default: both are tried; an image passes when "
        "it matches in either, and its row says when it was read against its format's rule)",
    )
    p.add_argument(
        "--handout",
        metavar="DIR",
        help="also copy each student's page folder to DIR/ID/: self-contained, to send as it is",
    )
    g = p.add_argument_group(
        "Gradescope",
        "Run as Gradescope's autograder (docs/grading.md): the one submission in "
        "ROOT/submission is graded and its results.json written to ROOT/results/.",
    )
    g.add_argument("--gradescope", action="store_true", help="grade ROOT/submission")
    g.add_argument(
        "--gradescope-root",
        default="/autograder",
        metavar="ROOT",
        help="the autograder folder (default /autograder)",
    )
    g.add_argument(
        "--gradescope-visibility",
        choices=("visible", "hidden", "after_due_date", "after_published"),
        default="visible",
        help="when students see the tests (default visible)",
    )


def _add_executor_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--executor",
        choices=("local", "dask"),
        default="local",
        help="process pool (default) or Dask",
    )
    p.add_argument(
        "--scheduler", default=None, help="Dask scheduler address, e.g. tcp://127.0.0.1:8786"
    )
    p.add_argument(
        "--scheduler-timeout",
        type=positive_float,
        default=10.0,
        metavar="S",
        help="seconds to reach the Dask scheduler and hear its handshake (default 10); "
        "a scheduler that refuses, stays silent or is not one exits 4",
    )
    p.add_argument("--jobs", type=positive_int, default=2, help="local processes (default 2)")


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "grade",
        help="grade a folder of submissions: per-student pages and a gradebook",
        description="Grades every submission (an image named after the student, or a folder of "
        "images named after the scenes; with --run, a student's program, built and run in a "
        "sandbox) against a target model (--against) with a rubric; "
        "writes OUT/index.html (the class page), gradebook.csv, gradebook.json, scores.csv "
        "(id,score), gradescope/ID/results.json and OUT/students/ID/index.html. "
        "Re-runs skip what is done.",
    )
    p.add_argument("submissions", nargs="?", help="folder of submissions")
    p.add_argument(
        "--scene",
        action="append",
        help="a built-in scene's name (classic, paper, lit) or a scene file; repeatable",
    )
    p.add_argument(
        "--against",
        metavar="MODEL",
        default=None,
        type=target_model_type,
        help="target model: classic (default, or the rubric's `against`), paper, physical, "
        "MODE+Qn/-Qn, mitsuba, mitsuba-path. Demo models are judged by exact match",
    )
    p.add_argument("--out", default="grades", help="output folder (default grades)")
    p.add_argument(
        "--rubric",
        default=None,
        help="rubric TOML (default: the built-in rubric, see compare/rubric.py)",
    )
    _add_executor_arguments(p)
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
    _add_program_arguments(p)
    _add_lms_arguments(p)
    add_cache_argument(p)
    p.set_defaults(func=run_grade)
