"""The Fresnel curve's constants fitted as values (compare/diagnose/fresnel_fit.py): rtdemo's
own renders of the classic scene with a curve a student might type are diagnosed as that
curve, named as a constant with its mix and power; the paper's curve gets none."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import SCENES, render_demo

from compare.diagnose.renderer import CandidateRenderer
from compare.diagnose.search import DiagnoseOptions, Diagnosis, diagnose
from compare.judge.images import read_image
from scene_model.scene import load_scene

CLASSIC = SCENES / "classic.json"
W, H = 160, 120


def _diagnosed(rtdemo: str, tmp_path: Path, *curve: str) -> Diagnosis:
    out = tmp_path / "student.ppm"
    render_demo(rtdemo, CLASSIC, out, "-q", "--mode", "classic", *curve, size=(W, H))
    with CandidateRenderer(CLASSIC, W, H, threads=1) as render:
        return diagnose(read_image(out), load_scene(CLASSIC), render, DiagnoseOptions(parallel=2))


@pytest.mark.parametrize(
    ("mix", "power", "name"),
    [
        # rust-fresnel_constants_swapped's 0.9 + 0.1 (1 - cos)^3 (tests/corpus/classic.rs)
        ("0.9", "3", "Fresnel 0.9 + 0.1 (1 - cos)^3"),
        # away from every seed (switches.FRESNEL_SEEDS) in both constants
        ("0.65", "4", "Fresnel 0.65 + 0.35 (1 - cos)^4"),
        # Schlick's curve for ior 1.5, a seed
        ("0.04", "5", "Fresnel 0.04 + 0.96 (1 - cos)^5"),
    ],
)
def test_a_students_fresnel_curve_is_fitted(
    rtdemo: str, tmp_path: Path, mix: str, power: str, name: str
) -> None:
    d = _diagnosed(rtdemo, tmp_path, "--fresnel-mix", mix, "--fresnel-power", power)
    assert d.causes == [name] and d.mode == "classic" and d.exact, d.sentences
    cause = d.as_dict()["causes"][0]
    assert cause["kind"] == "constant" and "the paper's: 0.1 + 0.9 (1 - cos)^3" in cause["sentence"]


def test_the_papers_curve_gets_no_fresnel_cause(rtdemo: str, tmp_path: Path) -> None:
    d = _diagnosed(rtdemo, tmp_path)
    assert d.result == "classic" and not d.steps and d.exact, d.sentences
