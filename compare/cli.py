"""`rtval`: the validation suite's command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from compare.images import ImageError
from compare.tools import ToolError
from mitsuba_ref.drjit_env import MitsubaUnavailable
from mitsuba_ref.scene import SceneError

EXIT_USAGE = 2
EXIT_SCENE = 3
EXIT_IO = 4


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, e.g. 320x240, got {text!r}")
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise argparse.ArgumentTypeError(f"each side must be 1-16384, got {text!r}")
    return w, h


def _cmd_report(args: argparse.Namespace) -> int:
    from compare.report import build_report

    index = build_report(args.scene, args.reports_dir, size=args.size,
                         progress=lambda m: print(m, file=sys.stderr))
    print(index)
    return 0


def _export_options_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("scene mapping")
    g.add_argument("--light", choices=("area", "point"), default="area",
                   help="sphere lights as area emitters (default) or point emitters at their centres")
    g.add_argument("--light-units", choices=("calibrated", "physical"), default="calibrated",
                   help="calibrated (default): a white surface facing the light at look_at receives "
                        "the paper's emission; physical: emission taken as radiance")
    g.add_argument("--mapping", choices=("physical", "paper"), default="physical",
                   help="mirrors as exact mirrors (physical) or conductors fitted to the paper's Fresnel")
    g.add_argument("--keep-huge-spheres", action="store_true",
                   help="export radius >= 100 spheres as spheres (shows Mitsuba's float32 acne)")


def _cmd_export(args: argparse.Namespace) -> int:
    from mitsuba_ref.export import ExportOptions, export_scene
    from mitsuba_ref.scene import load_scene

    scene = load_scene(args.scene)
    exported = export_scene(scene, ExportOptions(
        light=args.light, light_units=args.light_units, mapping=args.mapping,
        keep_huge_spheres=args.keep_huge_spheres, spp=args.spp, centre_rays=args.centre_rays,
        integrator="path" if args.integrator == "path" else "rtval_whitted"))
    out = Path(args.output)
    if not out.parent.is_dir():
        raise OSError(f"{out}: cannot write: directory '{out.parent}' does not exist")
    for f in exported.write(out):
        print(f)
    for name, factor in exported.light_factors.items():
        print(f"light '{name}': intensity = emission x {factor:.6g} ({args.light_units} units)",
              file=sys.stderr)
    if exported.conductor:
        c = exported.conductor
        print(f"paper mirror conductor: eta {c.eta:.4f}, k {c.k:.4f}, fit RMS error "
              f"{c.rms_error:.4f}, max {c.max_error:.4f}", file=sys.stderr)
    for note in exported.notes:
        print(f"note: {note}", file=sys.stderr)
    return 0


def _cmd_reference(args: argparse.Namespace) -> int:
    from compare.images import write_exr
    from mitsuba_ref.reference import ReferenceSettings, render_reference
    from mitsuba_ref.scene import load_scene

    scene = load_scene(args.scene)
    out = Path(args.output)
    if not out.parent.is_dir():
        raise OSError(f"{out}: cannot write: directory '{out.parent}' does not exist")
    settings = ReferenceSettings(
        integrator=args.integrator, spp=args.spp, seed=args.seed, variant=args.variant,
        centre_rays=args.centre_rays, light=args.light, light_units=args.light_units,
        mapping=args.mapping, keep_huge_spheres=args.keep_huge_spheres,
        shadows=not args.no_shadows, reflection=not args.no_reflection,
        refraction=not args.no_refraction, time_budget=args.time_budget,
        target_stderr=args.target_stderr, size=args.size)
    result = render_reference(scene, settings, progress=lambda m: print("\r" + m, end="", file=sys.stderr))
    print(file=sys.stderr)
    aovs = dict(result.aovs)
    if result.variance is not None:
        aovs.update({f"var.{c}": result.variance[..., i] for i, c in enumerate("RGB")})
    write_exr(out, result.rgb, aovs=aovs, header=result.header)
    print(out)
    print(f"{settings.integrator} {settings.variant}: {result.header['rtval.spp']} spp in "
          f"{result.seconds:.2f} s (stopped by {result.header['rtval.stopped_by']})", file=sys.stderr)
    return 0


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    if not v > 0 or v != v or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rtval",
        description="Holds the course paper's ray tracer against Mitsuba 3 and reports where and why they differ.",
        epilog="Exit codes: 0 ok, 2 bad arguments, 3 invalid scene, 4 unreadable input or unwritable output.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("report", help="render a scene with every renderer and write reports/<scene>/index.html",
                       description="Renders SCENE with every renderer and writes reports/<scene>/index.html, report.json and images.")
    p.add_argument("scene", nargs="?", default="scenes/paper.json", help="scene file (default: scenes/paper.json)")
    p.add_argument("--reports-dir", type=Path, default=Path("reports"), help="where reports go (default: reports)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="override the camera's image size")
    p.set_defaults(func=_cmd_report)

    p = sub.add_parser("export", help="write the scene as Mitsuba 3 XML (plus PLY meshes)",
                       description="Writes SCENE as a Mitsuba 3 XML file that Mitsuba's own loader renders as-is; "
                                   "huge spheres become spherical-cap PLY meshes beside it.")
    p.add_argument("scene", help="scene file")
    p.add_argument("-o", "--output", required=True, help="the XML file to write")
    p.add_argument("--integrator", choices=("path", "whitted"), default="path",
                   help="integrator written into the XML (whitted needs mitsuba_ref.whitted.register())")
    p.add_argument("--spp", type=_positive_int, default=16, help="samples per pixel in the XML (default 16)")
    p.add_argument("--centre-rays", action="store_true", help="stratified sampler without jitter: pixel centres")
    _export_options_args(p)
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("reference", help="render a Mitsuba reference (whitted or path) to EXR",
                       description="Renders a reference with Mitsuba 3: colour plus id, depth, N.* AOVs "
                                   "(and var.* per-sample variance with spp >= 2).")
    p.add_argument("scene", help="scene file")
    p.add_argument("-o", "--output", required=True, help="the EXR file to write")
    p.add_argument("--integrator", choices=("whitted", "path"), default="whitted",
                   help="whitted: the demo's physical transport (default); path: Mitsuba's path tracer")
    p.add_argument("--spp", type=_positive_int, default=1, help="samples per pixel (default 1)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--variant", choices=("llvm_ad_rgb", "scalar_rgb"), default="llvm_ad_rgb",
                   help="Mitsuba variant (default llvm_ad_rgb; scalar_rgb is one ray at a time)")
    p.add_argument("--centre-rays", action="store_true",
                   help="every camera ray through its pixel centre, as the demo shoots")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="override the image size")
    p.add_argument("--time-budget", type=_positive_float, default=None, metavar="SECONDS",
                   help="stop after the pass that spends this budget")
    p.add_argument("--target-stderr", type=_positive_float, default=None,
                   help="stop once the mean standard error of the pixel means is this low")
    p.add_argument("--no-shadows", action="store_true", help="whitted: no shadow rays")
    p.add_argument("--no-reflection", action="store_true", help="whitted: no reflection lobes")
    p.add_argument("--no-refraction", action="store_true", help="whitted: no transmission lobes")
    _export_options_args(p)
    p.set_defaults(func=_cmd_reference)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except SceneError as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except (ImageError, OSError) as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return EXIT_IO
    except ValueError as e:  # invalid combinations of options found below argparse
        print(f"rtval: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except (ToolError, MitsubaUnavailable) as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("rtval: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
