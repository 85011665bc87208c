"""`rtval`: the validation suite's command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from compare.images import ImageError
from compare.rubric import RubricError
from compare.tools import ToolError
from mitsuba_ref.drjit_env import MitsubaUnavailable
from mitsuba_ref.scene import SceneError

EXIT_USAGE = 64  # EX_USAGE: kept apart from compare's 0-4 verdict codes
EXIT_SCENE = 3
EXIT_IO = 4


class _Parser(argparse.ArgumentParser):
    """Bad arguments exit with 64, so that 2 always means "fail" for compare and check."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        sys.exit(EXIT_USAGE)


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

    index = build_report(args.scene, args.reports_dir, size=args.size, test_image=args.test_image,
                         test_label=args.label, test_encoding=args.test_encoding, jobs=args.jobs,
                         pdf=not args.no_pdf, progress=lambda m: print(m, file=sys.stderr, flush=True))
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


def _cmd_compare(args: argparse.Namespace) -> int:
    from compare.compare_images import load_mask, run_comparison, table, write_outputs
    from compare.images import read_image
    from compare.judge import EXIT_SIZE, Tolerances
    from compare.metrics import SizeMismatch
    from mitsuba_ref.scene import load_scene

    ref = read_image(args.ref, encoding=args.ref_encoding)
    test = read_image(args.test, encoding=args.test_encoding)
    tol = Tolerances(fail=args.fail, failpercent=args.failpercent, hardfail=args.hardfail,
                     warn=args.warn, warnpercent=args.warnpercent, min_ssim=args.min_ssim,
                     max_flip=args.max_flip)
    mask = load_mask(args.mask, ref.shape) if args.mask else None
    scene = load_scene(args.scene) if args.scene else None
    aovs = read_image(args.aovs) if args.aovs else None
    try:
        result = run_comparison(ref, test, tolerances=tol, mask=mask, scene=scene, aovs=aovs)
    except SizeMismatch as e:
        print(f"rtval: {e}", file=sys.stderr)
        return EXIT_SIZE
    write_outputs(result, json_path=args.json, diff_path=args.diff_image)
    if not args.quiet:
        print(table(result))
    return result.verdict.exit_code


def _cmd_ztest(args: argparse.Namespace) -> int:
    import json

    import numpy as np

    from compare.images import ImageError, read_image, write_exr
    from compare.judge import EXIT_FAIL, EXIT_PASS, EXIT_SIZE
    from compare.ztest import z_test

    ref = read_image(args.ref)
    test = read_image(args.test)
    if not all(f"var.{c}" in ref.aovs for c in "RGB"):
        raise ImageError(f"{args.ref}: no var.R/var.G/var.B channels: render the reference with "
                         "`rtval reference --spp N` (N >= 2), which stores per-sample variance")
    if ref.shape != test.shape:
        print(f"rtval: size mismatch: reference {ref.shape[1]}x{ref.shape[0]}, test "
              f"{test.shape[1]}x{test.shape[0]}", file=sys.stderr)
        return EXIT_SIZE
    spp = args.test_spp or int(test.header.get("rtval.spp", "0") or 0)
    if spp < 1:
        raise ValueError(f"{args.test}: header has no rtval.spp; give --test-spp N")
    var = np.stack([ref.aovs[f"var.{c}"] for c in "RGB"], axis=-1)
    result = z_test(test.rgb, spp, ref.rgb, var, alpha=args.alpha)
    failing = int((~(result.p_values > result.alpha_sidak).all(axis=-1)).sum())
    print(f"Z-test: {100 * result.pass_fraction:.3f} % of pixels pass (need 99.75 %), "
          f"{failing} fail at Sidak-corrected alpha {result.alpha_sidak:.3g} "
          f"(alpha {args.alpha}, test spp {spp}): {'PASS' if result.passed else 'FAIL'}")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "passed": result.passed, "pass_fraction": result.pass_fraction,
            "failing_pixels": failing, "alpha": args.alpha, "alpha_sidak": result.alpha_sidak,
            "test_spp": spp}, indent=2) + "\n")
    if not result.passed and args.pvalue_image:
        write_exr(args.pvalue_image, result.p_values.astype(np.float32),
                  header={"rtval.content": "per-channel two-sided p-values of the Z-test"})
        print(f"p-value image: {args.pvalue_image}", file=sys.stderr)
    return EXIT_PASS if result.passed else EXIT_FAIL


def _cmd_check(args: argparse.Namespace) -> int:
    from compare import check

    results = check.run_check(
        scenes=args.scenes, modes=args.modes.split(","), backends=args.backends.split(","),
        baseline_dir=Path(args.baseline), size=args.size, update=args.update, rtdemo=args.rtdemo,
        progress=lambda m: print(m, file=sys.stderr))
    print(check.table(results))
    if args.json:
        check.write_json(results, Path(args.json))
    if args.junit:
        check.write_junit(results, Path(args.junit))
    updated = [r.name for r in results if r.updated]
    if updated:
        print(f"updated baselines: {', '.join(updated)}", file=sys.stderr)
    return check.exit_code(results)


