"""What a program's image writer does to a right image (compare/diagnose/transforms.py),
fitted on the image against the start's render and named as a cause of kind "image": the
classic program's pixels from rtdemo, written by a PPM writer with one such mistake."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo

from compare.diagnose.evidence import diagnose_image
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, diagnose
from compare.judge.images import linear_to_srgb, read_image
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 160, 120
F64 = np.ndarray


def _codes(v: F64) -> np.ndarray:
    return (np.clip(v, 0.0, 1.0) * 255).astype(np.uint8)  # clamped and truncated


WRITERS: dict[str, tuple[Callable[[F64], np.ndarray], str]] = {
    "bgr": (lambda x: _codes(x[..., ::-1]), "channels written as B, G, R (not R, G, B)"),
    "sqrt": (lambda x: _codes(np.sqrt(np.clip(x, 0, 1))), "every value raised to the power 1/2"),
    "gamma_2.2": (lambda x: _codes(np.clip(x, 0, 1) ** 2.2), "every value raised to the power 2.2"),
    "scale_0.8": (lambda x: _codes(0.8 * x), "every value multiplied by 0.8"),
    "srgb": (
        lambda x: _codes(linear_to_srgb(x.astype(np.float32)).astype(np.float64)),
        "the sRGB curve applied before writing (encoded twice)",
    ),
    "no_clamp": (
        lambda x: (np.floor(x * 255).astype(np.int64) & 255).astype(np.uint8),
        "values over 1 not clamped: they wrap round to dark codes",
    ),
}


@pytest.fixture(scope="module")
def classic(rtdemo: str, tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    out = tmp_path_factory.mktemp("classic") / "c.exr"
    im = render_demo(rtdemo, CLASSIC, out, "-q", "--mode", "classic", size=(W, H))
    return np.nan_to_num(im.rgb.astype(np.float64))


@pytest.mark.slow
@pytest.mark.parametrize("writer", list(WRITERS))
def test_a_writers_transform_is_fitted_and_named(
    classic: np.ndarray, tmp_path: Path, writer: str
) -> None:
    write, words = WRITERS[writer]
    ppm = tmp_path / f"{writer}.ppm"
    ppm.write_bytes(f"P6\n{W} {H}\n255\n".encode() + write(classic).tobytes())
    with CandidateRenderer(CLASSIC, W, H, threads=1, cache=tmp_path / "cache") as render:
        d = diagnose(read_image(ppm), load_scene(CLASSIC), render, DiagnoseOptions(parallel=2))
    # Before: "not explained" in every effect, or quirks fitted to the tone (gamma 2.2 was
    # "+Q7 +Q2, background (1, 1, 1)").
    assert d.image_transforms == [words] and d.causes == [words], d.sentences
    assert d.result == "classic" and d.steps == [] and d.exact, d.sentences
    assert f"the image was written with {words}" in d.summary
    cause = d.as_dict()["causes"][0]
    assert cause["kind"] == "image" and cause["name"] == words
    assert cause["evidence"] and all(
        e["differing"][1] <= e["differing"][0] // 2 for e in cause["evidence"].values()
    )


def test_a_right_image_has_no_transform(classic: np.ndarray, tmp_path: Path) -> None:
    ppm = tmp_path / "right.ppm"
    ppm.write_bytes(f"P6\n{W} {H}\n255\n".encode() + _codes(classic).tobytes())
    with CandidateRenderer(CLASSIC, W, H, threads=1, cache=tmp_path / "cache") as render:
        d = diagnose(read_image(ppm), load_scene(CLASSIC), render, DiagnoseOptions(parallel=2))
    assert d.image_transforms == [] and d.causes == [] and d.exact


def test_the_evidence_shows_candidates_through_the_writers_transform(
    classic: np.ndarray, tmp_path: Path
) -> None:
    # The student page's pictures: the candidate as the writer would have stored it, so the
    # difference that the diagnosis explains is gone from them (x 8: one level shows as 8).
    write, words = WRITERS["scale_0.8"]
    ppm = tmp_path / "dim.ppm"
    ppm.write_bytes(f"P6\n{W} {H}\n255\n".encode() + write(classic).tobytes())
    out = diagnose_image(read_image(ppm), CLASSIC, tmp_path / "cache", tmp_path / "pages")
    assert out["image_transforms"] == [words]
    assert out["causes"][0]["kind"] == "image" and "then every value" in out["command"]
    diff = linear_to_srgb(read_image(tmp_path / "pages" / out["evidence"][0]["diff"]).rgb)
    shown = linear_to_srgb(read_image(ppm).rgb)
    raw = np.clip(8 * np.abs(shown - linear_to_srgb(classic.astype(np.float32))), 0, 1)
    # Measured at 160x120: a mean of 0.020 (the truncating writer's last level, x 8 in the
    # dark) against 0.235 for the render shown as it is.
    assert float(diff.mean()) < 0.2 * float(raw.mean())
