"""Grading's typed results (compare/grading/results.py): they write exactly the JSON the
results files hold and read it back strictly; --explain's arithmetic is scoring.py's; the
model cache (compare/verdict/against.py) keeps several models, keyed by the files' identity."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import SCENES

from compare.grading.gradebook import explain
from compare.grading.results import BadResult, SceneResult, StudentResult, read_result
from compare.judge.images import write_exr
from compare.judge.scoring import EffectRule, EffectScore, Term, _overall, weighted_score
from compare.verdict import against


def _effect(pixels: int, weight: float, score: float) -> dict[str, Any]:
    rule = {"min_ssim": 0.5, "max_flip": 0.1, "weight": weight}
    return {"status": "pass", "score": score, "reasons": [], "pixels": pixels, "ssim": 0.9,
            "flip": 0.01, "differing": None, "rule": rule}  # fmt: skip


def _stored(effects: dict[str, Any]) -> dict[str, Any]:
    """A result as grade writes it: one judged scene, one missing one."""
    overall = weighted_score(
        {k: Term(e["pixels"], e["rule"]["weight"], e["score"]) for k, e in effects.items()}
    )[0]
    verdict = {"status": "pass", "score": overall, "basis": "flip", "effects": effects,
               "absent_effects": {}, "flip_at_zero_score": 0.5, "pass_score": 60.0}  # fmt: skip
    judged = {"scene": "classic", "model": "mitsuba", "diagnosis": "", "status": "pass",
              "score": overall, "reason": "", "verdict": verdict, "sentences": ["ok"],
              "nan_pixels": 0, "diagnosis_detail": None}  # fmt: skip
    missing = {"scene": "paper", "model": "mitsuba", "diagnosis": "", "status": "missing",
               "score": 0.0, "reason": "no image for scene 'paper'"}  # fmt: skip
    return {"student": "ann", "key": "k" * 24, "status": "fail", "score": overall / 2,
            "model": "mitsuba", "reasons": "paper: no image for scene 'paper'", "diagnosis": "",
            "scenes": [judged, missing], "rubric": "default rubric", "seconds": 0.5,
            "page": "students/ann/index.html"}  # fmt: skip


def test_the_json_round_trips_exactly() -> None:
    stored = _stored({"shadow": _effect(300, 1.0, 80.0), "direct": _effect(100, 2.0, 50.0)})
    text = json.dumps(stored, indent=2)
    result = StudentResult.from_json(json.loads(text))
    assert result.dumps() == text
    assert result.scenes[1] == SceneResult("paper", "mitsuba", "missing", 0.0, stored["scenes"][1]["reason"])  # fmt: skip
    with_program = {**stored, "program": {"sandboxed": True}}
    assert StudentResult.from_json(with_program).to_json() == with_program


@pytest.mark.parametrize(
    "damage",
    [
        lambda d: d.pop("scenes"),
        lambda d: d.__setitem__("score", "100"),
        lambda d: d.__setitem__("score", True),
        lambda d: d["scenes"][0].pop("reason"),
        lambda d: d["scenes"][0].__setitem__("verdict", []),
    ],
)
def test_a_result_missing_a_field_is_no_result(tmp_path: Path, damage: Any) -> None:
    stored = _stored({"shadow": _effect(300, 1.0, 80.0)})
    damage(stored)
    path = tmp_path / "ann.json"
    path.write_text(json.dumps(stored))
    with pytest.raises(BadResult, match=r"ann\.json"):
        read_result(path)
    assert read_result(tmp_path / "none.json") is None


@pytest.mark.parametrize("weights", [(1.0, 2.0), (0.0, 0.0)])
def test_explain_shows_the_verdicts_own_weights(
    tmp_path: Path, weights: tuple[float, float]
) -> None:
    """The shares --explain prints multiply out to the stored score, as scoring.py computes
    it: with all weights 0 too (scored by pixels alone), where explain once printed 0."""
    rules = [EffectRule(weight=w) for w in weights]
    effects = {"shadow": EffectScore("pass", 80.0, [], 300, 0.9, 0.01, rules[0]),
               "direct": EffectScore("pass", 50.0, [], 100, 0.9, 0.01, rules[1])}  # fmt: skip
    stored = _stored({k: _effect(e.pixels, e.rule.weight, e.score) for k, e in effects.items()})
    assert stored["scenes"][0]["score"] == _overall(effects)
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "ann.json").write_text(json.dumps(stored))
    lines = [ln for ln in explain(tmp_path, "ann").splitlines() if ln.split()[0] in effects]
    parts = [float(ln.rsplit("= ", 1)[1]) for ln in lines]
    assert len(parts) == 2 and sum(parts) == pytest.approx(_overall(effects), abs=0.1)


def test_several_models_stay_loaded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`--scene classic --scene paper`: the masks of each model are computed once, not once
    per student; a render replaced at the same path is loaded again."""
    calls: list[str] = []
    real = against.effect_masks
    monkeypatch.setattr(against, "_LOADED", {})
    monkeypatch.setattr(against, "effect_masks", lambda *a: calls.append("m") or real(*a))
    models = []
    for name in ("classic", "paper"):
        exr = tmp_path / f"{name}.exr"
        rgb = np.zeros((6, 8, 3), np.float32)
        write_exr(exr, rgb, aovs={"id": np.zeros((6, 8), np.float32), "depth": rgb[..., 0]})
        models.append(against.ModelRenders("classic", str(SCENES / f"{name}.json"), str(exr)))
    for _student in range(3):
        for m in models:
            against.load(m)
    assert len(calls) == 2
    rgb = np.ones((6, 8, 3), np.float32)
    write_exr(models[0].reference, rgb, aovs={"id": rgb[..., 0], "depth": rgb[..., 0]})
    assert against.load(models[0]).reference.rgb.max() == 1.0 and len(calls) == 3