def _cmd_stress(args: argparse.Namespace) -> int:
    from compare import stress

    files = [Path(p) for p in args.scenes] if args.scenes else sorted(Path("scenes/stress").glob("*.json"))
    if not files:
        raise OSError("no stress scenes: give files, or run from the project folder (scenes/stress/*.json)")
    data = stress.run_stress(files, Path(args.out), size=args.size, progress=lambda m: print(m, file=sys.stderr))
    print(stress.table(data))
    print(Path(args.out) / "index.html")
    return 0


def _cmd_grade(args: argparse.Namespace) -> int:
    from compare import grade

    out = Path(args.out)
    if args.explain:
        print(grade.explain(out, args.explain))
        return 0
    if not args.submissions or not args.scene:
        raise ValueError("grade needs SUBMISSIONS and at least one --scene (or --explain ID)")
    scenes = [Path(s) if Path(s).suffix == ".json" else Path("scenes") / f"{s}.json" for s in args.scene]
    results = grade.run_grading(Path(args.submissions), scenes, out, rubric_path=args.rubric,
                                executor=args.executor, scheduler=args.scheduler, jobs=args.jobs, size=args.size,
                                progress=lambda m: print(m, file=sys.stderr, flush=True))
    passed = sum(r["status"] == "pass" for r in results)
    print(f"{passed} passed, {len(results) - passed} failed")
    print(out / "gradebook.csv")
    return 0


def _positive(convert: type) -> Any:
    """An argparse type: a positive, finite int or float."""

    def parse(text: str) -> Any:
        kind = "integer" if convert is int else "number"
        try:
            v = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a positive {kind}, got {text!r}")
        if not 0 < v < float("inf"):
            raise argparse.ArgumentTypeError(f"expected a positive {kind}, got {text!r}")
        return v

    return parse


