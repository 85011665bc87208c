"""Metric values pinned against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from compare.judge.images import linear_to_srgb
from compare.judge.metrics import SizeMismatch, compute_maps, compute_metrics


def _wang_ssim_map(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SSIM straight from Wang et al. 2004 (Gaussian sigma 1.5, truncated at 3.5 sigma like
    scikit-image's 11-pixel window, K1 0.01, K2 0.03, L 1), averaged over channels."""
    c1, c2 = 0.01**2, 0.03**2
    out = []
    for ch in range(a.shape[-1]):
        x, y = a[..., ch].astype(np.float64), b[..., ch].astype(np.float64)
        f = lambda v: gaussian_filter(v, 1.5, truncate=3.5, mode="reflect")  # noqa: E731
        mx, my = f(x), f(y)
        sxx, syy, sxy = f(x * x) - mx * mx, f(y * y) - my * my, f(x * y) - mx * my
        out.append(
            ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
        )
    return np.mean(out, axis=0)


@pytest.fixture
def pair() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(20261122)
    ref = rng.uniform(0, 1.2, (40, 56, 3)).astype(np.float32)
    test = np.clip(ref + rng.normal(0, 0.05, ref.shape), 0, None).astype(np.float32)
    test[7, 11, 2] = ref[7, 11, 2] + 3.0  # the one largest error
    return ref, test


def test_ssim_equals_an_independent_wang_implementation(
    pair: tuple[np.ndarray, np.ndarray],
) -> None:
    ref, test = pair
    maps = compute_maps(ref, test, hdr=False)
    expected = _wang_ssim_map(linear_to_srgb(ref), linear_to_srgb(test))[5:-5, 5:-5].mean()
    m = compute_metrics(ref, test, maps)
    assert m.ssim == pytest.approx(expected, abs=1e-6)


def test_psnr_rmse_mae_relmse_by_hand(pair: tuple[np.ndarray, np.ndarray]) -> None:
    ref, test = pair
    m = compute_metrics(ref, test, compute_maps(ref, test, hdr=True))
    a, b = linear_to_srgb(ref).astype(np.float64), linear_to_srgb(test).astype(np.float64)
    mse = np.mean((a - b) ** 2)
    assert m.psnr_db == pytest.approx(10 * math.log10(1 / mse), rel=1e-6)  # float32 display values
    assert m.rmse_display == pytest.approx(math.sqrt(mse), rel=1e-6)
    d = ref.astype(np.float64) - test
    assert m.mae_linear == pytest.approx(np.mean(np.abs(d)), rel=1e-9)
    assert m.rel_mse_linear == pytest.approx(
        np.mean(d**2 / (ref.astype(np.float64) ** 2 + 0.01)), rel=1e-9
    )
    assert m.max_error_at == (11, 7, 2)
    assert m.max_error_linear == pytest.approx(3.0, abs=1e-5)
    assert m.over_threshold == int((np.abs(a - b).max(-1) > 1 / 255).sum())
    assert m.flip_hdr is not None and m.flip_hdr > 0


def test_flip_is_zero_for_identical_images_and_pinned_for_a_step() -> None:
    ref = np.full((32, 32, 3), 0.25, np.float32)
    maps = compute_maps(ref, ref, hdr=False)
    assert compute_metrics(ref, ref, maps).flip_ldr == 0.0
    test = ref.copy()
    test[:, 16:] = 0.5
    m = compute_metrics(ref, test, compute_maps(ref, test, hdr=False))
    # Pinned with flip-evaluator 1.7 (LDR, 67 ppd) on this synthetic pair; the number only
    # moves if FLIP or our sRGB encoding changes.
    assert m.flip_ldr == pytest.approx(0.27273, abs=1e-4)


def test_mask_restricts_every_metric(pair: tuple[np.ndarray, np.ndarray]) -> None:
    ref, test = pair
    maps = compute_maps(ref, test, hdr=False)
    mask = np.zeros(ref.shape[:2], bool)
    mask[20:30, 20:40] = True
    m = compute_metrics(ref, test, maps, mask=mask)
    assert m.pixels == 200
    assert m.max_error_at is not None and 20 <= m.max_error_at[1] < 30
    assert m.mae_linear == pytest.approx(
        np.abs(ref[mask].astype(np.float64) - test[mask]).mean(), rel=1e-9
    )


def test_nan_and_inf_are_counted_not_averaged() -> None:
    ref = np.full((16, 16, 3), 0.5, np.float32)
    test = ref.copy()
    test[3, 4, 0] = np.nan
    test[5, 6, 1] = np.inf
    m = compute_metrics(ref, test, compute_maps(ref, test, hdr=True))
    assert (m.nan_test, m.inf_test, m.nan_ref) == (1, 1, 0)
    assert math.isfinite(m.mae_linear) and m.mae_linear == 0.0


def test_sizes_must_match() -> None:
    with pytest.raises(SizeMismatch, match="never resampled"):
        compute_maps(np.zeros((4, 4, 3), np.float32), np.zeros((4, 5, 3), np.float32), hdr=False)


def test_images_smaller_than_the_ssim_window_give_nan_not_a_crash() -> None:
    ref = np.full((8, 8, 3), 0.5, np.float32)
    m = compute_metrics(ref, ref, compute_maps(ref, ref, hdr=False))
    assert math.isnan(m.ssim) and m.mae_display == 0.0
