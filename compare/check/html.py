"""`rtval check --html DIR`: one page for the failures only. Each failing case shows the
reference (baseline or target model) and the render side by side, the difference and the
FLIP map, its per-effect numbers and a diagnosis (compare.diagnose.search: the nearest demo
model, quirks and named mistakes). User text is escaped by Jinja's autoescape, the page
carries a Content-Security-Policy (compare/pages/writer.py), every file is written atomically;
NaN/Inf pixels show in the PNGs' marker colour (compare/judge/png.py)."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from compare.check.run import CaseResult
from compare.diagnose.record import Diagnosis
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, diagnose
from compare.judge.images import Image
from compare.judge.png import display_values, write_display_png
from compare.judge.tolerances import diff_image
from compare.pages.writer import write_page
from compare.render.ray_trees import page_trees
from safe_files.paths import UnsafePathError
from scene_model.scene import load_scene

PNGS = ("reference", "render", "difference", "flip")
# A bounded search per failing case (diagnose.MAX_RENDERS is 200): the page is a first look.
DIAGNOSE_RENDERS = 60


def _magma(values: np.ndarray) -> np.ndarray:
    """The FLIP map in magma; a non-finite value stays NaN (the PNG's marker colour)."""
    import matplotlib

    rgb = np.asarray(matplotlib.colormaps["magma"](np.clip(np.nan_to_num(values), 0, 1)))[..., :3]
    rgb[~np.isfinite(values)] = np.nan
    return rgb


def _diagnosis(case: CaseResult, note: Callable[[str], None]) -> dict[str, Any] | None:
    """The nearest demo model, quirks and named mistakes that explain a failing render
    (compare.diagnose.search), as lines for the page, with that model's ray trees at a few
    pixels that differ. Optional: when it cannot be made (no pictures, rtdemo fails, the
    search fails), the page says so and `note` is told."""
    if case.pictures is None or not case.scene_file:
        return None

    image = Image(rgb=case.pictures.test, encoding=case.test_encoding)
    h, w = image.shape
    try:
        with CandidateRenderer(case.scene_file, w, h) as render:
            how = DiagnoseOptions(max_renders=DIAGNOSE_RENDERS)
            found = diagnose(image, load_scene(case.scene_file), render, how)
    except Exception as e:  # an optional slot: its failure must not lose the page
        message = f"no diagnosis for {case.name}: {e}"
        note(message)
        return {"lines": [message]}
    return {"lines": [found.reason(), *found.sentences], "rays": _rays(case, found)}


def _rays(case: CaseResult, found: Diagnosis) -> dict[str, Any]:
    """The diagnosis' result model's ray trees where the render differs from the reference
    by more than one 8-bit level (a scene copy's result is not traced: no file holds it)."""
    assert case.pictures is not None
    if found.candidate.scene_changes():
        return {"error": "the explaining model changes the scene (" + found.result + ")"}
    ref, test = display_values(case.pictures.ref), display_values(case.pictures.test)
    differing = np.nan_to_num(np.abs(ref - test)).max(axis=2) > 1.5 / 255
    args = found.candidate.rtdemo_args()
    trees = page_trees(case.scene_file, args, case.pictures.test, differing, {})
    return {"model": found.result, **trees}


def write_html(
    results: list[CaseResult], out_dir: Path, *, note: Callable[[str], None] = print
) -> Path:
    """Writes out_dir/index.html (and its PNGs); returns the page's path."""
    failures = [r for r in results if r.status == "fail" and not r.updated]
    images = out_dir / "images"
    if images.is_symlink():
        raise UnsafePathError(f"{images}: is a symbolic link; check writes its own folder")
    if images.is_dir():
        shutil.rmtree(images)  # images of an earlier run's failures would linger
    images.mkdir(parents=True)
    cases: list[dict[str, Any]] = []
    for i, r in enumerate(failures):
        entry: dict[str, Any] = {
            "name": r.name,
            "reasons": r.reasons,
            "against": r.against,
            "images": {},
            "effects": [
                {"name": n, **e.__dict__, "failed": n in r.failed_effects}
                for n, e in r.effects.items()
            ],
            "diagnosis": _diagnosis(r, note),
        }
        pics = r.pictures
        if pics is not None:
            ref, test = display_values(pics.ref), display_values(pics.test)
            pictures = {
                "reference": ref,
                "render": test,
                "difference": diff_image(ref, test),
                "flip": _magma(pics.flip),
            }
            for kind, picture in pictures.items():
                name = f"case{i:03d}-{kind}.png"  # never a user's text in a file name
                write_display_png(images / name, picture)
                entry["images"][kind] = f"images/{name}"
        cases.append(entry)
    page = out_dir / "index.html"
    write_page(page, "check.html.j2", cases=cases, total=len(results), failed=len(failures))
    return page