_positive_int = _positive(int)
_positive_float = _positive(float)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="rtval",
        description="Holds the course paper's ray tracer against Mitsuba 3 and reports where and why they differ.",
        epilog="Exit codes: 0 ok (compare/check: pass), 1 warn or renderer failure, 2 fail, "
               "3 invalid scene (compare/check: size mismatch), 4 unreadable input or unwritable "
               "output, 64 bad arguments.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Parser)

    p = sub.add_parser("report", help="render a scene with every renderer and write reports/<scene>/index.html",
                       description="Renders SCENE with every renderer and writes reports/<scene>/index.html, report.json and images.")
    p.add_argument("scene", nargs="?", default="scenes/paper.json", help="scene file (default: scenes/paper.json)")
    p.add_argument("--reports-dir", type=Path, default=Path("reports"), help="where reports go (default: reports)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="override the camera's image size")
    p.add_argument("--test-image", metavar="IMAGE", help="grade this render (EXR, PNG, PPM, PFM) in the demo's place")
    p.add_argument("--label", default=None, help="name of the --test-image renderer in the report")
    p.add_argument("--test-encoding", choices=("srgb", "linear"), default=None,
                   help="8-bit encoding of --test-image (default: PNG srgb, PPM linear)")
    p.add_argument("--jobs", type=_positive_int, default=1, help="renders run in parallel (default 1)")
    p.add_argument("--no-pdf", action="store_true", help="skip report.pdf (printed by headless Chromium)")
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

    p = sub.add_parser("compare", help="metrics and a verdict for two images (EXR, PNG, PPM, PFM)",
                       description="Compares TEST against REF: SSIM, FLIP, PSNR, RMSE, MAE, relative MSE, "
                                   "max error, pixels over threshold, NaN/Inf, each in a stated space; "
                                   "per effect with --scene. Exit 0 pass, 1 warn, 2 fail, 3 size mismatch, "
                                   "4 unreadable input.")
    p.add_argument("ref", help="reference image")
    p.add_argument("test", help="image under test")
    p.add_argument("--ref-encoding", choices=("srgb", "linear"), default=None,
                   help="8-bit reference encoding (default: PNG srgb, PPM linear as the paper writes it)")
    p.add_argument("--test-encoding", choices=("srgb", "linear"), default=None,
                   help="8-bit test encoding (default: PNG srgb, PPM linear)")
    p.add_argument("--json", metavar="OUT.json", help="write every number as JSON")
    p.add_argument("--diff-image", metavar="OUT.png", help="write |ref - test| (display) x 8")
    p.add_argument("--mask", metavar="MASK.png", help="only pixels where the mask is white")
    p.add_argument("--scene", metavar="SCENE.json", help="add per-effect metrics (masks from id/depth AOVs)")
    p.add_argument("--aovs", metavar="FILE.exr", help="take the id/depth AOVs from this EXR")
    g = p.add_argument_group("tolerances (per-pixel error = largest display-channel difference)")
    g.add_argument("--fail", type=float, default=0.01, help="failing pixel error (default 0.01)")
    g.add_argument("--failpercent", type=float, default=0.0, help="%% of pixels allowed over --fail (default 0)")
    g.add_argument("--hardfail", type=float, default=float("inf"), help="any pixel over this fails")
    g.add_argument("--warn", type=float, default=1 / 255, help="warning pixel error (default 1/255)")
    g.add_argument("--warnpercent", type=float, default=0.0, help="%% of pixels allowed over --warn (default 0)")
    g.add_argument("--min-ssim", type=float, default=None, help="fail below this SSIM")
    g.add_argument("--max-flip", type=float, default=None, help="fail above this mean LDR FLIP")
    p.add_argument("-q", "--quiet", action="store_true", help="no table on stdout")
    p.set_defaults(func=_cmd_compare)

    p = sub.add_parser("ztest", help="statistical check against a stochastic reference (Mitsuba's Z-test)",
                       description="Per-pixel, per-channel Z-test of TEST against REF's mean and per-sample "
                                   "variance (var.* channels), Sidak-corrected; passes when >= 99.75 %% of "
                                   "pixels pass. Exit 0 pass, 2 fail, 3 size mismatch, 4 unreadable input.")
    p.add_argument("ref", help="reference EXR with var.R, var.G, var.B (rtval reference --spp N)")
    p.add_argument("test", help="image under test")
    p.add_argument("--test-spp", type=_positive_int, default=None,
                   help="samples per pixel of TEST (default: its rtval.spp header)")
    p.add_argument("--alpha", type=float, default=0.01, help="significance level (default 0.01)")
    p.add_argument("--pvalue-image", metavar="OUT.exr", help="on failure, write the p-values here")
    p.add_argument("--json", metavar="OUT.json", help="write the result as JSON")
    p.set_defaults(func=_cmd_ztest)

    from compare.check import DEFAULT_MODES, DEFAULT_SCENES, DEFAULT_SIZE

    p = sub.add_parser("check", help="regression check of the demo against stored baselines",
                       description="Renders the demo on the scene set for every backend and mode asked for "
                                   "and compares each render with its baseline under per-scene tolerances "
                                   "(BASELINE/tolerances.json). A missing baseline fails. Exit 0 pass, 1 warn, "
                                   "2 fail.")
    p.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES), help="scene files")
    p.add_argument("--modes", default=",".join(DEFAULT_MODES), help="comma-separated modes (default all)")
    p.add_argument("--backends", default="cpu", help="comma-separated backends (default cpu)")
    p.add_argument("--baseline", default="tests/baselines", help="baseline folder (default tests/baselines)")
    p.add_argument("--size", type=_size, default=DEFAULT_SIZE, metavar="WxH",
                   help="render size (default %dx%d)" % DEFAULT_SIZE)
    p.add_argument("--update", action="store_true", help="rewrite new or failing baselines, say which")
    p.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    p.add_argument("--junit", metavar="OUT.xml", help="write the results as JUnit XML")
    p.add_argument("--rtdemo", default=None, help="the rtdemo executable to check (default: the installed one)")
    p.set_defaults(func=_cmd_check)

    p = sub.add_parser("stress", help="render the stress scenes with every method; NaN, error and stability atlas",
                       description="Renders each stress scene with every demo mode and backend and both Mitsuba "
                                   "references; reports NaN/Inf, error against the Whitted reference and stability "
                                   "under tiny nudges; writes an atlas to OUT/index.html.")
    p.add_argument("scenes", nargs="*", help="scene files (default: scenes/stress/*.json)")
    p.add_argument("--out", default="reports/stress", help="output folder (default reports/stress)")
    p.add_argument("--size", type=_size, default=(160, 120), metavar="WxH", help="render size (default 160x120)")
    p.set_defaults(func=_cmd_stress)

    p = sub.add_parser("grade", help="grade a folder of submissions: per-student pages and a gradebook",
                       description="Grades every submission (an image named after the student, or a folder of "
                                   "images named after the scenes) against the scenes' references with a rubric; "
                                   "writes OUT/gradebook.csv, gradebook.json and OUT/students/ID/index.html. "
                                   "Re-runs skip what is done.")
    p.add_argument("submissions", nargs="?", help="folder of submissions")
    p.add_argument("--scene", action="append", help="scene name (scenes/NAME.json) or file; repeatable")
    p.add_argument("--out", default="grades", help="output folder (default grades)")
    p.add_argument("--rubric", default=None, help="rubric TOML (default: the built-in rubric, see compare/rubric.py)")
    p.add_argument("--executor", choices=("local", "dask"), default="local", help="process pool (default) or Dask")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://127.0.0.1:8786")
    p.add_argument("--jobs", type=_positive_int, default=2, help="local processes (default 2)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="reference size (default: the scene's)")
    p.add_argument("--explain", metavar="ID", help="print how student ID's score came about, then exit")
    p.set_defaults(func=_cmd_grade)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except SceneError as e:
        print(f"rtval: error: {e}", file=sys.stderr)
        return EXIT_SCENE
    except (ImageError, OSError, RubricError) as e:
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
