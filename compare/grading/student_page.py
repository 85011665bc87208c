"""A student's page (OUT/students/<slug>/index.html) that teaches: the model's image beside
theirs with a flip control, the difference with its scale stated, each effect's points and
how the score is made in words, each reason once, a glossary of the effects and the quirks.
It links only to its own folder, so `grade --handout DIR` can send each folder as it is."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

from compare.grading.class_page import effect_weights
from compare.grading.results import SceneResult, StudentResult
from compare.judge.quirks import QUIRKS
from compare.pages.writer import write_page
from compare.student_ids import student_slug
from safe_files.paths import atomic_output, own_folder

# compare/judge/effects.py's masks, in a student's words.
EFFECTS = {
    "background": "pixels whose camera ray misses every sphere",
    "emitter": "pixels whose camera ray hits a light",
    "direct": "diffuse surfaces that every light reaches (lit, or facing away from it)",
    "shadow": "diffuse surfaces where a sphere blocks some light (cast shadows)",
    "reflection": "mirror spheres",
    "refraction": "glass spheres",
    "edges": "silhouettes: pixels where the sphere hit changes within the pixel",
}


def _scene_teaching(s: SceneResult, scenes: int) -> dict[str, Any]:
    """What the page says of one judged scene beyond the stored result: each effect's
    points and most points, and whether any pixel differs."""
    v = s.verdict or {}
    weights = effect_weights(s, scenes)
    effects: dict[str, Any] = v.get("effects", {})
    exact = v.get("exact")
    return {
        "points": {k: effects[k]["score"] * w for k, w in weights.items()},
        "most": {k: 100.0 * w for k, w in weights.items()},
        "share": {k: w * scenes for k, w in weights.items()},
        "differing": None if exact is None else exact.get("differing"),
        "scenes": scenes,
    }


def teaching(result: StudentResult) -> dict[str, Any]:
    """The page's extra context: per judged scene (by name) its teaching, and the glossary."""
    return {
        "scenes": {
            s.scene: _scene_teaching(s, len(result.scenes)) for s in result.scenes if s.verdict
        },
        "effects": EFFECTS,
        "quirks": QUIRKS,
    }


def write_student_page(page_dir: Path, result: StudentResult) -> None:
    write_page(
        page_dir / "index.html", "student.html.j2", r=result.to_json(), teach=teaching(result)
    )


def write_handouts(results: list[StudentResult], out: Path, handout: Path) -> list[Path]:
    """HANDOUT/<slug>/: a copy of each student's page folder (the page, its pictures), to
    send as it is. Only regular files are copied; no link is followed or made."""
    handout.mkdir(parents=True, exist_ok=True)
    made = []
    for r in results:
        slug = student_slug(r.student)
        source = out / "students" / slug
        if not source.is_dir():  # a resumed result whose page was removed: nothing to send
            continue
        target = own_folder(handout, slug)
        with os.scandir(source) as entries:
            for e in entries:
                if e.is_file(follow_symlinks=False):
                    with atomic_output(target / e.name) as tmp:
                        shutil.copyfile(e.path, tmp)
        made.append(target)
    return made
