"""`rtval report`: one scene through every renderer into reports/<scene>/."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from compare.cli.common import add_cache_argument, positive_int, report_size_type, target_model_type
from compare.report.label import MAX_LABEL, label_problem


def run_report(args: argparse.Namespace) -> int:
    from compare import interrupts as interrupt

    if args.against and not args.test_image:
        raise ValueError("--against needs --test-image (the image judged against MODEL)")
    if args.size is None:
        _check_scene_size(args.scene)

    try:
        with interrupt.stop_guard():
            index = _build(args)
            interrupt.check()  # a stop signal whose exception was lost: never exit 0
    except interrupt.Stopped as e:  # SIGINT, SIGTERM, SIGHUP: the report has removed what it began
        print(f"rtval: interrupted ({signal.Signals(e.signum).name})", file=sys.stderr)
        return e.exit_code
    print(index)
    return 0


def _build(args: argparse.Namespace) -> Path:
    from compare.render.cache import RenderCache
    from compare.render.progress import Progress
    from compare.report.build import build_report
    from compare.report.context import ReportOptions

    opts = ReportOptions(
        Path(args.scene),
        Path(args.reports_dir),
        size=args.size,
        test_image=args.test_image,
        test_label=args.label,
        test_encoding=args.test_encoding,
        against=args.against,
        jobs=args.jobs,
        pdf=not args.no_pdf,
    )
    return build_report(opts, RenderCache(args.cache), Progress(sys.stderr))


def _check_scene_size(scene_file: str) -> None:
    from compare.cli.common import REPORT_MIN_SIDE
    from scene_model.scene import load_scene

    cam = load_scene(scene_file).camera
    if min(cam.width, cam.height) < REPORT_MIN_SIDE:
        raise ValueError(
            f"{scene_file}: its camera is {cam.width}x{cam.height}; a report needs at least "
            f"{REPORT_MIN_SIDE}x{REPORT_MIN_SIDE} (SSIM's window): pass --size"
        )


def _label(text: str) -> str:
    why = label_problem(text)
    if why:
        raise argparse.ArgumentTypeError(why)
    return text


def _add_test_image_options(p: argparse.ArgumentParser) -> None:
    """An image rendered elsewhere, graded in the demo's place."""
    p.add_argument(
        "--test-image",
        metavar="IMAGE",
        help="grade this render (EXR, PNG, PPM, PFM) in the demo's place",
    )
    p.add_argument(
        "--against",
        metavar="MODEL",
        default=None,
        type=target_model_type,
        help="with --test-image: the model it was asked to implement (default classic); the "
        "report gives its verdict against that model and against Mitsuba side by side",
    )
    p.add_argument(
        "--label",
        type=_label,
        default=None,
        help=f"name of the --test-image renderer in the report (one line, at most {MAX_LABEL} "
        "characters)",
    )
    p.add_argument(
        "--test-encoding",
        choices=("srgb", "linear"),
        default=None,
        help="8-bit encoding of --test-image (default: PNG srgb, PPM linear)",
    )


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "report",
        help="render a scene with every renderer and write reports/<scene>/index.html",
        description="Renders SCENE with every renderer (renders come from the shared cache when "
        "nothing changed) and writes reports/<scene>/: index.html, report.json, report.pdf, "
        "PNGs, the reference and test EXRs and a copy of the scene; relative links only, so "
        "the folder can be zipped and sent. Prints a time per step at the end.",
    )
    p.add_argument(
        "scene",
        nargs="?",
        default="paper",
        help="a scene file or a built-in scene's name (default: paper, the paper's own scene)",
    )
    p.add_argument(
        "--reports-dir",
        type=Path,
        default=Path("reports"),
        help="where reports go (default: reports)",
    )
    p.add_argument(
        "--size",
        type=report_size_type,
        default=None,
        metavar="WxH",
        help="override the camera's image size (each side at least 32: SSIM's window)",
    )
    _add_test_image_options(p)
    p.add_argument(
        "--jobs", type=positive_int, default=1, help="renders run in parallel (default 1)"
    )
    p.add_argument(
        "--no-pdf", action="store_true", help="skip report.pdf (printed by headless Chromium)"
    )
    add_cache_argument(p)
    p.set_defaults(func=run_report)
