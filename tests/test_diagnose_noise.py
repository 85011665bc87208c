"""Random noise on every pixel (compare/diagnose/noise.py): named as an image cause and taken
out before the search, so that a bug beyond it is still found; never named for an error that
has structure (a scale, shadow acne) or for a clean image."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import SCENES, render_demo

from compare.diagnose import noise
from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, Diagnosis, diagnose
from compare.judge.images import read_image
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 160, 120


def _render(rtdemo: str, tmp_path: Path, *args: str) -> np.ndarray:
    out = tmp_path / f"r{len(list(tmp_path.iterdir()))}.exr"
    image = render_demo(rtdemo, CLASSIC, out, "-q", "--mode", "classic", *args, size=(W, H))
    return np.clip(np.nan_to_num(image.rgb), 0, 1)


def _ppm(path: Path, rgb: np.ndarray, sigma: float, seed: int = 7) -> Path:
    noisy = rgb + np.random.default_rng(seed).normal(0, sigma, rgb.shape)
    codes = np.floor(255 * np.clip(noisy, 0, 1)).astype(np.uint8)  # a truncating writer
    path.write_bytes(f"P6\n{W} {H}\n255\n".encode() + codes.tobytes())
    return path


def _diagnosed(path: Path) -> Diagnosis:
    with CandidateRenderer(CLASSIC, W, H, threads=1) as render:
        return diagnose(read_image(path), load_scene(CLASSIC), render, DiagnoseOptions(parallel=2))


def test_noise_on_a_right_image_is_named_and_nothing_else(rtdemo: str, tmp_path: Path) -> None:
    d = _diagnosed(_ppm(tmp_path / "noisy.ppm", _render(rtdemo, tmp_path), 0.01))
    causes = d.as_dict()["causes"]
    assert [c["kind"] for c in causes] == ["image"], d.sentences
    assert causes[0]["name"].startswith("random noise on every pixel (about 2.")  # 2.55 levels
    assert d.result == "classic" and not d.steps and d.exact, d.sentences


def test_a_bug_under_the_noise_is_localised_not_named(rtdemo: str, tmp_path: Path) -> None:
    # No candidate's codes match noisy pixels exactly, so no step is named through the
    # noise: the refraction that differs beyond it is told where it lives.
    wrong = _render(rtdemo, tmp_path, "--mistake", "eta_inverted")
    d = _diagnosed(_ppm(tmp_path / "noisy.ppm", wrong, 0.01))
    causes = d.as_dict()["causes"]
    assert len(causes) == 1 and causes[0]["name"].startswith("random noise"), d.sentences
    assert not d.steps and d.effects["refraction"].state == "unexplained", d.sentences
    assert "refraction" in " ".join(d.sentences[-3:]), d.sentences


@pytest.mark.parametrize(
    "what",
    ["clean", "scaled by 0.9", "shadow acne (no_offset)", "eta_inverted"],
)
def test_errors_with_structure_are_not_noise(rtdemo: str, tmp_path: Path, what: str) -> None:
    right = _render(rtdemo, tmp_path)
    image = {
        "clean": lambda: right,
        "scaled by 0.9": lambda: 0.9 * right,
        "shadow acne (no_offset)": lambda: _render(rtdemo, tmp_path, "--mistake", "no_offset"),
        "eta_inverted": lambda: _render(rtdemo, tmp_path, "--mistake", "eta_inverted"),
    }[what]()
    stored = np.floor(255 * np.clip(image, 0, 1)) / 255
    assert noise.fitted(stored.astype(np.float32), right.astype(np.float32), "linear") is None


def test_noise_is_fitted_as_its_spread(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    right = rng.uniform(0.2, 0.8, (H, W, 3)).astype(np.float32)
    for sigma in (0.01, 0.03):
        noisy = np.floor(255 * np.clip(right + rng.normal(0, sigma, right.shape), 0, 1)) / 255
        fit = noise.fitted(noisy.astype(np.float32), right, "linear")
        assert fit is not None and fit.undo is not None
        # the spread of the middle 98 %: 0.96 of the noise's here (measured), less where
        # values clip (2.1 of 2.55 levels on the classic scene's white background)
        assert 0.8 * 255 * sigma <= fit.value <= 1.02 * 255 * sigma
        undone = fit.undo(noisy.astype(np.float32))
        assert np.array_equal(undone, (np.floor(255 * right) / 255).astype(np.float32))
