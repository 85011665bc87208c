"""An image without one finite pixel (all NaN, all infinite) has nothing to explain: diagnose
says so once (NoFinitePixels; `rtval diagnose` exits 4, as for an unusable input) instead of
naming mistakes or unexplained regions for it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, run

from compare.diagnose.candidate import Candidate
from compare.diagnose.search import DiagnoseError, FunctionRenderer, NoFinitePixels, diagnose
from compare.judge.images import Image, write_exr
from compare.judge.target_model import TargetModel
from scene_model.scene import load_scene

RTVAL = str(Path(sys.executable).with_name("rtval"))
CLASSIC = SCENES / "classic.json"


def _nonfinite(kind: str) -> np.ndarray:
    rgb = np.full((12, 16, 3), np.nan, np.float32)
    if kind == "infinite":
        rgb[:] = np.inf
        rgb[::2] = -np.inf
    elif kind == "mixed":
        rgb[:, ::3] = np.inf
    return rgb


def _never(c: TargetModel | Candidate) -> Image:
    raise AssertionError(f"rendered {c.name} for an image with nothing to explain")


@pytest.mark.parametrize("kind", ["nan", "infinite", "mixed"])
def test_no_finite_pixel_is_one_clear_finding(kind: str) -> None:
    image = Image(rgb=_nonfinite(kind), encoding="float", path=f"{kind}.exr")
    with pytest.raises(NoFinitePixels, match=rf"{kind}\.exr: no finite pixel"):
        diagnose(image, load_scene(CLASSIC), FunctionRenderer(_never))
    assert issubclass(NoFinitePixels, DiagnoseError)  # grade and report say it in the cell


def test_rtval_diagnose_exits_4_and_writes_nothing(tmp_path: Path) -> None:
    image, out = tmp_path / "nan.exr", tmp_path / "d.json"
    write_exr(image, _nonfinite("nan"))
    proc = run([RTVAL, "diagnose", str(image), "--scene", str(CLASSIC), "--json", str(out),
                "--cache", str(tmp_path / "c")])  # fmt: skip
    assert proc.returncode == 4, proc.stderr
    assert "no finite pixel" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists() and proc.stdout == ""


def test_one_finite_pixel_is_still_diagnosed() -> None:
    rgb = _nonfinite("nan")
    rgb[0, 0] = 0.5
    # No error before the search: the search itself then runs (and needs a renderer).
    with pytest.raises(AssertionError, match="rendered"):
        diagnose(Image(rgb=rgb, encoding="float"), load_scene(CLASSIC), FunctionRenderer(_never))
