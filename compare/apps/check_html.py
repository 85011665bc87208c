"""`rtval check --html DIR`: one page for the failures only. Each failing case shows the
reference (baseline or demo model) and the render side by side, the difference and the FLIP
map, its per-effect numbers and, where compare.judge.diagnose exists, a diagnosis."""

from __future__ import annotations

import importlib
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from jinja2 import Environment, PackageLoader, select_autoescape

from compare.apps.check import CaseResult
from compare.files import write_atomic
from compare.judge.images import linear_to_srgb
from compare.judge.tolerances import diff_image

PNGS = ("reference", "render", "difference", "flip")


def _save_png(path: Path, display: np.ndarray) -> None:
    from PIL import Image as PILImage

    data = np.round(np.clip(np.nan_to_num(display), 0.0, 1.0) * 255.0).astype(np.uint8)
    PILImage.fromarray(data, "RGB").save(path, format="PNG")


def _magma(values: np.ndarray) -> np.ndarray:
    import matplotlib

    return np.asarray(matplotlib.colormaps["magma"](np.clip(np.nan_to_num(values), 0, 1)))[..., :3]


def _diagnosis(case: CaseResult) -> list[str] | None:
    """The diagnose helper's explanation of a failing render (nearest demo model, quirks,
    named mistakes), when compare.judge.diagnose is installed; None without it."""
    try:
        diagnose = importlib.import_module("compare.judge.diagnose")
        candidates = importlib.import_module("compare.render.candidates")
    except ImportError:
        return None
    if case.pictures is None or not case.scene_file:
        return None
    from compare.judge.images import Image
    from scene_model.scene import load_scene

    image = Image(rgb=case.pictures.test, encoding=case.test_encoding)
    h, w = image.shape
    try:
        with candidates.CandidateRenderer(case.scene_file, w, h) as render:
            found = diagnose.diagnose(
                image, load_scene(case.scene_file), render, progress=lambda _m: None
            )
        return [str(found.result), *(str(x) for x in found.sentences)]
    except Exception as e:  # an optional slot: its failure must not lose the page
        return [f"no diagnosis: {type(e).__name__}: {e}"]


def write_html(results: list[CaseResult], out_dir: Path) -> Path:
    """Writes out_dir/index.html (and its PNGs); returns the page's path."""
    failures = [r for r in results if r.status == "fail" and not r.updated]
    images = out_dir / "images"
    if images.is_dir():
        shutil.rmtree(images)  # images of an earlier run's failures would linger
    images.mkdir(parents=True)
    cases: list[dict[str, Any]] = []
    for i, r in enumerate(failures):
        entry: dict[str, Any] = {
            "name": r.name,
            "reasons": r.reasons,
            "against": r.against or "baseline",
            "images": {},
            "effects": [
                {"name": n, **e.__dict__, "failed": n in r.failed_effects}
                for n, e in r.effects.items()
            ],
            "diagnosis": _diagnosis(r),
        }
        pics = r.pictures
        if pics is not None:
            ref, test = linear_to_srgb(pics.ref), linear_to_srgb(pics.test)
            pictures = {
                "reference": ref,
                "render": test,
                "difference": diff_image(ref, test),
                "flip": _magma(pics.flip),
            }
            for kind, picture in pictures.items():
                name = f"case{i:03d}-{kind}.png"  # never a user's text in a file name
                _save_png(images / name, picture)
                entry["images"][kind] = f"images/{name}"
        cases.append(entry)
    env = Environment(
        loader=PackageLoader("compare.apps", "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    html = env.get_template("check.html.j2").render(
        cases=cases, total=len(results), failed=len(failures)
    )
    page = out_dir / "index.html"
    write_atomic(page, html)
    return page
