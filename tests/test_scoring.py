"""The grading arithmetic pinned with numbers worked by hand (docs/metrics.md states the rules):
an effect's score is 100 (1 - FLIP / flip_at_zero) clamped to [0, 100]; the overall score is the
mean of the effect scores weighted by pixels x rule weight; an effect passes with FLIP <= max_flip
and SSIM >= min_ssim; the pixel tolerances count errors strictly over their thresholds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.judge.effects import EFFECTS
from compare.judge.evaluate import evaluate_pair
from compare.judge.metrics import Metrics
from compare.judge.rubric import RubricError, parse_rubric
from compare.judge.scoring import EffectRule, effect_score, score_effects
from compare.judge.tolerances import Tolerances


def metrics(pixels: int, flip: float, ssim: float = 0.9) -> Metrics:
    nan = float("nan")
    return Metrics(
        pixels=pixels,
        ssim=ssim,
        flip_ldr=flip,
        flip_hdr=None,
        psnr_db=nan,
        rmse_display=nan,
        mae_display=nan,
        rmse_linear=nan,
        mae_linear=nan,
        rel_mse_linear=nan,
        max_error_linear=nan,
        max_error_at=None,
        over_threshold=0,
        threshold=0.01,
        nan_ref=0,
        nan_test=0,
        inf_ref=0,
        inf_test=0,
    )


@pytest.mark.parametrize(
    ("flip", "score"), [(0.0, 100.0), (0.05, 90.0), (0.25, 50.0), (0.5, 0.0), (0.8, 0.0)]
)
def test_effect_score_at_a_given_flip(flip: float, score: float) -> None:
    assert effect_score(flip) == pytest.approx(score, abs=1e-12)


def test_flip_at_zero_moves_the_line() -> None:
    # 100 (1 - 0.05 / 0.25) = 80
    assert effect_score(0.05, flip_at_zero=0.25) == pytest.approx(80.0)


def test_two_effects_weighted_by_pixels() -> None:
    # 300 px at FLIP 0.05 (score 90) and 100 px at FLIP 0.25 (score 50):
    # (300 * 90 + 100 * 50) / 400 = 80.
    s = score_effects({"direct": metrics(300, 0.05), "shadow": metrics(100, 0.25)})
    assert s.score == pytest.approx(80.0)
    assert s.effects["direct"].status == "pass" and s.effects["shadow"].status == "fail"
    assert s.status == "fail" and s.failing_effects == ["shadow"]
    assert s.effects["shadow"].reasons == ["FLIP 0.250 > 0.1"]


def test_rule_weight_multiplies_the_pixel_share() -> None:
    # The shadow effect weighs 2: (300 * 90 + 2 * 100 * 50) / (300 + 200) = 74.
    rules = {"shadow": EffectRule(max_flip=0.3, weight=2.0)}
    s = score_effects({"direct": metrics(300, 0.05), "shadow": metrics(100, 0.25)}, rules)
    assert s.score == pytest.approx(74.0)
    assert s.status == "pass"  # FLIP 0.25 <= 0.3 under the rule


def test_weights_of_effects_the_image_lacks_fall_back_to_pixels() -> None:
    """Only shadows weighted, in an image without shadows (the paper's lightless scene):
    the overall score is the pixel-weighted mean, never 0 for a perfect image."""
    rules = {k: EffectRule(weight=0.0) for k in ("direct", "reflection")}
    s = score_effects({"direct": metrics(300, 0.0), "reflection": metrics(100, 0.0)}, rules)
    assert s.score == pytest.approx(100.0) and s.status == "pass"


def test_rubric_weights_are_bounded_and_not_all_zero() -> None:
    """The hostile-input pass: weight = 1e308 on two effects made every score NaN (and bare
    NaN in gradebook.json); all weights 0 failed everyone."""
    with pytest.raises(RubricError, match=r"line 2: weight must be a number from 0 to 1000"):
        parse_rubric("[effects.direct]\nweight = 1e308\n", "r.toml")
    zero = "".join(f"[effects.{e}]\nweight = 0\n" for e in EFFECTS)
    with pytest.raises(RubricError, match="every effect has weight 0"):
        parse_rubric(zero, "r.toml")
    r = parse_rubric("[effects.direct]\nweight = 1000\n[effects.shadow]\nweight = 1000\n")
    big = 16384 * 16384
    s = score_effects({"direct": metrics(big, 0.05), "shadow": metrics(big, 0.25)}, r.effects)
    assert math.isfinite(s.score) and s.score == pytest.approx(70.0)


def test_a_rubric_nested_too_deeply_is_an_error_not_a_crash() -> None:
    deep = "x = " + "[" * 100_000 + "]" * 100_000 + "\n"
    with pytest.raises(RubricError, match="nested too deeply"):
        parse_rubric(deep, "deep.toml")


@pytest.mark.parametrize(
    ("flip", "ssim", "status"),
    [
        (0.10, 0.5, "pass"),  # both exactly on the default boundary pass
        (0.1001, 0.9, "fail"),
        (0.05, 0.4999, "fail"),
        (0.05, float("nan"), "fail"),  # SSIM undefined (region too small): never a pass
    ],
)
def test_pass_fail_boundaries(flip: float, ssim: float, status: str) -> None:
    assert score_effects({"direct": metrics(10, flip, ssim)}).status == status


def test_pass_score_boundary() -> None:
    # One effect at FLIP 0.1 scores exactly 80.
    one = {"direct": metrics(10, 0.1)}
    assert score_effects(one, pass_score=80.0).status == "pass"
    assert score_effects(one, pass_score=80.5).status == "fail"


def test_no_effects_is_a_fail_with_score_zero() -> None:
    s = score_effects({})
    assert s.status == "fail" and s.score == 0.0


def test_tolerances_count_errors_strictly_over_the_threshold() -> None:
    ref = np.full((16, 16, 3), 0.5, np.float32)
    test = ref.copy()
    # Display error: the sRGB-encoded difference. Make 3 pixels differ clearly, 1 barely.
    test[0, 0] = 0.6
    test[0, 1] = 0.6
    test[0, 2] = 0.6
    test[5, 5] = 0.5001  # far below 1/255 after encoding
    tol = Tolerances(fail=0.01, failpercent=3 / 256 * 100, warn=1 / 255, warnpercent=0.0)
    ev = evaluate_pair(ref, test, tolerances=tol)
    assert ev.verdict.failing_pixels == 3 and ev.verdict.warning_pixels == 3
    assert ev.verdict.status == "warn"  # 3 of 256 allowed to fail, none allowed to warn
    tighter = Tolerances(fail=0.01, failpercent=2 / 256 * 100)
    assert evaluate_pair(ref, test, tolerances=tighter).verdict.status == "fail"
    assert math.isclose(ev.metrics.pixels, 256)
