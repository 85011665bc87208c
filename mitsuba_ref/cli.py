"""`rtval export` and `rtval reference`: mitsuba_ref's commands, registered into rtval's parser."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

from compare.cli.common import positive_float, positive_int, seed_type, size_type


def _export_options_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("scene mapping")
    g.add_argument(
        "--light",
        choices=("area", "point"),
        default="area",
        help="sphere lights as area emitters (default) or point emitters at their centres",
    )
    g.add_argument(
        "--light-units",
        choices=("calibrated", "physical"),
        default="calibrated",
        help="calibrated (default): a white surface facing the light at look_at receives "
        "the paper's emission; physical: emission taken as radiance",
    )
    g.add_argument(
        "--mapping",
        choices=("physical", "paper"),
        default="physical",
        help="mirrors as exact mirrors (physical) or conductors fitted to the paper's Fresnel",
    )
    g.add_argument(
        "--keep-huge-spheres",
        action="store_true",
        help="export radius >= 100 spheres as spheres (shows Mitsuba's float32 acne)",
    )


def _check_output(out: Path, scene: Path) -> None:
    """Before any work: the output is a regular file or absent (never a device, a FIFO or a
    link) and not the scene it is made from."""
    from scene_model.safe_paths import check_outputs_distinct

    check_outputs_distinct([("-o", str(out))], [("SCENE", str(scene))])


def run_export(args: argparse.Namespace) -> int:
    from mitsuba_ref.export import ExportOptions, export_scene
    from scene_model.scene import load_scene

    _check_output(Path(args.output), Path(args.scene))
    scene = load_scene(args.scene)
    exported = export_scene(
        scene,
        ExportOptions(
            light=args.light,
            light_units=args.light_units,
            mapping=args.mapping,
            keep_huge_spheres=args.keep_huge_spheres,
            spp=args.spp,
            centre_rays=args.centre_rays,
            integrator="path" if args.integrator == "path" else "rtval_whitted",
        ),
    )
    out = Path(args.output)
    if not out.parent.is_dir():
        raise OSError(f"{out}: cannot write: directory '{out.parent}' does not exist")
    for f in exported.write(out):
        print(f)
    for name, factor in exported.light_factors.items():
        print(
            f"light '{name}': intensity = emission x {factor:.6g} ({args.light_units} units)",
            file=sys.stderr,
        )
    if exported.conductor:
        c = exported.conductor
        print(
            f"paper mirror conductor: eta {c.eta:.4f}, k {c.k:.4f}, fit RMS error "
            f"{c.rms_error:.4f}, max {c.max_error:.4f}",
            file=sys.stderr,
        )
    for note in exported.notes:
        print(f"note: {note}", file=sys.stderr)
    return 0


def run_reference(args: argparse.Namespace) -> int:
    if args.batch:
        if args.scene or args.output:
            raise ValueError("--batch takes its scenes and outputs from the batch file")
        from mitsuba_ref.batch import run_batch

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
    from compare.cli.main import build_parser

    args = build_parser().parse_args(["reference", *argv])
    if args.batch or not args.scene or not args.output:
        raise ValueError("each batch job needs SCENE and -o OUT.exr, and no --batch")
    return args


def render_to_file(
    args: argparse.Namespace, progress: Callable[[int, int, float], None]
) -> tuple[float, str]:
    """Renders one `rtval reference` command's image to its -o file; returns the wall
    seconds and what was done (samples, why it stopped)."""
    from compare.judge.images import write_exr
    from mitsuba_ref.reference import ReferenceSettings, render_reference
    from scene_model.scene import load_scene

    start = time.perf_counter()
    _check_output(Path(args.output), Path(args.scene))
    scene = load_scene(args.scene)
    out = Path(args.output)
    if not out.parent.is_dir():
        raise OSError(f"{out}: cannot write: directory '{out.parent}' does not exist")
    settings = ReferenceSettings(
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
    )
    result = render_reference(scene, settings, progress=progress)
    aovs = dict(result.aovs)
    if result.variance is not None:
        aovs.update({f"var.{c}": result.variance[..., i] for i, c in enumerate("RGB")})
    write_exr(out, result.rgb, aovs=aovs, header=result.header)
    summary = f"{result.header['rtval.spp']} spp (stopped by {result.header['rtval.stopped_by']})"
    return time.perf_counter() - start, summary


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "export",
        help="write the scene as Mitsuba 3 XML (plus PLY meshes)",
        description="Writes SCENE as a Mitsuba 3 XML file that Mitsuba's own loader renders as-is; "
        "huge spheres become spherical-cap PLY meshes beside it.",
    )
    p.add_argument("scene", help="scene file")
    p.add_argument("-o", "--output", required=True, help="the XML file to write")
    p.add_argument(
        "--integrator",
        choices=("path", "whitted"),
        default="path",
        help="integrator written into the XML (whitted needs mitsuba_ref.whitted.register())",
    )
    p.add_argument(
        "--spp", type=positive_int, default=16, help="samples per pixel in the XML (default 16)"
    )
    p.add_argument(
        "--centre-rays",
        action="store_true",
        help="stratified sampler without jitter: pixel centres",
    )
    _export_options_args(p)
    p.set_defaults(func=run_export)

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
    p.add_argument("--no-shadows", action="store_true", help="whitted: no shadow rays")
    p.add_argument("--no-reflection", action="store_true", help="whitted: no reflection lobes")
    p.add_argument("--no-refraction", action="store_true", help="whitted: no transmission lobes")
    _export_options_args(p)
    p.set_defaults(func=run_reference)
