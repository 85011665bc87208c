"""The report's folder, REPORTS/<scene>/: real folders only (a link there would send its
writes and deletions elsewhere), and nothing in it that looks finished unless this run
finished it: index.html, report.pdf and report.json go first and come back last."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from compare.report.context import SCENE_COPY
from compare.report.derived import copy_file
from safe_files.paths import require_folder

FINISHED = ("index.html", "report.pdf", "report.json")  # written last, in this order
OLD_LAYOUT = "cache"  # the folder's render cache before the shared one


def prepare_folder(out: Path, scene_file: Path) -> None:
    """out/ and out/images/ as real folders, without an earlier run's finished files, and
    the scene's copy beside the page."""
    for d in (out, out / "images"):
        require_folder(d, missing_ok=True)
    old = out / OLD_LAYOUT
    if os.path.isdir(old) and not os.path.islink(old):
        shutil.rmtree(old)
    for d in (out, out / "images"):
        d.mkdir(parents=True, exist_ok=True)
        require_folder(d)  # made by this run, or a folder that was already there
    remove_finished(out)
    copy_file(scene_file, out / SCENE_COPY)


def remove_finished(out: Path) -> None:
    """Removes what says "this report is complete" (a failed or interrupted run)."""
    for name in FINISHED:
        (out / name).unlink(missing_ok=True)


def remove_unlinked(images: Path, linked: set[str]) -> None:
    """Nothing of an earlier run stays (another test image, the EXRs of the layout before
    the shared cache): images/ holds what this page links to. A link in it is removed as a
    link, never followed."""
    require_folder(images, missing_ok=True)
    for p in images.iterdir():
        if f"images/{p.name}" not in linked:
            p.unlink()
