"""`rtval ztest REF TEST`: Mitsuba-style per-pixel Z-test against a stochastic reference."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from compare.cli.common import check_output_folders, positive_int

if TYPE_CHECKING:
    from compare.judge.images import Image
    from compare.judge.ztest import ZTestResult


def _size_mismatch(ref: tuple[int, int], test: tuple[int, int]) -> None:
    print(
        f"rtval: size mismatch: reference {ref[1]}x{ref[0]}, test {test[1]}x{test[0]}",
        file=sys.stderr,
    )


def _load_pair(args: argparse.Namespace) -> tuple[Image, Image] | None:
    """REF (with its variance channels) and TEST; None (said on stderr) when sizes differ."""
    from compare.judge.images import ImageError, image_size, read_image

    ref_size, test_size = image_size(args.ref), image_size(args.test)  # before decoding
    if ref_size != test_size:
        _size_mismatch(ref_size, test_size)
        return None
    ref = read_image(args.ref)
    test = read_image(args.test)
    if not all(f"var.{c}" in ref.aovs for c in "RGB"):
        raise ImageError(
            f"{args.ref}: no var.R/var.G/var.B channels: render the reference with "
            "`rtval reference --spp N` (N >= 2), which stores per-sample variance"
        )
    if ref.shape != test.shape:
        _size_mismatch(ref.shape, test.shape)
        return None
    return ref, test


def _write_json(args: argparse.Namespace, result: ZTestResult, failing: int, spp: int) -> None:
    import json

    from safe_files.paths import write_atomic

    record = {
        "passed": result.passed,
        "pass_fraction": result.pass_fraction,
        "failing_pixels": failing,
        "alpha": args.alpha,
        "alpha_sidak": result.alpha_sidak,
        "test_spp": spp,
    }
    write_atomic(args.json, json.dumps(record, indent=2) + "\n")


def run_ztest(args: argparse.Namespace) -> int:
    import numpy as np

    from compare.judge.images import write_exr
    from compare.judge.tolerances import EXIT_FAIL, EXIT_PASS, EXIT_SIZE
    from compare.judge.ztest import z_test
    from safe_files.paths import check_outputs_distinct

    check_outputs_distinct(
        [("--json", args.json), ("--pvalue-image", args.pvalue_image)],
        [("REF", args.ref), ("TEST", args.test)],
    )
    check_output_folders([("--json", args.json), ("--pvalue-image", args.pvalue_image)])
    if not (0 < args.alpha < 1):  # also refuses NaN
        raise ValueError(f"--alpha: expected a number between 0 and 1, got {args.alpha}")
    pair = _load_pair(args)
    if pair is None:
        return EXIT_SIZE
    ref, test = pair
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
        _write_json(args, result, failing, spp)
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
        "variance (var.* channels), Sidak-corrected; passes when >= 99.75 % of "
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
