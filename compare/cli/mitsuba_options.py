"""What `rtval export` and `rtval reference` share: the scene-mapping options and the checks
made on their output before any work."""

from __future__ import annotations

import argparse
from pathlib import Path

from safe_files.paths import check_outputs_distinct


def add_scene_mapping_args(p: argparse.ArgumentParser) -> None:
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


def check_output(out: Path, scene: Path, more: list[tuple[str, str]] | None = None) -> None:
    """Before any work: each output (-o, then `more` as (option, path)) is a regular file or
    absent (never a device, a FIFO or a link), not the scene it is made from, and not
    another output."""
    check_outputs_distinct([("-o", str(out)), *(more or [])], [("SCENE", str(scene))])


def check_output_folder(out: Path) -> None:
    if not out.parent.is_dir():
        raise OSError(f"{out}: cannot write: directory '{out.parent}' does not exist")
