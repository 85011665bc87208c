"""`rtval reference`: a Mitsuba reference (whitted or path) to EXR, alone or as a batch."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from compare.cli.common import Parser, positive_float, positive_int, seed_type, size_type
from compare.cli.mitsuba_options import add_scene_mapping_args, check_output, check_output_folder

if TYPE_CHECKING:
    from mitsuba_ref.reference import ReferenceImage, ReferenceSettings


def run_reference(args: argparse.Namespace) -> int:
    if args.batch:
        if args.scene or args.output:
            raise ValueError("--batch takes its scenes and outputs from the batch file")
        from compare.cli.reference_batch import run_batch

        return run_batch(Path(args.batch), _parse_job, render_to_file)
    if not args.scene or not args.output:
        raise ValueError("reference needs SCENE and -o OUT.exr (or --batch JOBS.json)")
    from compare.render.progress import Progress

    progress = Progress()
    step = f"{args.integrator} {args.variant}"
    seconds, summary = render_to_file(args, lambda d, t, e: progress.update(step, d, t, e))
    progress.line(f"{step}: {summary} in {seconds:.2f} s")
    print(args.output)
    return 0


def _parse_job(argv: list[str]) -> argparse.Namespace:
    """One batch job's arguments, read by the same parser as `rtval reference`."""
    parser = Parser(prog="rtval")
    register(parser.add_subparsers(dest="command", required=True, parser_class=Parser))
    args = parser.parse_args(["reference", *argv])
    if args.batch or not args.scene or not args.output:
        raise ValueError("each batch job needs SCENE and -o OUT.exr, and no --batch")
    return args


def snapshot_type(text: str) -> tuple[int, str]:
    """SPP:OUT.exr for --snapshot."""
    spp, sep, path = text.partition(":")
    if not sep or not path or not spp.isdigit() or int(spp) < 1:
        raise argparse.ArgumentTypeError(f"expected SPP:OUT.exr, e.g. 4:ref-4spp.exr, got {text!r}")
    return int(spp), path


def _settings(args: argparse.Namespace) -> ReferenceSettings:
    from mitsuba_ref.reference import ReferenceSettings

    return ReferenceSettings(
        integrator=args.integrator,
        spp=args.spp,
        seed=args.seed,
        variant=args.variant,
        centre_rays=args.centre_rays,
        light=args.light,
        light_units=args.light_units,
        mapping=args.mapping,
        keep_huge_spheres=args.keep_huge_spheres,
        shadows=not args.no_shadows,
        reflection=not args.no_reflection,
        refraction=not args.no_refraction,
        time_budget=args.time_budget,
        target_stderr=args.target_stderr,
        size=args.size,
        snapshots=tuple(spp for spp, _ in args.snapshot),
        aovs=not args.no_aovs,
    )


def render_to_file(
    args: argparse.Namespace,
    progress: Callable[[int, int, float], None],
    snapshot: Callable[[int, str, float], None] | None = None,
) -> tuple[float, str]:
    """Renders one `rtval reference` command's image to its -o file (and each --snapshot's
    to its file, then `snapshot(spp, path, seconds)`); returns the wall seconds and what
    was done (samples, why it stopped)."""
    from mitsuba_ref.reference import render_reference
    from scene_model.scene import load_scene

    start = time.perf_counter()
    out = Path(args.output)
    snapshots = dict(args.snapshot)
    if len(snapshots) < len(args.snapshot):
        raise ValueError("--snapshot: each SPP at most once")
    check_output(out, Path(args.scene), [("--snapshot", p) for p in snapshots.values()])
    scene = load_scene(args.scene)
    for path in (out, *map(Path, snapshots.values())):
        check_output_folder(path)

    def write_snapshot(image: ReferenceImage) -> None:
        _write(Path(snapshots[image.spp_done]), image)
        if snapshot is not None:
            snapshot(image.spp_done, snapshots[image.spp_done], time.perf_counter() - start)

    result = render_reference(scene, _settings(args), progress=progress, snapshot=write_snapshot)
    for warning in result.warnings:
        print(f"rtval: warning: {args.scene}: {warning}", file=sys.stderr)
    _write(out, result)
    summary = f"{result.header['rtval.spp']} spp (stopped by {result.header['rtval.stopped_by']})"
    return time.perf_counter() - start, summary


