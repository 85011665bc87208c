"""The camera fitted from geometry: where the image's silhouettes lie against the start's
render tells how the program turned pixels into rays.

Every camera slip of a pixel loop (a field of view of its own, the field of view taken as the
horizontal one, a missing aspect ratio, a row divided by the width, pixel corners for
centres) maps each image column to a column of the scene's camera by an affine function,
and each row likewise (rtdemo --camera-map). So the image is an affine resampling of the
start's render, axis by axis, wherever their colours agree. Each axis is registered on its
edges: the profile of edge strength along the axis (silhouettes dominate it), matched against
the render's over scales by FFT cross-correlation, then refined. The fitted map is read as
the nearest of the slips students make (_stories), with its own field of view snapped to a
whole degree; only that story's exact camera is rendered, and the gates decide whether it is
named. A map no story fits is not rendered: it is no camera a program has.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from compare.judge.arrays import F32
from compare.judge.images import linear_to_srgb

CameraMap = tuple[float, float, float, float]  # su, ou, sv, ov (camera_rays.h)

# Scales tried per axis (image pixel -> render pixel), log-spaced, then refined around the
# best: a field of view from about a third to three times the scene's.
SCALES = np.geomspace(0.35, 3.0, 240)
# The registration must explain the edges this well (normalised correlation)...
MIN_CORRELATION = 0.8
# ...and the map must move some border pixel by at least this much (else it is the scene's).
MIN_MOVE_PX = 0.75
# A story is the fit's when its map is this near (relative to the scales): the registration
# places edges to about a pixel, so STORY_PIXELS of the image's smaller side, plus
# STORY_FLOOR; a whole degree of field of view moves the scales by 3 %.
STORY_PIXELS = 2.5
STORY_FLOOR = 0.005
# A profile is flat where its variance is below this share of its mean square.
FLAT = 1e-9


@dataclass(frozen=True)
class Fitted:
    """A camera the image shows: its map and the slip it is, in words."""

    camera: CameraMap
    words: str

    @property
    def key(self) -> str:
        return ",".join(f"{v:.9g}" for v in self.camera) + "|" + self.words


def fitted(image: F32, renders: list[F32], fov_y: float) -> list[Fitted]:
    """The camera of `image` against the starts' `renders` (linear, one shape) of a scene
    whose vertical field of view is `fov_y` degrees, registered on the render whose edges
    it matches best (a mode's colours move some edges): the nearest story, and the same
    with pixel corners for centres or without (half a pixel, which only a render tells
    apart); [] where the image's silhouettes lie where the render's do, or where no affine
    camera explains them."""
    h, w = image.shape[:2]
    ei = edges(image)
    fits: list[tuple[float, tuple[float, float], tuple[float, float]]] = []
    for render in renders:
        er = edges(render)
        rx = _register(ei.sum(axis=0), er.sum(axis=0))
        ry = _register(ei.sum(axis=1), er.sum(axis=1))
        if rx is not None and ry is not None:
            fits.append((min(rx[2], ry[2]), (rx[0], rx[1]), (ry[0], ry[1])))
    if not fits:
        return []
    _, x, y = max(fits)
    moves = [abs((a - 1) * n + b) for (a, b), n in ((x, w), (y, h))] + [abs(x[1]), abs(y[1])]
    if max(moves) < MIN_MOVE_PX:
        return []
    t = math.tan(math.radians(fov_y) / 2)
    return _story(_as_map(x, y, w, h, t), w, h, fov_y)


def edges(rgb: F32) -> np.ndarray:
    """Edge strength: the display luminance's gradient magnitude (one pixel shorter on the
    far sides, padded back)."""
    lum = linear_to_srgb(np.clip(np.nan_to_num(rgb), 0, 1).astype(np.float32)).mean(axis=-1)
    gx = np.abs(np.diff(lum, axis=1, append=lum[:, -1:]))
    gy = np.abs(np.diff(lum, axis=0, append=lum[-1:, :]))
    return np.asarray(gx + gy, np.float64)


def _register(p_img: np.ndarray, p_ren: np.ndarray) -> tuple[float, float, float] | None:
    """(a, b, correlation) with render index j = a i + b for image index i, best matching
    the edge profiles, or None when none matches well. Every scale with its FFT's best
    shifts, then the scale refined twice within 3 pixels of the shift, then the shift to a
    twentieth of a pixel: each stage one batch of correlations."""
    shifts = _fft_shifts(p_img, p_ren, SCALES)
    corr, a, b = _best_of(p_img, p_ren, np.repeat(SCALES, shifts.shape[1]), shifts.ravel())
    near = np.arange(-3.0, 4.0)
    for step in (0.004, 0.001):
        scales = a + step * near
        corr, a, b = _best_of(
            p_img, p_ren, np.repeat(scales, near.size), np.tile(b + near, near.size)
        )
    fine = b + np.linspace(-1, 1, 41)
    corr, a, b = _best_of(p_img, p_ren, np.full(fine.size, a), fine)
    return (a, b, corr) if corr >= MIN_CORRELATION and p_img.size >= 16 else None


def _best_of(
    p_img: np.ndarray, p_ren: np.ndarray, scales: np.ndarray, shifts: np.ndarray
) -> tuple[float, float, float]:
    """(correlation, a, b) of the best pair (scales[k], shifts[k])."""
    corr = _correlations(p_img, p_ren, scales, shifts)
    k = int(np.argmax(corr))
    return float(corr[k]), float(scales[k]), float(shifts[k])


def _fft_shifts(p_img: np.ndarray, p_ren: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """Per scale a (rows), the shifts b (render index a i + b) of the FFT cross-correlation's
    five highest raw scores between the image's profile and the render's resampled at a."""
    n = p_img.size
    m = np.ceil(n / scales).astype(int) + 1  # the render on the image's grid: k is a k
    k = np.arange(m.max(), dtype=np.float64)
    valid = k[None, :] < m[:, None]
    ren = np.interp(scales[:, None] * k[None, :], np.arange(n), p_ren, left=0.0, right=0.0)
    ren = np.where(valid, ren - (ren * valid).sum(axis=1, keepdims=True) / m[:, None], 0.0)
    size = 1 << int(np.ceil(np.log2(n + m.max())))
    spectrum = np.fft.rfft(p_img - p_img.mean(), size)[None, :] * np.conj(
        np.fft.rfft(ren, size, axis=1)
    )
    raw = np.fft.irfft(spectrum, size, axis=1)
    # raw[lag]: image index i against resampled index i - lag, i.e. render index a (i - lag)
    lags = np.arange(-k.size + 1, n)
    scores = np.where(lags[None, :] > -m[:, None], raw[:, lags % size], -np.inf)
    top = lags[np.argpartition(scores, -5, axis=1)[:, -5:]]
    return -scales[:, None] * top


def _correlations(
    p_img: np.ndarray, p_ren: np.ndarray, scales: np.ndarray, shifts: np.ndarray
) -> np.ndarray:
    """Per pair k, the normalised correlation of the image's profile with the render's at
    j = scales[k] i + shifts[k], over the image indices whose j lies inside the render (-1
    where under a quarter of them do, or where either side is flat there)."""
    n = p_img.size
    j = scales[:, None] * np.arange(n, dtype=np.float64)[None, :] + shifts[:, None]
    inside = ((j >= 0) & (j <= n - 1)).astype(np.float64)
    y = np.interp(j, np.arange(n), p_ren) * inside
    count = inside.sum(axis=1)
    sx, sxx = inside @ p_img, inside @ (p_img * p_img)
    sy, syy, sxy = y.sum(axis=1), (y * y).sum(axis=1), y @ p_img
    with np.errstate(invalid="ignore", divide="ignore"):
        vx, vy = sxx - sx * sx / count, syy - sy * sy / count
        corr = (sxy - sx * sy / count) / np.sqrt(vx * vy)
        # a flat side: its variance is rounding against its mean square
        flat = (vx <= FLAT * sxx) | (vy <= FLAT * syy)
    return np.asarray(np.where((count < n // 4) | flat | ~np.isfinite(corr), -1.0, corr))


def _as_map(x: tuple[float, float], y: tuple[float, float], w: int, h: int, t: float) -> CameraMap:
    """The registration (index j = a i + b per axis, pixel centres at i + 0.5) as the camera
    map it implies for a scene camera of tan(fov / 2) = t."""
    (ax, bx), (ay, by) = x, y
    # continuous coordinates: q = a p + b' with b' = b + 0.5 - 0.5 a
    bx_c, by_c = bx + 0.5 - 0.5 * ax, by + 0.5 - 0.5 * ay
    s0u, s0v = t * w / h, t
    return (s0u * ax, s0u * (ax - 1 + 2 * bx_c / w), s0v * ay, s0v * (1 - ay - 2 * by_c / h))


def _stories(
    w: int, h: int, fov_y: float
) -> list[tuple[str, Callable[[float], CameraMap], Callable[[CameraMap], float]]]:
    """The slips students make: (words with {f} for the field of view, the map for a field
    of view f, the f a fitted map implies)."""
    aspect = w / h

    def tan(f: float) -> float:
        return math.tan(math.radians(f) / 2)

    def fov(tn: float) -> float:
        return math.degrees(2 * math.atan(max(tn, 1e-9)))

    return [
        (f"a field of view of {{f}} degrees (the scene's is {fov_y:g})",
         lambda f: (tan(f) * aspect, 0.0, tan(f), 0.0), lambda m: fov(m[2])),
        ("the field of view ({f} degrees) taken as the horizontal one",
         lambda f: (tan(f), 0.0, tan(f) / aspect, 0.0), lambda m: fov(m[0])),
        ("no aspect ratio: the field of view ({f} degrees) on both axes",
         lambda f: (tan(f), 0.0, tan(f), 0.0), lambda m: fov((m[0] + m[2]) / 2)),
        ("the row divided by the width, not the height",
         lambda f: (tan(f) * aspect, 0.0, tan(f) / aspect, tan(f) * (1 - 1 / aspect)),
         lambda m: fov(m[0] / aspect)),
        ("the column divided by the height, not the width",
         lambda f: (tan(f) * aspect * aspect, tan(f) * aspect * (aspect - 1), tan(f), 0.0),
         lambda m: fov(m[2])),
    ]  # fmt: skip


def _story(m: CameraMap, w: int, h: int, fov_y: float) -> list[Fitted]:
    """The story that fits the map (within the tolerance) with the fewest changes from the
    scene's camera (the slip itself, and a field of view of its own), then one that reads
    the scene's field of view, then the nearer; its field of view snapped to a whole degree;
    with and without pixel corners. [] where no story fits: edges move for other reasons too (shadow acne's speckle, a
    mode's colours), and a map fitted to them is no camera. Stories overlap (a 40-degree
    camera is nearly a 52-degree one taken as horizontal): one change is likelier than two."""
    tolerance = STORY_PIXELS / min(w, h) + STORY_FLOOR
    fits: list[tuple[int, bool, float, str, CameraMap]] = []
    for n, (words, make, fov_of) in enumerate(_stories(w, h, fov_y)):
        f = fov_of(m)
        for fov in {round(f), fov_y}:
            story, text = make(fov), words.format(f=f"{fov:g}")
            d = min(_distance(story, m), _distance(_cornered(story, w, h), m))
            changes = (fov != fov_y) + (n > 0)
            if d <= tolerance and changes:  # the scene's field of view, read right, first
                fits.append((changes, fov != fov_y, d, text, story))
    if not fits:  # edges that moved for another reason (acne, a wrong mode): no camera
        return []
    *_, text, story = min(fits)
    corners = ", and pixel corners (x, y) for centres (x + 0.5, y + 0.5)"
    return [Fitted(story, text), Fitted(_cornered(story, w, h), text + corners)]


def _cornered(m: CameraMap, w: int, h: int) -> CameraMap:
    """The map with pixel corners (x, y) where the centres (x + 0.5, y + 0.5) belong."""
    su, ou, sv, ov = m
    return (su, ou - su / w, sv, ov + sv / h)


def _distance(a: CameraMap, b: CameraMap) -> float:
    """How far two maps lie apart: the largest difference of a number, relative to its
    axis's scale."""
    su, sv = abs(a[0]) + 1e-9, abs(a[2]) + 1e-9
    terms = (a[0] - b[0]) / su, (a[1] - b[1]) / su, (a[2] - b[2]) / sv, (a[3] - b[3]) / sv
    return max(abs(t) for t in terms)
