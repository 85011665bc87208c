"""`rtval ztest REF TEST`: Mitsuba-style per-pixel Z-test against a stochastic reference."""

from __future__ import annotations

import argparse
import sys

from compare.cli.common import positive_int


def run_ztest(args: argparse.Namespace) -> int:
    import json

    import numpy as np

    from compare.files import write_atomic
    from compare.judge.images import ImageError, image_size, read_image, write_exr
    from compare.judge.tolerances import EXIT_FAIL, EXIT_PASS, EXIT_SIZE
    from compare.judge.ztest import z_test
    from scene_model.safe_paths import check_outputs_distinct

    check_outputs_distinct(
        [("--json", args.json), ("--pvalue-image", args.pvalue_image)],
        [("REF", args.ref), ("TEST", args.test)],
    )
    if not (0 < args.alpha < 1):  # also refuses NaN
        raise ValueError(f"--alpha: expected a number between 0 and 1, got {args.alpha}")
    ref_size, test_size = image_size(args.ref), image_size(args.test)  # before decoding
    if ref_size != test_size:
        print(
            f"rtval: size mismatch: reference {ref_size[1]}x{ref_size[0]}, test "
            f"{test_size[1]}x{test_size[0]}",
            file=sys.stderr,
        )
        return EXIT_SIZE
    ref = read_image(args.ref)
    test = read_image(args.test)
    if not all(f"var.{c}" in ref.aovs for c in "RGB"):
        raise ImageError(
            f"{args.ref}: no var.R/var.G/var.B channels: render the reference with "
            "`rtval reference --spp N` (N >= 2), which stores per-sample variance"
        )
    if ref.shape != test.shape:
        print(
            f"rtval: size mismatch: reference {ref.shape[1]}x{ref.shape[0]}, test "
            f"{test.shape[1]}x{test.shape[0]}",
            file=sys.stderr,
        )
        return EXIT_SIZE
    spp = args.test_spp or int(test.header.get("rtval.spp", "0") or 0)
    if spp < 1:
        raise ValueError(f"{args.test}: header has no rtval.spp; give --test-spp N")
    var = np.stack([ref.aovs[f"var.{c}"] for c in "RGB"], axis=-1)
    result = z_test(test.rgb, spp, ref.rgb, var, alpha=args.alpha)
    failing = int((~(result.p_values > result.alpha_sidak).all(axis=-1)).sum())
    print(
        f"Z-test: {100 * result.pass_fraction:.3f} % of pixels pass (need 99.75 %), "
        f"{failing} fail at Sidak-corrected alpha {result.alpha_sidak:.3g} "
        f"(alpha {args.alpha}, test spp {spp}): {'PASS' if result.passed else 'FAIL'}"
    )
    if args.json:
        write_atomic(
            args.json,
            json.dumps(
                {
                    "passed": result.passed,
                    "pass_fraction": result.pass_fraction,
                    "failing_pixels": failing,
                    "alpha": args.alpha,
                    "alpha_sidak": result.alpha_sidak,
                    "test_spp": spp,
                },
                indent=2,
            )
            + "\n",
        )
    if not result.passed and args.pvalue_image:
        write_exr(
            args.pvalue_image,
            result.p_values.astype(np.float32),
            header={"rtval.content": "per-channel two-sided p-values of the Z-test"},
        )
        print(f"p-value image: {args.pvalue_image}", file=sys.stderr)
    return EXIT_PASS if result.passed else EXIT_FAIL


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "ztest",
        help="statistical check against a stochastic reference (Mitsuba's Z-test)",
        description="Per-pixel, per-channel Z-test of TEST against REF's mean and per-sample "
        "variance (var.* channels), Sidak-corrected; passes when >= 99.75 %% of "
        "pixels pass. Exit 0 pass, 2 fail, 3 size mismatch, 4 unreadable input.",
    )
    p.add_argument("ref", help="reference EXR with var.R, var.G, var.B (rtval reference --spp N)")
    p.add_argument("test", help="image under test")
    p.add_argument(
        "--test-spp",
        type=positive_int,
        default=None,
        help="samples per pixel of TEST (default: its rtval.spp header)",
    )
    p.add_argument("--alpha", type=float, default=0.01, help="significance level (default 0.01)")
    p.add_argument("--pvalue-image", metavar="OUT.exr", help="on failure, write the p-values here")
    p.add_argument("--json", metavar="OUT.json", help="write the result as JSON")
    p.set_defaults(func=run_ztest)
