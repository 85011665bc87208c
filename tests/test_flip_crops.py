"""The metrics' shortcuts leave every number the report prints where it was: FLIP over the
crops around the differences (compare/judge/flip_crops.py) against flip-evaluator over the
whole image, and two fixed pairs against the values the whole-image implementation gave."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import flip_evaluator
import numpy as np
import pytest

from compare.diagnose import flip as diagnose_flip
from compare.judge import flip_crops, metrics
from compare.judge.evaluate import Evaluation
from compare.judge.exact_match import exact_match
from compare.judge.images import linear_to_srgb
from compare.judge.metrics import compute_maps, compute_metrics
from compare.judge.tolerances import Tolerances

PPD = {"ppd": 67.0}
F32 = np.float32


def _discs(
    h: int, w: int, discs: list[tuple[int, int, int, tuple[float, float, float]]], sky: float
) -> tuple[np.ndarray, np.ndarray]:
    """Shaded discs (centre y, x, radius, colour) over a constant background; their ids."""
    yy, xx = np.mgrid[0:h, 0:w]
    img = np.full((h, w, 3), sky, np.float32)
    ids = np.full((h, w), -1, np.int32)
    for i, (cy, cx, r, colour) in enumerate(discs):
        inside = (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
        shade = (1.0 - 0.5 * ((xx - cx) / r) ** 2)[..., None]
        img[inside] = (np.asarray(colour, np.float32) * shade)[inside]
        ids[inside] = i
    return img, ids


def sky_pair() -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """A white sky (maximum = median luminance: HDR-FLIP's start = stop) with three discs;
    the test has noise on two and the third one pixel to the right."""
    discs = [(60, 80, 30, (0.9, 0.2, 0.1)), (150, 220, 45, (0.1, 0.3, 0.9))]
    ref, ids = _discs(240, 320, [*discs, (170, 70, 20, (0.2, 0.8, 0.2))], 1.0)
    test, _ = _discs(240, 320, [*discs, (170, 71, 20, (0.2, 0.8, 0.2))], 1.0)
    noisy = (ids >= 0) & (ids != 2)
    noise = np.random.default_rng(20261202).standard_normal((int(noisy.sum()), 3))
    test[noisy] *= (1 + 0.08 * noise).astype(np.float32)
    return ref, test, {"background": ids < 0, "discs": ids >= 0, "moved": ids == 2}


def hdr_pair() -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Bright discs (up to 6) on black (median 0: some 25 exposures); noise on the discs, a
    NaN and an Inf in the test."""
    discs = [(50, 60, 25, (6.0, 5.0, 4.0)), (120, 150, 35, (0.5, 0.4, 0.3))]
    ref, ids = _discs(160, 220, [*discs, (40, 170, 15, (2.0, 0.2, 0.2))], 0.0)
    test = ref.copy()
    lit = ids >= 0
    noise = np.random.default_rng(7).standard_normal((int(lit.sum()), 3))
    test[lit] *= (1 + 0.05 * noise).astype(np.float32)
    test[100, 100] = np.nan
    test[10, 10, 1] = np.inf
    return ref, test, {"background": ids < 0, "discs": ids >= 0}


# The values of the implementation before flip_crops (flip-evaluator over the whole image,
# LDR and HDR with its own exposures), at commit 2d6143f, from compute_maps(hdr=True) and
# compute_metrics(threshold=1/255) on the pairs above. LDR FLIP and every other metric must
# come out the same; HDR FLIP within 1e-6 (the report prints 4 decimals): its one exposure
# where the whole-image run had two, 1 ulp apart, differs by FLIP's float noise.
PINNED: dict[str, dict[str, dict[str, Any]]] = {
    "sky": {
        "global": {"ssim": 0.9608553051948547, "flip_ldr": 0.01174224354326725,
                   "flip_hdr": 0.010001694783568382, "psnr_db": 34.740441469926424,
                   "rmse_display": 0.018322212953352523, "mae_linear": 0.0037386606421043527,
                   "rel_mse_linear": 0.010663594391507228,
                   "max_error_linear": 0.8999999985098839, "max_error_at": (50, 170, 0),
                   "over_threshold": 10121},
        "background": {"ssim": 0.9955850839614868, "flip_ldr": 0.002339773578569293,
                       "flip_hdr": 0.002053615404292941, "psnr_db": 37.998645680304,
                       "rmse_display": 0.012591217210360892,
                       "mae_linear": 0.0004466177387038223,
                       "rel_mse_linear": 0.0003463383256080623,
                       "max_error_linear": 0.8999999985098839, "max_error_at": (91, 170, 0),
                       "over_threshold": 41},
        "discs": {"ssim": 0.7583758234977722, "flip_ldr": 0.07151399552822113,
                  "flip_hdr": 0.06052783876657486, "psnr_db": 28.350691015243935,
                  "rmse_display": 0.03823538338797222, "mae_linear": 0.0246662647337379,
                  "rel_mse_linear": 0.07625066497193969,
                  "max_error_linear": 0.8999999985098839, "max_error_at": (50, 170, 0),
                  "over_threshold": 10080},
        "moved": {"ssim": 0.8410166501998901, "flip_ldr": 0.17130959033966064,
                  "flip_hdr": 0.1038769781589508, "psnr_db": 20.736404450185137,
                  "rmse_display": 0.091871282168181, "mae_linear": 0.03159427188793249,
                  "rel_mse_linear": 0.5983285420141927,
                  "max_error_linear": 0.8999999985098839, "max_error_at": (50, 170, 0),
                  "over_threshold": 945},
    },
    "hdr": {
        "global": {"ssim": 0.9827338457107544, "flip_ldr": 0.006464969366788864,
                   "flip_hdr": 0.007921842858195305, "psnr_db": 44.844022710729476,
                   "rmse_display": 0.0057253081241344745, "mae_linear": 0.011686644952109287,
                   "rel_mse_linear": 0.0004239941190254699,
                   "max_error_linear": 0.8924016952514648, "max_error_at": (62, 59, 0),
                   "over_threshold": 4454},
        "background": {"ssim": 0.9991442561149597, "flip_ldr": 0.001441255328245461,
                       "flip_hdr": 0.001394395949319005, "psnr_db": 49.34655006214022,
                       "rmse_display": 0.0034093571374938783, "mae_linear": 0.0,
                       "rel_mse_linear": 0.0, "max_error_linear": 0.0,
                       "max_error_at": (0, 0, 0), "over_threshold": 1},
        "discs": {"ssim": 0.9198852181434631, "flip_ldr": 0.02855067513883114,
                  "flip_hdr": 0.036618396639823914, "psnr_db": 39.00372571860042,
                  "rmse_display": 0.011215372798022991, "mae_linear": 0.06306094266815004,
                  "rel_mse_linear": 0.0022878652462760217,
                  "max_error_linear": 0.8924016952514648, "max_error_at": (62, 59, 0),
                  "over_threshold": 4453},
    },
}  # fmt: skip
PAIRS = {"sky": sky_pair, "hdr": hdr_pair}


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_every_metric_stays_at_the_whole_image_implementations_value(name: str) -> None:
    ref, test, masks = PAIRS[name]()
    maps = compute_maps(ref, test, hdr=True)
    for region, pinned in PINNED[name].items():
        got = compute_metrics(ref, test, maps, mask=masks.get(region), threshold=1 / 255)
        for field, value in pinned.items():
            # Pinned on an AVX-512 machine. numpy's float32 loops (pow, exp, sums) take other
            # code paths on AVX2 and differ there by up to ~2e-6 relative; a crop or exposure
            # shortcut that changed a value would move it far more (and the bit-for-bit tests below compare crops with whole images).
            tol = {"abs": 1e-6} if field == "flip_hdr" else {"rel": 1e-5}
            assert getattr(got, field) == pytest.approx(value, **tol), (region, field)


def _patched(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Noise, and the same noise with a few rectangles replaced (one at the image's edge)."""
    a = rng.random((150, 170, 3)).astype(np.float32)
    b = a.copy()
    b[0:6, 160:170] = 0.5
    for _ in range(5):
        y, x, dy, dx = rng.integers(0, 150), rng.integers(0, 170), *rng.integers(1, 20, 2)
        b[y : y + dy, x : x + dx] = rng.random(3)
    return a, b


def _cropped_with_reach(a: np.ndarray, b: np.ndarray, reach: int, monkeypatch: Any) -> np.ndarray:
    monkeypatch.setattr(flip_crops, "FLIP_REACH", reach)
    return flip_crops.cropped_ldr_flip(a, b)


def test_ldr_flip_over_crops_is_the_whole_images_bit_for_bit(monkeypatch: Any) -> None:
    """Noise is where FLIP's filters see the most: with the reach of 10 px every pixel equals
    the whole-image evaluation's; at 9 px some do not (the reach is the filters' own)."""
    rng = np.random.default_rng(11)
    short = 0
    for _ in range(3):
        a, b = _patched(rng)
        whole = flip_evaluator.evaluate(a, b, "LDR", applyMagma=False, parameters=PPD)[0]
        assert np.array_equal(_cropped_with_reach(a, b, 10, monkeypatch), whole[..., 0])
        short += int((_cropped_with_reach(a, b, 9, monkeypatch) != whole[..., 0]).sum())
    assert short > 0


def test_a_map_updated_from_a_known_one_is_the_whole_images_bit_for_bit() -> None:
    """The diagnosis's second FLIP map starts from the first (diagnose_flip.py): the image
    against another render that differs from the first in a few rectangles."""
    rng = np.random.default_rng(5)
    image, first = _patched(rng)
    second = first.copy()
    second[40:52, 0:9] = 0.25
    second[140:150, 100:130] = rng.random(3)
    known = flip_crops.cropped_ldr_flip(first, image)
    whole = flip_evaluator.evaluate(second, image, "LDR", applyMagma=False, parameters=PPD)[0]
    assert np.array_equal(flip_crops.updated_ldr_flip(second, image, first, known), whole[..., 0])


def test_identical_images_need_no_flip_call() -> None:
    a = np.random.default_rng(2).random((40, 50, 3)).astype(np.float32)
    assert flip_crops.crops(np.zeros(a.shape[:2], bool)) == []
    assert not flip_crops.cropped_ldr_flip(a, a.copy()).any()


@pytest.mark.parametrize("name", ["sky", "hdr", "noise"])
def test_exposures_are_flip_evaluators_own(name: str) -> None:
    """Start, stop and count as flip-evaluator reports them for the same reference (float32,
    bit for bit); a start = stop range is evaluated once."""
    if name == "noise":
        ref = (np.random.default_rng(4).random((50, 64, 3)) ** 3 * 5).astype(np.float32)
    else:
        ref = np.nan_to_num(PAIRS[name]()[0])
    _, _, params = flip_evaluator.evaluate(ref, ref, "HDR", applyMagma=False, parameters=PPD)
    exposures = flip_crops.hdr_exposures(ref)
    assert exposures[0] == params["startExposure"]
    if params["stopExposure"] - params["startExposure"] < flip_crops.SAME_EXPOSURE:
        assert len(exposures) == 1
    else:
        assert len(exposures) == params["numExposures"]
        assert exposures[-1] == pytest.approx(params["stopExposure"], abs=1e-5)


def test_hdr_flip_over_crops_matches_flip_evaluators_hdr_mode() -> None:
    """A pair whose reference spans 7 stops: every pixel within FLIP's float noise."""
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:160, 0:200]
    glow = np.exp(-((xx - 100) ** 2 + (yy - 80) ** 2) / 400.0)[..., None]
    ref = (0.05 + 6 * glow) * np.array([1, 0.8, 0.6]) + 0.02 * rng.random((160, 200, 3))
    ref = ref.astype(np.float32)
    test = ref.copy()
    test[60:100, 80:130] *= (1 + 0.1 * rng.standard_normal((40, 50, 3))).astype(np.float32)
    test = np.maximum(test, 0)
    whole, _, params = flip_evaluator.evaluate(ref, test, "HDR", applyMagma=False, parameters=PPD)
    assert params["numExposures"] == 7
    got = flip_crops.cropped_hdr_flip(ref, test)
    assert np.abs(got - whole[..., 0]).max() < 1e-4
    assert float(got.mean()) == pytest.approx(float(whole.mean()), abs=1e-7)


def test_display_flip_of_the_metrics_is_the_cropped_one() -> None:
    ref, test, _ = sky_pair()
    maps = compute_maps(ref, test, hdr=False)
    a, b = linear_to_srgb(ref), linear_to_srgb(test)
    whole = flip_evaluator.evaluate(a, b, "LDR", applyMagma=False, parameters=PPD)[0][..., 0]
    assert np.array_equal(maps.flip_ldr, whole)
    assert maps.flip_hdr is None
    assert F32(maps.flip_ldr[0, 0]) == 0.0  # the sky's corner: equal all around


@pytest.mark.parametrize(("shape", "reach", "density"), [((50, 70), 10, 0.01), ((13, 9), 3, 0.1),
                                                         ((1, 1), 10, 1.0), ((5, 5), 0, 0.3)])  # fmt: skip
def test_the_crops_dilation_is_a_square_maximum_filter(
    shape: tuple[int, int], reach: int, density: float
) -> None:
    from scipy.ndimage import maximum_filter

    mask = np.random.default_rng(reach).random(shape) < density
    want = maximum_filter(mask, size=2 * reach + 1, mode="constant").astype(bool)
    np.testing.assert_array_equal(flip_crops._dilate(mask, reach), want)


def test_the_verdicts_flip_seeds_the_diagnosis_map_bit_for_bit(monkeypatch: Any) -> None:
    """Grading hands the verdict's FLIP (over the failing effects' crop) to the diagnosis
    (diagnose_flip.Flips.seed): the start's map made from it is the whole image's, and fewer
    pixels are evaluated. The image is an 8-bit copy of the render (it differs everywhere by
    less than a level: exact) with the right side redrawn (that effect fails)."""
    yy, xx = np.mgrid[0:120, 0:200]
    ref = np.stack([xx / 200, yy / 120, (xx + yy) / 320], axis=-1).astype(np.float32)
    test = np.floor(ref * 255) / np.float32(255)
    test[30:90, 130:190] = (0.9, 0.1, 0.3)
    masks = {"left": xx < 100, "right": xx >= 100}
    exact = exact_match([ref], test, "linear", model="m", masks=masks)
    assert exact.per_effect["left"].passed and not exact.per_effect["right"].passed
    ev = Evaluation(ref, test, Tolerances(), masks=masks, exact=exact)
    ev.effect_flip("right")
    known = ev.known_flip()
    assert known is not None and 0.3 < known[1].mean() < 0.6
    evaluated: list[int] = []
    real = flip_crops._ldr_flip

    def counted(a: np.ndarray, b: np.ndarray, srgb: bool) -> np.ndarray:
        evaluated.append(a.shape[0] * a.shape[1])
        return real(a, b, srgb)

    monkeypatch.setattr(flip_crops, "_ldr_flip", counted)
    flips = diagnose_flip.Flips(None, ThreadPoolExecutor(max_workers=1))
    flips.seed(ref, test, *known)
    seeded = flips._map(metrics.display(ref), metrics.display(test))
    seeded_pixels = sum(evaluated)
    evaluated.clear()
    assert np.array_equal(seeded, metrics.flip_ldr_map(ref, test))
    assert seeded_pixels < 0.8 * sum(evaluated)
