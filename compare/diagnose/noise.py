"""Random noise on every pixel: an image whose every value is off from the start's render by
a small amount that neither leans one way nor follows its neighbours (grain a program adds,
dithering, a jittered sampler). No step of the algorithm does that, so no candidate can
explain it, and a search would try every switch for nothing.

It is fitted on the differences in 8-bit levels between the image and the start's render:
their spread (sigma, of the pixels without a larger error), their mean and how much each
differs like its right-hand neighbour. Noise is named when most pixels are off by two levels
or more, the mean is near zero and neighbours are unrelated. The image is then judged with the
noise taken out (each value within NOISE_BAND sigmas of the render's is set to what a writer
of the render stores): an error beyond the noise is localised (no candidate's codes could
match noisy pixels exactly, so none is searched for).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from compare.diagnose.score import encoded
from compare.diagnose.transforms import Transform, noise_transform
from compare.judge.arrays import F32
from compare.judge.images import linear_to_srgb, srgb_to_linear

# The fit is of the pixels within CAP_SIGMAS of a coarse spread (the median absolute
# difference's), which must be most of the image; most of them must be off by two levels or
# more (one level is a writer's rounding).
CAP_SIGMAS = 8.0
SMALL_MIN_SHARE = 0.6
NOISE_MIN_SHARE = 0.5
# The spread, in 8-bit levels, of the pixels within the fit: below it is rounding, above it
# the image is something else.
SIGMA_RANGE = (0.75, 24.0)
# The mean difference may be at most this share of sigma, and half a level a truncating
# writer takes off (noise does not lean one way).
MEAN_MAX = 0.25
# The correlation of each difference with its right-hand neighbour's: a wrong step of the
# algorithm changes regions alike, noise does not.
NEIGHBOUR_MAX = 0.3
# Values within this many sigmas of the render's are taken for noise (sigma is of the values
# within the cap, a little under the whole's: 6 of it keep a Gaussian's every value at 640x480).
NOISE_BAND = 6.0


def fitted(image: F32, render: F32, codes: str) -> Transform | None:
    """The noise on `image` against `render` (both linear, one shape), or None."""
    a, b = encoded(image, codes), encoded(render, codes)
    d = a.astype(np.float64) - b
    # The pixels within CAP_SIGMAS of a first, coarse spread: a wrong step's larger errors
    # in some regions are left out of the fit, and localised after it.
    finite = np.isfinite(image).all(axis=-1) & np.isfinite(render).all(axis=-1)
    rough = max(1.0, 1.4826 * float(np.median(np.abs(d[finite]))))
    small = np.asarray(finite & (np.abs(d) <= CAP_SIGMAS * rough).all(axis=-1))
    ds = d[small]
    if small.mean() < SMALL_MIN_SHARE or (np.abs(ds) >= 2).any(axis=-1).mean() < NOISE_MIN_SHARE:
        return None
    sigma, mean = float(ds.std()), float(ds.mean())
    if not SIGMA_RANGE[0] <= sigma <= SIGMA_RANGE[1] or abs(mean) > MEAN_MAX * sigma + 0.5:
        return None
    if _neighbour_correlation(d, small) > NEIGHBOUR_MAX:
        return None
    return noise_transform(sigma, _undo(a, b, _stored(render, codes), NOISE_BAND * sigma))


def _neighbour_correlation(d: np.ndarray, small: np.ndarray) -> float:
    """The correlation of each difference with its right-hand neighbour's, over the pairs
    of pixels both within the fit."""
    both = (small[:, :-1] & small[:, 1:])[..., None] & np.ones(d.shape[-1], bool)
    x, y = d[:, :-1][both], d[:, 1:][both]
    if x.size < 2 or x.std() == 0 or y.std() == 0:
        return 1.0
    return float(np.corrcoef(x, y)[0, 1])


def _stored(render: F32, codes: str) -> F32:
    """The values a truncating 8-bit writer of the render stores, read back as linear."""
    if codes == "linear":
        return np.asarray(np.floor(255 * np.clip(np.nan_to_num(render), 0, 1)) / 255, np.float32)
    levels = np.floor(255 * linear_to_srgb(np.nan_to_num(render)))
    return srgb_to_linear(np.asarray(levels / 255, np.float32))


def _undo(a: np.ndarray, b: np.ndarray, stored: F32, band: float) -> Callable[[F32], F32]:
    """The image with each value within `band` levels of the render's replaced by what a
    writer of the render stores (a function of the image: the search calls it on the image
    it judges)."""
    near = np.abs(a.astype(np.float64) - b) <= band

    def undo(image: F32) -> F32:
        out: F32 = np.where(near, stored, image).astype(image.dtype)
        return out

    return undo
