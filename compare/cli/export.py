"""`rtval export`: the scene as Mitsuba 3 XML (plus PLY meshes) for Mitsuba's own loader."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.cli.common import positive_int
from compare.cli.mitsuba_options import add_scene_mapping_args, check_output, check_output_folder


def run_export(args: argparse.Namespace) -> int:
    from mitsuba_ref.export import ExportOptions, export_scene
    from scene_model.scene import load_scene

    check_output(Path(args.output), Path(args.scene))
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
    for warning in exported.warnings:
        print(f"rtval: warning: {args.scene}: {warning}", file=sys.stderr)
    out = Path(args.output)
    check_output_folder(out)
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
    add_scene_mapping_args(p)
    p.set_defaults(func=run_export)
