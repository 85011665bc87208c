"""compare.judge.convergence: the time each renderer takes to reach the reference's own error."""

from __future__ import annotations

import numpy as np

from compare.judge.convergence import mitsuba_to_converged, time_to_converged
from compare.judge.images import Image


def _image(value: float, seconds: float, **header: str) -> Image:
    rgb = np.full((4, 4, 3), value, np.float32)
    return Image(rgb=rgb, aovs={}, header={"rtval.render_seconds": str(seconds), **header})


def test_the_first_spp_within_the_reference_error_is_timed() -> None:
    ref = _image(0.5, 40.0, **{"rtval.mean_stderr": "0.01", "rtval.spp": "32"})
    demo = {
        1: _image(0.55, 0.1),
        4: _image(0.52, 0.3),
        16: _image(0.505, 1.0),
        64: _image(0.5, 4.0),
    }
    c = time_to_converged(ref, demo)
    assert set(c["demo_errors"]) == {"1", "4", "16"}
    assert abs(c["demo_errors"]["4"] - 0.02) < 1e-6 and abs(c["demo_errors"]["16"] - 0.005) < 1e-6
    assert c["demo_spp"] == 16 and c["demo_seconds"] == 1.0
    assert c["reference_seconds"] == 40.0 and c["reference_spp"] == 32
    assert abs(c["speedup"] - 40.0) < 1e-9


def test_not_reached_is_said_not_guessed() -> None:
    ref = _image(0.5, 40.0, **{"rtval.mean_stderr": "0.001", "rtval.spp": "32"})
    demo = {1: _image(0.6, 0.1), 4: _image(0.55, 0.3), 64: _image(0.5, 4.0)}
    c = time_to_converged(ref, demo)
    assert c["demo_spp"] is None and np.isnan(c["speedup"])


def test_an_image_with_no_noise_is_converged_at_once_and_never_nan() -> None:
    """A scene where nothing varies between samples (the sky alone, no light): the reference's
    error is 0, every render reaches it at its first spp, and no number is NaN."""
    var = {f"var.{c}": np.zeros((4, 4), np.float32) for c in "RGB"}
    header = {"rtval.render_seconds": "2.0", "rtval.mean_stderr": "0", "rtval.spp": "32"}
    ref = Image(rgb=np.ones((4, 4, 3), np.float32), aovs=var, header=header)
    demo = {spp: _image(1.0, 0.01 * spp) for spp in (1, 4, 16, 64)}
    c = time_to_converged(ref, demo)
    assert c["target_error"] == 0 and c["demo_spp"] == 1 and c["speedup"] == 200.0
    assert all(e == 0 for e in c["demo_errors"].values())
    cands = [{"key": "ref", "label": "ref", "spp": 32, "image": ref}]
    cands.append({"key": "path", "label": "path", "spp": 4, "image": _image(1.0, 0.5)})
    m = mitsuba_to_converged(ref, cands, {"ref"})
    assert [r["error"] for r in m["configurations"]] == [0.0, 0.0]
    assert all(r["reaches"] for r in m["configurations"]) and m["fastest"]["key"] == "path"