def _add_stopping_and_effects(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--time-budget",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="stop after the pass that spends this budget",
    )
    p.add_argument(
        "--target-stderr",
        type=positive_float,
        default=None,
        help="stop once the mean standard error of the pixel means is this low",
    )
    p.add_argument(
        "--snapshot",
        type=snapshot_type,
        action="append",
        default=[],
        metavar="SPP:OUT.exr",
        help="also write the image after SPP samples (below --spp): the very image of the "
        "same command with --spp SPP (its passes are a prefix of these), for no extra work; "
        "repeatable",
    )
    p.add_argument("--no-shadows", action="store_true", help="whitted: no shadow rays")
    p.add_argument("--no-reflection", action="store_true", help="whitted: no reflection lobes")
    p.add_argument("--no-refraction", action="store_true", help="whitted: no transmission lobes")
    p.add_argument(
        "--no-aovs",
        action="store_true",
        help="write colour (and variance) alone, without the id, depth and N.* AOVs: for a "
        "render wanted for its image and time (scalar variants trace them one ray at a time)",
    )


def _write(out: Path, image: ReferenceImage) -> None:
    from compare.judge.images import write_exr

    aovs = dict(image.aovs)
    if image.variance is not None:
        aovs.update({f"var.{c}": image.variance[..., i] for i, c in enumerate("RGB")})
    try:
        write_exr(out, image.rgb, aovs=aovs, header=image.header)
    except RuntimeError as e:  # OpenEXR's write error (a full disk): its text names no path
        raise OSError(f"{out}: cannot write: {_exr_reason(e)}") from None


def _exr_reason(e: RuntimeError) -> str:
    """OpenEXR's message without the temporary file's name it quotes."""
    text = str(e)
    return (text.rsplit('". ', 1)[-1] if '". ' in text else text).rstrip(".")


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "reference",
        help="render a Mitsuba reference (whitted or path) to EXR",
        description="Renders a reference with Mitsuba 3: colour plus id, depth, N.* AOVs "
        "(and var.* per-sample variance with spp >= 2).",
    )
    p.add_argument("scene", nargs="?", help="scene file")
    p.add_argument("-o", "--output", help="the EXR file to write")
    p.add_argument(
        "--batch",
        metavar="JOBS.json",
        help="render several references in one process (Mitsuba is imported once): "
        '{"jobs": [[SCENE, "-o", OUT, OPTIONS...], ...]}; JSON lines on stdout report '
        "progress and each finished render",
    )
    p.add_argument(
        "--integrator",
        choices=("whitted", "path"),
        default="whitted",
        help="whitted: the demo's physical transport (default); path: Mitsuba's path tracer",
    )
    p.add_argument("--spp", type=positive_int, default=1, help="samples per pixel (default 1)")
    p.add_argument("--seed", type=seed_type, default=0, help="random seed (default 0)")
    p.add_argument(
        "--variant",
        choices=("llvm_ad_rgb", "scalar_rgb"),
        default="llvm_ad_rgb",
        help="Mitsuba variant (default llvm_ad_rgb; scalar_rgb: path through Mitsuba's own "
        "render loop, whitted and --centre-rays one ray at a time)",
    )
    p.add_argument(
        "--centre-rays",
        action="store_true",
        help="every camera ray through its pixel centre, as the demo shoots",
    )
    p.add_argument(
        "--size", type=size_type, default=None, metavar="WxH", help="override the image size"
    )
    _add_stopping_and_effects(p)
    add_scene_mapping_args(p)
    p.set_defaults(func=run_reference)
