"""The exact-match rule (compare/judge/exact_match.py) on hand-made pixels: either 8-bit
convention matches, one level beyond it does not; the sRGB case works in the encoded domain;
floats within half-float precision; NaN in the model; sub-pixel offset renders; the bound."""

from __future__ import annotations

import numpy as np
import pytest

from compare.judge.evaluate import ExactInputs, evaluate_pair
from compare.judge.exact_match import allowed_differing, channel_matches, exact_match
from compare.judge.images import linear_to_srgb, srgb_to_linear
from compare.judge.rubric import RubricError, parse_rubric


def _px(*values: float) -> np.ndarray:
    """One pixel per value, grey."""
    return np.repeat(np.array(values, np.float32)[:, None], 3, axis=1)[None]


def test_truncating_and_rounding_codes_both_match_and_nothing_else() -> None:
    x = np.float32(100.7 / 255)  # truncation writes 100, rounding 101
    model = _px(x, x, x, x)
    test = _px(99 / 255, 100 / 255, 101 / 255, 102 / 255)
    assert channel_matches(model, test, "linear").tolist() == [[False, True, True, False]]


def test_values_above_one_and_below_zero_clamp() -> None:
    model = _px(2.0, -0.5)
    assert channel_matches(model, _px(1.0, 0.0), "linear").all()
    assert not channel_matches(model, _px(254 / 255, 1 / 255), "linear").any()


def test_srgb_compares_encoded_codes() -> None:
    # A dark value: one linear 8-bit level is ~13 sRGB levels here; the rule works on codes.
    x = np.float32(0.00123)
    code = 255 * float(linear_to_srgb(np.array([x], np.float32))[0])  # ~ 40.3
    lo, hi = int(np.floor(code)), int(np.floor(code + 0.5))
    test = np.array([lo - 1, lo, hi, hi + 1], np.float32) / 255
    got = channel_matches(_px(x, x, x, x), _px(*srgb_to_linear(test)), "srgb")
    assert got.tolist() == [[False, True, True, False]]


def test_float_tolerance_is_half_float_precision() -> None:
    model = _px(0.5, 0.5, 0.0, 2e-8)  # half floats step by 2^-24 near 0
    test = _px(0.5 * (1 + 2**-12), 0.5 * (1 + 2**-9), 2**-26, 0.0)
    assert channel_matches(model, test, "float").tolist() == [[True, False, True, True]]


def test_nan_in_the_model_accepts_both_c_conventions() -> None:
    nan = float("nan")
    model = _px(nan, nan, nan)
    assert channel_matches(model, _px(0.0, 1.0, 0.5), "linear").tolist() == [[True, True, False]]


def test_value_slack_covers_float32_reordering_at_a_code_boundary() -> None:
    # 184.0077 in the model, 183.99 in another float32 program: truncation gives 183.
    x = np.float32(184.0077 / 255)
    assert not channel_matches(_px(x), _px(183 / 255), "linear").all()
    y = np.float32(184.001 / 255)  # 5e-6 relative: within 2^-16
    assert channel_matches(_px(y), _px(183 / 255), "linear").all()


def test_offset_renders_accept_edge_pixels_and_count_them() -> None:
    centre = np.zeros((4, 4, 3), np.float32)
    shifted = centre.copy()
    shifted[1, 1] = 1.0  # a silhouette pixel that flips under a 1e-4 px turn
    test = shifted.copy()
    alone = exact_match([centre], test, "linear", model="classic")
    assert alone.differing == 1 and alone.unstable_pixels == 0
    both = exact_match([centre, shifted], test, "linear", model="classic")
    assert both.differing == 0 and both.unstable_pixels == 1 and both.passed


def test_the_spread_is_symmetric_and_only_where_the_renders_move() -> None:
    """scratchapixel's raytracer.cpp (-O2) at classic (570, 190): centre 193.71, the turned
    renders 192.32 ... 193.79, the program 195: within x0 + u (u = 1.39 codes), so it
    matches; the same 195 where every render says 193.71 does not."""
    centre = np.full((2, 2, 3), 193.71 / 255, np.float32)
    turned = centre.copy()
    turned[0, 0] = 192.32 / 255
    test = np.full((2, 2, 3), 195 / 255, np.float32)
    got = exact_match([centre, turned], test, "linear", model="classic")
    assert got.matches.tolist() == [[True, False], [False, False]]
    assert got.unstable_pixels == 1


def test_effect_bound_and_scores() -> None:
    h, w = 50, 40  # 2000 pixels per effect: ceil(sqrt(2000) / 16) = 3 stray pixels may differ
    model = np.full((h, w, 3), 0.5, np.float32)
    masks = {"direct": np.ones((h, w), bool)}
    assert allowed_differing(2000) == 3 and allowed_differing(10) == 1
    assert allowed_differing(200) == 1 and allowed_differing(10_000) == 7
    assert allowed_differing(434_103) == 42  # the paper scene's reflections at 1200x800
    test = model.copy()
    test[0, :2] = 0.0
    ev = evaluate_pair(model, test, masks=masks, exact=ExactInputs("classic", [], "float"))
    assert ev.score is not None and ev.score.status == "pass" and ev.score.basis == "exact"
    assert ev.score.score == 100.0  # strays within the allowance cost no point
    assert "maps" not in ev.__dict__  # an exact pass never computes FLIP or SSIM
    test[0, :5] = 0.0
    ev = evaluate_pair(model, test, masks=masks, exact=ExactInputs("classic", [], "float"))
    assert ev.score is not None and ev.score.status == "fail"
    (reason,) = ev.score.reasons()
    assert reason.startswith("direct: 5 px (0.25 %) differ from classic beyond half-float")
    assert ev.score.score == pytest.approx(100 * (1 - 5 / 2000))  # a fail: the share matching
    assert "FLIP" in reason and ev.score.effects["direct"].flip is not None


def test_rubric_against_is_validated_with_its_line() -> None:
    r = parse_rubric('[rubric]\nagainst = "Classic+q2"\n', "r.toml")
    assert r.against == "classic+Q2"
    assert parse_rubric("[rubric]\npass_score = 50\n").against is None
    with pytest.raises(RubricError, match=r"r\.toml: line 3: unknown model 'phong'"):
        parse_rubric('[rubric]\npass_score = 50\nagainst = "phong"\n', "r.toml")
    with pytest.raises(RubricError, match=r"line 2: against must be a string"):
        parse_rubric("[rubric]\nagainst = 3\n", "r.toml")
    with pytest.raises(RubricError, match=r"line 2: model 'classic\+Q14': no quirk Q14"):
        parse_rubric('[rubric]\nagainst = "classic+Q14"\n', "r.toml")
