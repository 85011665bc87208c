"""Paths, a subprocess runner and an rtdemo render shared by the test modules (imported as
`helpers`; pytest's rootdir-relative import puts tests/ on sys.path)."""

from __future__ import annotations

import json
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, Diagnosis, diagnose
from compare.judge.images import Image, read_image
from compare.render.cache import RenderCache
from scene_model.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"


def run(cmd: list[str], **kw: object) -> subprocess.CompletedProcess[str]:
    """Runs a command, capturing text output; never raises on a non-zero exit."""
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)  # type: ignore[call-overload]


_OUTPUT_FLAGS = {".exr": "-o", ".png": "--png", ".ppm": "--ppm"}


def render_demo(
    rtdemo: str,
    scene: Path | str,
    out: Path,
    *options: str,
    size: tuple[int, int] | None = None,
    **kw: object,
) -> Image:
    """`rtdemo render SCENE -o OUT [--width W --height H] OPTIONS...`, which must succeed
    (the assertion shows its stderr); the image it wrote. OUT's suffix picks the output option
    (.exr -o, .png --png, .ppm --ppm); kw goes to run() (env, timeout)."""
    flag = _OUTPUT_FLAGS[out.suffix]
    sized = [] if size is None else ["--width", str(size[0]), "--height", str(size[1])]
    proc = run([rtdemo, "render", str(scene), flag, str(out), *sized, *options], **kw)
    assert proc.returncode == 0, proc.stderr
    return read_image(out)


def diagnosed(
    image: Image, scene_file: Path, size: tuple[int, int], cache: RenderCache | Path
) -> tuple[dict[str, object], list[str]]:
    """`image` diagnosed against `scene_file` through a CandidateRenderer on `cache` (every
    render read from the cache, none from this process's memory): the diagnosis without its
    seconds, and the names of the candidates it asked for."""
    from compare.diagnose.renderer import CandidateRenderer, forget_recent
    from compare.diagnose.search import diagnose
    from scene_model.scene import load_scene

    forget_recent()
    with CandidateRenderer(scene_file, *size, cache=cache) as render:
        d = diagnose(image, load_scene(scene_file), render).as_dict()
    d.pop("seconds")
    return d, list(render.seen)


def chromium_browser():  # type: ignore[no-untyped-def]
    """(playwright, browser): Debian's Chromium under Playwright, as the page tests click."""
    from playwright.sync_api import sync_playwright  # deferred: only the page tests need it

    chromium = shutil.which("chromium")
    assert chromium, "Debian's chromium is installed by make setup"
    p = sync_playwright().start()
    args = ["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-sync"]
    return p, p.chromium.launch(executable_path=chromium, args=args)


def diagnose_scene_copy(
    rtdemo: str, tmp_path: Path, scene: Path, edit: Callable[[dict[str, Any]], None]
) -> Diagnosis:
    """rtdemo's classic render at 160x120 of a copy of `scene` that `edit` changes (a program
    with values of its own), diagnosed against the unchanged scene."""
    raw = json.loads(scene.read_text())
    edit(raw)
    own = tmp_path / "own.json"
    own.write_text(json.dumps(raw))
    size = (160, 120)
    image = render_demo(rtdemo, own, tmp_path / "own.ppm", "-q", "--mode", "classic", size=size)
    with CandidateRenderer(scene, *size, threads=1, cache=tmp_path / "cache") as render:
        return diagnose(image, load_scene(scene), render, DiagnoseOptions(parallel=2))
