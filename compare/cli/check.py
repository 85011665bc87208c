"""`rtval check`: the regression check of rtdemo, or of any renderer, against stored baselines
or a demo model."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from compare.cli.common import (
    add_cache_argument,
    check_output_folders,
    positive_int,
    size_type,
    target_model_type,
)

if TYPE_CHECKING:
    from compare.check.run import CaseResult, CheckSettings
    from compare.render.foreign import RendererCommand


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not 0 < v <= 86400:
        raise argparse.ArgumentTypeError(f"expected 0 < seconds <= 86400, got {text!r}")
    return v


def _parse_renderer(args: argparse.Namespace) -> RendererCommand | None:
    """The --renderer command, or None for rtdemo; refuses options that need the other."""
    from compare.render import foreign

    if args.renderer is None:
        if args.renderer_name or args.output_format != "exr" or args.timeout or args.sandbox:
            raise ValueError(
                "--renderer-name, --output-format, --timeout and --sandbox need --renderer"
            )
        return None
    try:
        renderer = foreign.parse_command(args.renderer, args.renderer_name, args.output_format)
    except foreign.TemplateError as e:
        raise ValueError(str(e)) from None
    if args.backends != "cpu":
        raise ValueError("--backends applies to rtdemo only, not to --renderer")
    if args.rtdemo:
        raise ValueError("--rtdemo and --renderer exclude each other")
    if args.sandbox:
        from compare.sandbox.bwrap import require_sandbox

        require_sandbox()  # refuses, saying why, where no sandbox can be made
    return renderer


def _settings(args: argparse.Namespace, renderer: RendererCommand | None) -> CheckSettings:
    from compare.check.run import CheckSettings
    from compare.render.cache import RenderCache

    return CheckSettings(
        scenes=args.scenes,
        baseline_dir=Path(args.baseline),
        size=args.size,
        modes=args.modes.split(",") if args.modes else None,
        backends=args.backends.split(","),
        update=args.update,
        rtdemo=args.rtdemo,
        renderer=renderer,
        against=args.against,
        spp=args.spp,
        timeout=args.timeout,
        sandbox=args.sandbox,
        cache=RenderCache(args.cache),
        keep_images=bool(args.html),
    )


def _write_outputs(args: argparse.Namespace, results: list[CaseResult]) -> None:
    """The table on stdout, then each file output asked for, then the CI step summary."""
    from compare.check import output as check_output

    print(check_output.table(results))
    if args.json:
        check_output.write_json(results, Path(args.json))
    if args.junit:
        check_output.write_junit(results, Path(args.junit))
    if args.html:
        from compare.check.html import write_html

        page = write_html(results, Path(args.html), note=lambda m: print(m, file=sys.stderr))
        print(f"failure page: {page}", file=sys.stderr)
    summary = os.environ.get("GITHUB_STEP_SUMMARY")
    if summary:
        check_output.append_step_summary(results, Path(summary))


def run_check(args: argparse.Namespace) -> int:
    from compare.check import run as check
    from safe_files.paths import check_outputs_distinct

    renderer = _parse_renderer(args)
    html_page = Path(args.html) / "index.html" if args.html else None
    outputs = [("--json", args.json), ("--junit", args.junit), ("--html", html_page)]
    check_outputs_distinct(outputs, [("--scenes", s) for s in args.scenes])
    check_output_folders([("--json", args.json), ("--junit", args.junit), ("--html", args.html)])
    results = check.run_check(
        _settings(args, renderer), progress=lambda m: print(m, file=sys.stderr)
    )
    _write_outputs(args, results)
    for action in ("written", "replaced"):
        names = [r.name for r in results if r.baseline_action == action]
        if names:
            print(f"baselines {action}: {', '.join(names)}", file=sys.stderr)
    return check.exit_code(results)


_DESCRIPTION = (
    "Renders the scene set with rtdemo (every backend and mode asked for) or "
    "with any program (--renderer) and compares each render with its baseline under "
    "per-scene tolerances (BASELINE/tolerances.json), or with --against MODEL against a "
    "target model (demo models: exact match). A failure names the scene and the effect. "
    "A missing baseline fails; so does a renderer that exits non-zero, times out, or "
    "writes no image, an unreadable one or one of the wrong size. Exit 0 pass, 1 warn, "
    "2 fail, 1 when rtdemo cannot render a model, 4 an unreadable tolerances.json or an "
    "output that is not a regular file, 64 bad arguments (also an output naming a scene "
    "or another output)."
)

_EPILOG = (
    "Renderer placeholders: {scene} (scene JSON), {scene_xml} (its Mitsuba XML "
    "export), {out} (the image to write), {width}, {height}, {spp}, {mode} (with it, one "
    "case per --modes entry); {width}x{height} is the scene's own size unless --size says "
    "otherwise. Example: rtval check --renderer 'python3 my_tracer.py "
    "{scene} -o {out} --size {width}x{height}' --update. Baselines: "
    "BASELINE/<renderer-name>/<scene>/<mode or default>.exr (rtdemo: "
    "BASELINE/<scene>/<mode>.exr)."
)


def _add_case_options(p: argparse.ArgumentParser) -> None:
    """What is rendered and what it is compared with."""
    from compare.check.run import DEFAULT_MODES, DEFAULT_SCENES

    p.add_argument(
        "--scenes",
        nargs="+",
        default=list(DEFAULT_SCENES),
        help=f"scene files or built-in names (default: {' '.join(DEFAULT_SCENES)})",
    )
    p.add_argument(
        "--modes",
        default=None,
        help=f"comma-separated rtdemo modes (default {','.join(DEFAULT_MODES)}; with "
        "--against, the model's own options); for --renderer only with {mode}",
    )
    p.add_argument("--backends", default="cpu", help="comma-separated backends (default cpu)")
    p.add_argument(
        "--baseline", default="tests/baselines", help="baseline folder (default tests/baselines)"
    )
    p.add_argument(
        "--size",
        type=size_type,
        default=None,
        metavar="WxH",
        help="render size ({width}x{height}); default: the size of the case's stored baseline, "
        "else the scene's own (its camera's width and height), so a renderer that ignores "
        "{width}/{height} works as it is",
    )
    p.add_argument("--spp", type=positive_int, default=1, help="samples per pixel ({spp})")
    p.add_argument(
        "--update",
        action="store_true",
        help="write the missing baselines and replace the failing ones, saying which "
        "(those cases count as written or replaced, not as failures)",
    )


def _add_output_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    p.add_argument(
        "--junit", metavar="OUT.xml", help="write JUnit XML (one testcase per case and effect)"
    )
    p.add_argument("--html", metavar="DIR", help="write a page for the failures to DIR/index.html")


def _add_renderer_options(p: argparse.ArgumentParser) -> None:
    """Which program renders: rtdemo, or any command line, and how it is run."""
    from compare.render.foreign import OUTPUT_FORMATS

    p.add_argument(
        "--rtdemo", default=None, help="the rtdemo executable to check (default: the installed one)"
    )
    p.add_argument(
        "--renderer",
        metavar="'CMD ...'",
        help="check this program instead of rtdemo: a command line with placeholders, split "
        "like a shell would, run without one",
    )
    p.add_argument(
        "--renderer-name",
        metavar="NAME",
        help="names the renderer's baseline folder (default: its program or script's stem)",
    )
    p.add_argument(
        "--output-format",
        choices=OUTPUT_FORMATS,
        default="exr",
        help="the image type the renderer writes to {out} (default exr; PNG is read as sRGB, "
        "PPM as linear)",
    )
    p.add_argument("--timeout", type=_seconds, metavar="S", help="time limit per scene, in seconds")
    p.add_argument(
        "--sandbox",
        action="store_true",
        help="run the renderer in the sandbox `rtval grade` runs students' programs in "
        "(bubblewrap: no network, nothing of yours visible but the files its command names, "
        "copied; docs/sandbox.md); --timeout is its wall time (default 600 s)",
    )


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "check",
        help="regression check of rtdemo or any renderer against baselines or a target model",
        description=_DESCRIPTION,
        epilog=_EPILOG,
    )
    _add_case_options(p)
    _add_output_options(p)
    _add_renderer_options(p)
    p.add_argument(
        "--against",
        metavar="MODEL",
        type=target_model_type,
        help="judge each render against a target model instead of its baseline (demo models "
        "such as classic or paper-Q8: exact match, rtdemo itself then rendered with the "
        "model's options unless --modes is given; mitsuba: the default rubric)",
    )
    add_cache_argument(p)
    p.set_defaults(func=run_check)
