"""Image metrics, each computed in a stated space.

display: clamp to [0, 1] (NaN -> 0), sRGB-encode — what a person sees.
linear:  the raw linear values (HDR); NaN/Inf pixels are counted and left out.

SSIM uses Wang et al. 2004's parameters (Gaussian window sigma 1.5, K1 0.01, K2 0.03,
population covariance) on display values; its mean leaves out a 5-pixel border, as
scikit-image does. FLIP is NVIDIA's flip-evaluator at 67 pixels per degree, run over the
crops around the differences (flip_crops.py).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from compare.judge.arrays import F32
from compare.judge.flip_crops import FLIP_PPD, cropped_hdr_flip, cropped_ldr_flip
from compare.judge.images import linear_to_srgb

BOOL = NDArray[np.bool_]
SSIM_WINDOW = 11  # scikit-image's Gaussian window for sigma 1.5
SSIM_BORDER = 5  # (win - 1) / 2, left out of the mean


class SizeMismatch(ValueError):
    """The two images differ in size; nothing is resampled.

    Parameters
    ----------
    message : str
        Both images' sizes, width x height.
    """


@dataclass
class Maps:
    """Per-pixel maps of a pair, kept for pictures and per-region means.

    The whole-image arrays are computed once per pair (compute_maps), so that the metrics of
    each region (the per-effect table asks for six) only index them. Display values are the
    linear ones clamped to [0, 1] (NaN -> 0) and sRGB-encoded.

    Attributes
    ----------
    ssim : F32
        H x W SSIM of the display values, the mean over channels; NaN when the image is
        smaller than the 11 x 11 window.
    flip_ldr : F32
        H x W LDR FLIP of the display values; NaN when computed with flip=False.
    flip_hdr : F32 or None
        H x W HDR FLIP of the linear values (NaN, infinities and negatives as 0); None
        unless asked for (hdr and flip), and on an all-black reference, where it is undefined.
    abs_display : F32
        H x W, the largest channel of |display(ref) - display(test)|.
    diff_display : F32
        H x W x 3, display(ref) - display(test).
    abs_linear : ndarray of float64
        H x W x 3, |ref - test| of the linear values.
    finite : BOOL
        H x W, both pixels finite in every channel.
    nan_ref, nan_test : BOOL
        H x W, a NaN in any channel of the reference, of the test.
    inf_ref, inf_test : BOOL
        H x W, an infinity in any channel of the reference, of the test.
    """

    ssim: F32
    flip_ldr: F32
    flip_hdr: F32 | None
    abs_display: F32
    diff_display: F32
    abs_linear: NDArray[np.float64]
    finite: BOOL
    nan_ref: BOOL
    nan_test: BOOL
    inf_ref: BOOL
    inf_test: BOOL


@dataclass
class Metrics:
    """Every metric of a test image against its reference over one region (compute_metrics).

    Display metrics compare the display values (clamped to [0, 1], NaN -> 0, sRGB-encoded);
    linear metrics the raw linear values over the pixels finite in both images. A metric
    with no pixel to measure is NaN (flip_hdr None); SPACES names each metric's space.

    Attributes
    ----------
    pixels : int
        Pixels in the region.
    ssim : float
        Mean SSIM (display), leaving out the image's 5-pixel border as scikit-image does
        (kept when nothing else of the region is left).
    flip_ldr : float
        Mean LDR FLIP (display); NaN when the maps were computed without FLIP.
    flip_hdr : float or None
        Mean HDR FLIP (linear); None when the maps have none (see Maps.flip_hdr).
    psnr_db : float
        PSNR in dB (display, data range 1); inf for identical display values.
    rmse_display, mae_display : float
        Root mean square and mean absolute error (display).
    rmse_linear, mae_linear : float
        Root mean square and mean absolute error (linear).
    rel_mse_linear : float
        Mean of (ref - test)^2 / (ref^2 + 0.01) (linear).
    max_error_linear : float
        The largest |ref - test| of any channel (linear).
    max_error_at : tuple[int, int, int] or None
        (x, y, channel) of that largest error; None without a finite pixel.
    over_threshold : int
        Pixels whose display error exceeds `threshold` in any channel.
    threshold : float
        The display error threshold of `over_threshold`.
    nan_ref, nan_test : int
        Pixels with a NaN in any channel, in the reference, in the test.
    inf_ref, inf_test : int
        Pixels with an infinity in any channel, in the reference, in the test.
    """

    pixels: int
    ssim: float
    flip_ldr: float
    flip_hdr: float | None
    psnr_db: float
    rmse_display: float
    mae_display: float
    rmse_linear: float
    mae_linear: float
    rel_mse_linear: float
    max_error_linear: float
    max_error_at: tuple[int, int, int] | None
    over_threshold: int
    threshold: float
    nan_ref: int
    nan_test: int
    inf_ref: int
    inf_test: int

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["spaces"] = SPACES
        d["flip_ppd"] = FLIP_PPD
        return d


SPACES = {
    "ssim": "display",
    "flip_ldr": "display",
    "flip_hdr": "linear",
    "psnr_db": "display",
    "rmse_display": "display",
    "mae_display": "display",
    "rmse_linear": "linear",
    "mae_linear": "linear",
    "rel_mse_linear": "linear",
    "max_error_linear": "linear",
    "over_threshold": "display",
}


def check_same_size(
    ref: F32, test: F32, ref_name: str = "reference", test_name: str = "test"
) -> None:
    if ref.shape != test.shape:
        raise SizeMismatch(
            f"size mismatch: {ref_name} is {ref.shape[1]}x{ref.shape[0]}, "
            f"{test_name} is {test.shape[1]}x{test.shape[0]} (never resampled)"
        )


def display(rgb: F32) -> F32:
    return linear_to_srgb(rgb)


def _any_channel(per_channel: BOOL) -> BOOL:
    return np.asarray(per_channel.any(axis=-1), bool)


# A crop of both images with this margin around a region has the whole image's FLIP values
# everywhere inside that region (flip_crops.FLIP_REACH is the filters' exact reach).
FLIP_MARGIN = 24


def flip_ldr_map(ref: F32, test: F32) -> F32:
    """LDR FLIP of the display values, H x W (flip_crops: evaluated around the differences)."""
    return cropped_ldr_flip(display(ref), display(test))


def compute_maps(ref: F32, test: F32, *, hdr: bool, flip: bool = True) -> Maps:
    """SSIM and FLIP maps plus the display error maps of `test` against `ref`, whole image.

    Parameters
    ----------
    ref, test : F32, linear RGB, H x W x 3, of one size (else SizeMismatch is raised)
    hdr : bool
        The inputs are HDR: HDR FLIP of the linear values is computed too.
    flip : bool, default True
        False leaves the FLIP maps NaN (FLIP is most of the cost; a first look can skip it).

    Returns
    -------
    Maps"""
    from skimage.metrics import structural_similarity

    check_same_size(ref, test)
    a, b = display(ref), display(test)
    if min(a.shape[:2]) < SSIM_WINDOW:
        ssim_map = np.full(a.shape[:2], np.nan, np.float32)  # too small for the 11x11 window
    else:
        _, full_map = structural_similarity(
            a,
            b,
            data_range=1.0,
            channel_axis=-1,
            gaussian_weights=True,
            sigma=1.5,
            use_sample_covariance=False,
            full=True,
        )
        ssim_map = np.asarray(full_map, np.float32).mean(axis=-1)
    flip_hdr = None
    flip_ldr = cropped_ldr_flip(a, b) if flip else np.full(a.shape[:2], np.nan, np.float32)

    def clean(x: F32) -> F32:
        return np.maximum(np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0), 0.0)

    # HDR FLIP derives its exposures from the reference's luminance: on an all-black one
    # it is undefined (None), as flip-evaluator (which exits there) leaves it.
    if flip and hdr:
        ref_hdr = clean(ref).astype(np.float32)
        if float(ref_hdr.max()) > 0.0:
            flip_hdr = cropped_hdr_flip(ref_hdr, clean(test).astype(np.float32))
    diff_display = a - b
    nan_ref, nan_test = _any_channel(np.isnan(ref)), _any_channel(np.isnan(test))
    inf_ref, inf_test = _any_channel(np.isinf(ref)), _any_channel(np.isinf(test))
    return Maps(
        ssim=ssim_map,
        flip_ldr=np.asarray(flip_ldr, np.float32),
        flip_hdr=None if flip_hdr is None else np.asarray(flip_hdr, np.float32),
        abs_display=np.abs(diff_display).max(axis=-1),
        diff_display=diff_display,
        abs_linear=np.abs(ref.astype(np.float64) - test),
        finite=~(nan_ref | nan_test | inf_ref | inf_test),
        nan_ref=nan_ref,
        nan_test=nan_test,
        inf_ref=inf_ref,
        inf_test=inf_test,
    )


def _interior(shape: tuple[int, int]) -> BOOL:
    m = np.zeros(shape, bool)
    h, w = shape
    if h > 2 * SSIM_BORDER and w > 2 * SSIM_BORDER:
        m[SSIM_BORDER : h - SSIM_BORDER, SSIM_BORDER : w - SSIM_BORDER] = True
    else:
        m[:] = True
    return m


def compute_metrics(
    ref: F32, test: F32, maps: Maps, *, mask: BOOL | None = None, threshold: float = 1.0 / 255.0
) -> Metrics:
    """Every metric of `test` against `ref` over `mask`, read from the pair's `maps`.

    Parameters
    ----------
    ref, test : F32
        Linear RGB, float32 H x W x 3, of one size (else SizeMismatch is raised).
    maps : Maps, compute_maps(ref, test, ...)
    mask : BOOL or None, default None
        H x W pixels to measure; None: every pixel.
    threshold : float, default 1/255
        Display error above which a pixel counts in ``over_threshold``.

    Returns
    -------
    Metrics"""
    check_same_size(ref, test)
    h, w = ref.shape[:2]
    region = np.ones((h, w), bool) if mask is None else mask
    n = int(region.sum())
    lin = region & maps.finite
    diff_d = maps.diff_display[region]
    mse_d = float(np.mean(diff_d**2)) if n else float("nan")
    ra, tb = ref[lin].astype(np.float64), test[lin].astype(np.float64)
    dl = ra - tb
    ssim_region = region & _interior((h, w))
    if not ssim_region.any():
        ssim_region = region
    max_at = None
    max_err = float("nan")
    if lin.any():
        full = np.where(lin[..., None], maps.abs_linear, -1.0)
        y, x, c = np.unravel_index(int(np.argmax(full)), full.shape)
        max_at, max_err = (int(x), int(y), int(c)), float(full[y, x, c])
    return Metrics(
        pixels=n,
        ssim=float(maps.ssim[ssim_region].mean()) if n else float("nan"),
        flip_ldr=float(maps.flip_ldr[region].mean()) if n else float("nan"),
        flip_hdr=None
        if maps.flip_hdr is None
        else float(maps.flip_hdr[region].mean())
        if n
        else None,
        psnr_db=float("inf") if mse_d == 0 else float(10 * np.log10(1.0 / mse_d)),
        rmse_display=float(np.sqrt(mse_d)),
        mae_display=float(np.mean(np.abs(diff_d))) if n else float("nan"),
        rmse_linear=float(np.sqrt(np.mean(dl**2))) if dl.size else float("nan"),
        mae_linear=float(np.mean(np.abs(dl))) if dl.size else float("nan"),
        rel_mse_linear=float(np.mean(dl**2 / (ra**2 + 0.01))) if dl.size else float("nan"),
        max_error_linear=max_err,
        max_error_at=max_at,
        over_threshold=int((maps.abs_display[region] > threshold).sum()),
        threshold=threshold,
        nan_ref=int(maps.nan_ref[region].sum()),
        nan_test=int(maps.nan_test[region].sum()),
        inf_ref=int(maps.inf_ref[region].sum()),
        inf_test=int(maps.inf_test[region].sum()),
    )


def metrics_from_dict(d: dict[str, Any]) -> Metrics:
    """The inverse of Metrics.as_dict (after a JSON round trip: null -> NaN where a float)."""
    fields = {k: v for k, v in d.items() if k in Metrics.__dataclass_fields__}
    for k in (
        "ssim",
        "flip_ldr",
        "psnr_db",
        "rmse_display",
        "mae_display",
        "rmse_linear",
        "mae_linear",
        "rel_mse_linear",
        "max_error_linear",
    ):
        if fields.get(k) is None:
            fields[k] = float("nan")
    if d.get("psnr_db") is None and d.get("rmse_display") == 0:
        fields["psnr_db"] = float("inf")  # identical display values; JSON has no Infinity
    if fields.get("max_error_at") is not None:
        fields["max_error_at"] = tuple(fields["max_error_at"])
    return Metrics(**fields)
