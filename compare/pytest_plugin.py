"""A pytest plugin: a renderer's own test suite checks a scene in one line.

    def test_classic_scene(rtval_check):
        rtval_check("scenes/classic.json", renderer="./build/tracer {scene} {out}")

The fixture runs `rtval check --renderer ...` in-process on one scene and fails the test with
the failures named by scene and effect. Baselines live in `rtval-baselines/` under pytest's
rootdir (ini option `rtval_baseline`); `pytest --rtval-update` writes new or failing ones.
Installed with rtval as the `rtval` pytest11 entry point; elsewhere `-p compare.pytest_plugin`.
Imports nothing heavy until the fixture is used.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Required, TypedDict, Unpack

import pytest

if TYPE_CHECKING:
    from compare.check.run import CaseResult


class CheckOptions(TypedDict, total=False):
    """The fixture's keyword options: renderer is required; the defaults are named."""

    renderer: Required[str]  # a command template, e.g. "./tracer {scene} {out}"
    name: str | None
    size: tuple[int, int]  # default (320, 240)
    output_format: str  # default "exr"
    against: str | None
    mode: str | None
    spp: int  # default 1
    timeout: float | None
    baseline: str | Path | None


def _scene_file(root: Path, scene: str | Path) -> Path:
    """A path relative to the rootdir, else a built-in scene's name (classic, paper, lit)."""
    from scene_model.builtin import scene_path  # deferred: as the fixture's imports

    path = root / scene
    return path if path.exists() else scene_path(str(scene))


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("rtval", "rtval regression check")
    group.addoption(
        "--rtval-update",
        action="store_true",
        default=False,
        help="rtval_check: write new or failing baselines instead of failing",
    )
    parser.addini(
        "rtval_baseline",
        "rtval_check: the baseline folder, relative to the rootdir (default rtval-baselines)",
        default="rtval-baselines",
    )


@pytest.fixture
def rtval_check(request: pytest.FixtureRequest) -> Callable[..., CaseResult]:
    """check(scene, *, renderer, name=None, size=(320, 240), output_format="exr",
    against=None, mode=None, spp=1, timeout=None, baseline=None) -> CaseResult; fails the
    test when the check fails."""
    config = request.config

    def check(scene: str | Path, **options: Unpack[CheckOptions]) -> CaseResult:
        # deferred: pytest loads this plugin in every session of the renderer's own suite
        from compare.check import run as app  # deferred: as above
        from compare.judge.target_model import parse_model  # deferred: as above
        from compare.render import foreign  # deferred: as above

        root = Path(config.rootpath)
        baseline, mode = options.get("baseline"), options.get("mode")
        against = options.get("against")
        model = parse_model(against) if against else None
        folder = Path(baseline) if baseline else root / str(config.getini("rtval_baseline"))
        cmd = foreign.parse_command(
            options["renderer"], options.get("name"), options.get("output_format", "exr")
        )
        settings = app.CheckSettings(
            scenes=[str(_scene_file(root, scene))],
            baseline_dir=folder if folder.is_absolute() else root / folder,
            size=options.get("size", (320, 240)),
            modes=[mode] if mode else list(app.DEFAULT_MODES),
            update=bool(config.getoption("--rtval-update")) and against is None,
            renderer=cmd,
            against=model,
            spp=options.get("spp", 1),
            timeout=options.get("timeout"),
        )
        lines: list[str] = []
        results = app.run_check(settings, progress=lines.append)
        failed = [r for r in results if r.status == "fail" and not r.updated]
        if failed:
            message: list[Any] = [m for r in failed for m in r.reasons]
            if any("no baseline" in str(m) for m in message):
                message.append("(run pytest --rtval-update once to write the baselines)")
            pytest.fail("rtval check failed:\n" + "\n".join(map(str, message)), pytrace=False)
        return results[0]

    return check
