"""`rtval diagnose IMAGE --scene S`: which demo model, quirks, switched-off effects, depth and
named mistakes explain a foreign image, effect by effect."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from compare.diagnose.search import Diagnosis
    from compare.judge.images import Image

EXIT_DIAGNOSED = 0
EXIT_RENDERER = 1


def run_diagnose(args: argparse.Namespace) -> int:
    from compare.cli.common import stderr_progress
    from compare.diagnose.candidate import Candidate
    from compare.diagnose.renderer import CandidateRenderer
    from compare.diagnose.search import (
        MODES,
        DiagnoseError,
        DiagnoseOptions,
        NoFinitePixels,
        diagnose,
    )
    from compare.errors import ToolError
    from compare.grading.encodings import nearer_reading
    from compare.judge.images import ImageError, read_image
    from compare.judge.target_model import parse_model
    from safe_files.paths import check_outputs_distinct
    from scene_model.scene import load_scene

    start = None
    if args.against_start:
        model = parse_model(args.against_start)  # ModelError is a ValueError: exit 64
        if not model.is_demo:
            raise ValueError(
                f"--against-start {args.against_start}: expected a demo model "
                "(paper, classic, physical, optionally with +Qn/-Qn)"
            )
        start = Candidate.from_model(model)
    scene_file = (
        Path(args.scene)
        if Path(args.scene).suffix == ".json"
        else (Path("scenes") / f"{args.scene}.json")
    )
    check_outputs_distinct(
        [("--json", args.json)], [("IMAGE", args.image), ("--scene", scene_file)]
    )
    scene = load_scene(scene_file)
    image = read_image(args.image, encoding=args.encoding)
    progress = (lambda _m: None) if args.quiet else stderr_progress
    h, w = image.shape
    try:
        threads = 1 if args.parallel > 1 else 0
        with CandidateRenderer(scene_file, w, h, threads=threads, cache=args.cache) as r:
            if args.encoding is None:  # a PNG of a PPM writer's bytes is read as such
                image = nearer_reading(image, [r.passing(Candidate.of_mode(m)).rgb for m in MODES])
            how = DiagnoseOptions(start=start, progress=progress, parallel=args.parallel)
            result = diagnose(image, scene, r, how)
    except NoFinitePixels as e:  # an input with nothing to judge: as an unusable image
        raise ImageError(str(e)) from None
    except DiagnoseError as e:
        raise ToolError(str(e)) from None
    _tell(args, result, image, scene_file)
    return EXIT_DIAGNOSED


def _tell(args: argparse.Namespace, result: Diagnosis, image: Image, scene_file: Path) -> None:
    """The diagnosis as --json's record and as lines on stdout: the headline, how an 8-bit
    file was read where not as its format implies, the sentences and the render command."""
    from compare.diagnose.evidence import render_command
    from compare.grading.encodings import encoding_note, with_encoding_cause
    from safe_files.paths import write_atomic

    record = with_encoding_cause(result.as_dict(), image)
    if args.json:
        write_atomic(args.json, json.dumps(record, indent=2) + "\n")
    mirrored = f", mirrored {result.mirrored}" if result.mirrored else ""
    # Modes as near before the search; a result that matches exactly was told from them.
    near = [] if result.exact else result.modes_as_near()
    tied = f" (as near: {', '.join(near)}; the image cannot tell them apart)" if near else ""
    # A symptom's mistakes give the same image: the result renders one of them, not the cause.
    symptoms = [c["name"] for c in record["causes"] if c["kind"] == "step"]
    stands = "".join(f" ({n}: one of its mistakes, the image cannot tell which)" for n in symptoms)
    print(f"{args.image}: {result.result}{mirrored}{tied}{stands}")
    for line in [encoding_note(image), *result.sentences]:
        if line:
            print(f"  {line}")
    print(f"  ({render_command(result, scene_file)} renders it)")
    sys.stdout.flush()


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from compare.cli.common import add_cache_argument, positive_int

    p = sub.add_parser(
        "diagnose",
        help="explain a foreign image as the nearest demo model, quirks and named mistakes",
        description="Explains IMAGE (a render of SCENE by another program) as the nearest demo "
        "model: mode, quirks present or absent, effects switched off, max depth (up to 32), "
        "constants fitted as values (background, ior, bias, the Fresnel curve's), the camera "
        "fitted from the silhouettes (field of view, aspect, pixel centres, where it stands and "
        "looks), named mistakes (rtdemo render --help lists them), what the image writer did "
        "(mirroring, channel order, encoding, noise), effect by effect, judged by exact match "
        "as the verdict judges (FLIP before and after for the eye). A cause is named only where "
        "its render makes at least half of an effect's differing pixels match and passes the "
        "gates (docs/diagnosis.md); what nothing explains is localised to the step of the "
        "algorithm its pixels' paths share. Exit 0 diagnosed, "
        "1 renderer failure, 3 invalid scene, 4 unreadable image, an image without one finite "
        "pixel (all NaN or infinite) or unwritable --json, "
        "64 bad arguments (also --json naming IMAGE or the scene).",
    )
    p.add_argument("image", help="the image to explain (EXR, PNG, PPM, PFM)")
    p.add_argument("--scene", required=True, metavar="S", help="scene name (scenes/S.json) or file")
    p.add_argument("--json", metavar="F", help="write the diagnosis as JSON")
    p.add_argument(
        "--against-start",
        metavar="MODE",
        help="start the search from this demo model (e.g. classic, paper-Q8) instead of the "
        "nearest of paper, classic and physical",
    )
    p.add_argument(
        "--encoding",
        choices=("srgb", "linear"),
        default=None,
        help="8-bit encoding of IMAGE (default: the format's own, PNG srgb and PPM linear, "
        "unless the other reading lies clearly nearer every demo mode: then that one, said as "
        "the first cause)",
    )
    p.add_argument(
        "--parallel",
        type=positive_int,
        default=2,
        help="renders at once, one thread each (default 2)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines on stderr")
    add_cache_argument(p)
    p.set_defaults(func=run_diagnose)
