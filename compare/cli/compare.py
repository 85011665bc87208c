"""`rtval compare REF TEST`: every metric and a verdict for one pair of images."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from compare.cli.common import add_cache_argument, check_output_folders, target_model_type

if TYPE_CHECKING:
    from compare.judge.tolerances import Tolerances
    from compare.verdict.pair import Comparison


def _image_paths(args: argparse.Namespace) -> tuple[str | None, str]:
    """(REF or None with --against, TEST), once the outputs are known to overwrite no input."""
    from safe_files.paths import check_outputs_distinct

    if args.against:
        if len(args.images) != 1 or not args.scene:
            raise ValueError("--against MODEL takes one image (TEST) and --scene SCENE.json")
    elif len(args.images) != 2:
        raise ValueError("compare needs REF TEST (or TEST --against MODEL --scene SCENE.json)")
    ref_path = None if args.against else args.images[0]
    test_path = args.images[-1]
    check_outputs_distinct(
        [("--json", args.json), ("--diff-image", args.diff_image)],
        [
            ("REF", ref_path),
            ("TEST", test_path),
            ("--mask", args.mask),
            ("--scene", args.scene),
            ("--aovs", args.aovs),
        ],
    )
    check_output_folders([("--json", args.json), ("--diff-image", args.diff_image)])
    return ref_path, test_path


def _tolerances(args: argparse.Namespace) -> Tolerances:
    from compare.judge.tolerances import Tolerances

    return Tolerances(
        fail=args.fail,
        failpercent=args.failpercent,
        hardfail=args.hardfail,
        warn=args.warn,
        warnpercent=args.warnpercent,
        min_ssim=args.min_ssim,
        max_flip=args.max_flip,
    )


def _judge_against(args: argparse.Namespace, test_path: str, tol: Tolerances) -> Comparison:
    from compare.judge.images import read_image
    from compare.render.cache import RenderCache
    from compare.render.progress import Progress
    from compare.verdict.pair import load_mask, run_against

    test = read_image(test_path, encoding=args.test_encoding)
    _warn_size(test_path, test.shape, args.scene)
    mask = load_mask(args.mask, test.shape) if args.mask else None
    return run_against(
        test,
        args.against,
        Path(args.scene),
        RenderCache(args.cache),
        tolerances=tol,
        mask=mask,
        progress=Progress(sys.stderr),
    )


def _warn_size(test_path: str, shape: tuple[int, int], scene_file: str) -> None:
    """The model is rendered at TEST's size; one that is not the scene's own is likely an
    image made for another scene or a resized copy, so it is said before the verdict."""
    from scene_model.scene import load_scene

    cam = load_scene(scene_file).camera
    if (cam.width, cam.height) != (shape[1], shape[0]):
        print(
            f"rtval: warning: {test_path} is {shape[1]}x{shape[0]}; {scene_file} renders at "
            f"{cam.width}x{cam.height}: the model is rendered at {shape[1]}x{shape[0]} to judge it",
            file=sys.stderr,
        )


def _judge_pair(
    args: argparse.Namespace, ref_path: str, test_path: str, tol: Tolerances
) -> Comparison | None:
    """REF against TEST; None (said on stderr) when their headers give different sizes."""
    from compare.judge.images import image_size, read_image
    from compare.verdict.pair import load_mask, run_comparison
    from scene_model.scene import load_scene

    # Sizes from the headers first: a mismatch costs no decoding (two 8192^2 EXRs or a
    # tiny PNG declaring 9400^2 pixels would otherwise take gigabytes before the refusal).
    ref_size, test_size = image_size(ref_path), image_size(test_path)
    if ref_size != test_size:
        print(
            f"rtval: size mismatch: reference {ref_path} is {ref_size[1]}x{ref_size[0]}, "
            f"test {test_path} is {test_size[1]}x{test_size[0]} (never resampled)",
            file=sys.stderr,
        )
        return None
    ref = read_image(ref_path, encoding=args.ref_encoding)
    test = read_image(test_path, encoding=args.test_encoding, expected_size=ref.shape)
    mask = load_mask(args.mask, ref.shape) if args.mask else None
    scene = load_scene(args.scene) if args.scene else None
    aovs = read_image(args.aovs) if args.aovs else None
    return run_comparison(ref, test, tolerances=tol, mask=mask, scene=scene, aovs=aovs)


def run_compare(args: argparse.Namespace) -> int:
    from compare.judge.metrics import SizeMismatch
    from compare.judge.tolerances import EXIT_SIZE
    from compare.verdict.pair import table, write_outputs

    ref_path, test_path = _image_paths(args)
    tol = _tolerances(args)
    try:
        if ref_path is None:
            result = _judge_against(args, test_path, tol)
        else:
            pair = _judge_pair(args, ref_path, test_path, tol)
            if pair is None:
                return EXIT_SIZE
            result = pair
    except SizeMismatch as e:
        print(f"rtval: {e}", file=sys.stderr)
        return EXIT_SIZE
    write_outputs(result, json_path=args.json, diff_path=args.diff_image)
    if not args.quiet:
        print(table(result))
    return result.verdict.exit_code


def _add_image_options(p: argparse.ArgumentParser) -> None:
    """The images, where they come from and what is written about them."""
    p.add_argument("images", nargs="+", metavar="IMAGE", help="REF TEST, or TEST with --against")
    p.add_argument(
        "--against",
        metavar="MODEL",
        default=None,
        type=target_model_type,
        help="judge TEST against this target model instead of a REF image: mitsuba, "
        "mitsuba-path, paper, classic, physical, MODE+Qn/-Qn (needs --scene)",
    )
    p.add_argument(
        "--ref-encoding",
        choices=("srgb", "linear"),
        default=None,
        help="8-bit reference encoding (default: PNG srgb, PPM linear as the paper writes it)",
    )
    p.add_argument(
        "--test-encoding",
        choices=("srgb", "linear"),
        default=None,
        help="8-bit test encoding (default: PNG srgb, PPM linear)",
    )
    p.add_argument("--json", metavar="OUT.json", help="write every number as JSON")
    p.add_argument("--diff-image", metavar="OUT.png", help="write |ref - test| (display) x 8")
    p.add_argument("--mask", metavar="MASK.png", help="only pixels where the mask is white")
    p.add_argument(
        "--scene", metavar="SCENE.json", help="add per-effect metrics (masks from id/depth AOVs)"
    )
    p.add_argument("--aovs", metavar="FILE.exr", help="take the id/depth AOVs from this EXR")


def _add_tolerance_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("tolerances (per-pixel error = largest display-channel difference)")
    g.add_argument("--fail", type=float, default=0.01, help="failing pixel error (default 0.01)")
    g.add_argument(
        "--failpercent",
        type=float,
        default=0.0,
        help="%% of pixels allowed over --fail (default 0)",
    )
    g.add_argument("--hardfail", type=float, default=float("inf"), help="any pixel over this fails")
    g.add_argument(
        "--warn", type=float, default=1 / 255, help="warning pixel error (default 1/255)"
    )
    g.add_argument(
        "--warnpercent",
        type=float,
        default=0.0,
        help="%% of pixels allowed over --warn (default 0)",
    )
    g.add_argument("--min-ssim", type=float, default=None, help="fail below this SSIM")
    g.add_argument("--max-flip", type=float, default=None, help="fail above this mean LDR FLIP")


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "compare",
        help="metrics and a verdict for two images (EXR, PNG, PPM, PFM)",
        description="Compares TEST against REF: SSIM, FLIP, PSNR, RMSE, MAE, relative MSE, "
        "max error, pixels over threshold, NaN/Inf, each in a stated space; "
        "per effect with --scene. With --against MODEL --scene S, TEST alone is judged "
        "against the model rendered at TEST's size (demo models: exact match). "
        "Exit 0 pass, 1 warn, 2 fail, 3 size mismatch, 4 unreadable input.",
    )
    _add_image_options(p)
    _add_tolerance_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no table on stdout")
    add_cache_argument(p)
    p.set_defaults(func=run_compare)
