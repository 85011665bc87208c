"""What a program's image writer or pixel loop can do to a right image, fitted on the image
itself against the start model's render (no sweep: each family is one fit):

  channels    a permutation of R, G, B (BGR order, a swapped pair)
  transposed  rows written as columns (a square image only: the size must stay)
  scale       every value multiplied by one factor (fitted: the median ratio of image to
              render, snapped to one or two decimals), or divided by the brightest
  gamma       every value raised to one power (fitted: the median ratio of their logs,
              snapped to one or two decimals or to 1 / one decimal: 1/2.2, 2.2, 0.5)
  srgb        the sRGB curve applied before an 8-bit linear file is written (or twice)
  wrap        no clamp: values over 1 wrap round as (unsigned char)(x * 255) does

Mirroring (left-right, upside down, both: a rotation by 180 degrees) is decided before these,
by search.py. A transform is named (a cause of kind "image") only when it passes the gates of
gates.py against the start: its render, so transformed, matches the pixels that differed from
the image by exact match, FLIP over them halves and no effect gets worse.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from compare.diagnose.score import code_distance, encoded
from compare.judge.arrays import F32
from compare.judge.images import linear_to_srgb

CHANNEL_NAMES = "RGB"
# A transform is kept when it brings the render at most this near (a share of the start's
# distance) and by at least FIT_MIN: the mirror's rule (search.MIRROR_RATIO, MIRROR_MIN).
FIT_RATIO = 0.5
FIT_MIN = 0.02
# Pixels whose values both lie in (LOW, HIGH) carry a scale or a power: no clamp, no black.
LOW, HIGH = 0.02, 0.95
# The paper's double_gamma mistake is x^(1/2.2): it is a named mistake, searched as one.
DOUBLE_GAMMA = 1 / 2.2
SUBSAMPLE = 3


@dataclass(frozen=True)
class Transform:
    """One transform of the rendered values into the image's (`apply`); `undo` where it only
    moves values (channels, transposition): the search then judges the image undone."""

    family: str  # "channels" | "transposed" | "scale" | "gamma" | "srgb" | "wrap"
    name: str  # for a student: "channels written as B, G, R"
    apply: Callable[[F32], F32]
    undo: Callable[[F32], F32] | None = None
    value: float = 0.0  # its parameter: the factor, the power, the channel order as digits

    @property
    def spec(self) -> list[str | float]:
        """What of_spec makes it again from (a diagnosis record keeps it)."""
        return [self.family, self.value, self.name]

    @property
    def moves_pixels(self) -> bool:
        return self.undo is not None


def _perm(order: tuple[int, int, int]) -> Transform:
    inverse = tuple(int(i) for i in np.argsort(order))
    words = ", ".join(CHANNEL_NAMES[i] for i in order)
    return Transform(
        "channels",
        f"channels written as {words} (not R, G, B)",
        lambda rgb: np.ascontiguousarray(rgb[..., list(order)]),
        lambda rgb: np.ascontiguousarray(rgb[..., list(inverse)]),
        float(order[0] * 100 + order[1] * 10 + order[2]),
    )


def _transposed() -> Transform:
    def t(rgb: F32) -> F32:
        return np.ascontiguousarray(rgb.transpose(1, 0, 2))

    return Transform("transposed", "rows written as columns (the image transposed)", t, t)


def _scale(s: float, name: str) -> Transform:
    f = np.float32(s)
    return Transform("scale", name, lambda rgb: (rgb * f).astype(np.float32), value=s)


def _gamma(p: float) -> Transform:
    def apply(rgb: F32) -> F32:
        with np.errstate(invalid="ignore"):
            out: F32 = np.power(np.maximum(rgb, np.float32(0.0)), np.float32(p))
        return out.astype(np.float32)

    return Transform("gamma", f"every value raised to the power {_power_text(p)}", apply, value=p)


def _power_text(p: float) -> str:
    inverse = 1 / p
    return f"1/{inverse:g}" if abs(round(inverse, 1) - inverse) < 1e-9 and p < 1 else f"{p:g}"


def _srgb() -> Transform:
    def apply(rgb: F32) -> F32:
        return linear_to_srgb(rgb)

    return Transform("srgb", "the sRGB curve applied before writing (encoded twice)", apply)


def _wrap() -> Transform:
    def apply(rgb: F32) -> F32:
        levels = np.nan_to_num(rgb, nan=0.0) * np.float32(255.0)
        wrapped = np.where(levels >= 256, np.mod(np.floor(levels), 256), levels)
        return (wrapped / np.float32(255.0)).astype(np.float32)

    return Transform("wrap", "values over 1 not clamped: they wrap round to dark codes", apply)


def encoding_cause(name: str) -> dict[str, Any]:
    """The cause (kind "image", as the transforms') of an 8-bit file judged in the encoding its
    format does not claim: grading judged it in both (compare/grading/encodings.py), so the
    encoding is a finding of the verdict, not a fit of the search."""
    return {
        "name": f"encoding: {name}",
        "kind": "image",
        "effects": [],
        "evidence": {},
        "sentence": f"image writing: {name}",
    }


def _carrying(image: F32, render: F32) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return (render > LOW) & (render < HIGH) & (image > LOW) & (image < HIGH)


def _fitted_scales(image: F32, render: F32) -> list[Transform]:
    out = []
    ok = _carrying(image, render)
    if ok.sum() >= 16:
        s = float(np.median(image[ok] / render[ok]))
        if abs(s - 1) > 0.01:
            # A truncating writer biases the ratio down by up to a level: its neighbours too.
            near = {round(s, 1), *(round(s + d, 2) for d in (-0.01, 0.0, 0.01))}
            ordered = sorted(near, key=lambda v: (len(f"{v:g}"), v))
            out += [_scale(v, f"every value multiplied by {v:g}") for v in ordered if v > 0]
    brightest = float(np.nanmax(render)) if np.isfinite(render).any() else 0.0
    if brightest > 1.0 + 1e-3 and np.isfinite(brightest):
        out.append(_scale(1 / brightest, f"every value divided by the brightest ({brightest:g})"))
    return out


def _fitted_powers(image: F32, render: F32) -> list[Transform]:
    ok = _carrying(image, render) & (render < 0.9) & (image < 0.9)
    if ok.sum() < 16:
        return []
    p = float(np.median(np.log(image[ok]) / np.log(render[ok])))
    if not np.isfinite(p) or abs(p - 1) < 0.03 or p <= 0:
        return []
    snapped = {round(p, 1), 1 / round(1 / p, 1), *(round(p + d, 2) for d in (-0.01, 0.0, 0.01))}
    # The plainest value first: of powers that fit alike, 2.2 is named, not 2.21.
    ordered = sorted(snapped, key=lambda q: (len(f"{q:g}"), q))
    return [_gamma(q) for q in ordered if abs(q - DOUBLE_GAMMA) > 0.01 and q > 0]


def _unchanged(rgb: F32) -> F32:
    return rgb


def noise_transform(sigma: float, undo: Callable[[F32], F32] | None = None) -> Transform:
    """Random noise (noise.py): `apply` leaves a render as it is (the noise is no value the
    render has); `undo`, where the fit knows it, takes the noise out of the image."""
    name = (
        f"random noise on every pixel (about {sigma:.1f} levels of 255 either way, "
        "unrelated from pixel to pixel): no step of the algorithm makes it; the image is "
        "judged with the noise taken out"
    )
    return Transform("noise", name, _unchanged, undo, sigma)


def of_spec(spec: list[str | float]) -> Transform:
    """The transform a spec names (Transform.spec); ValueError for one that is none."""
    family, value, name = str(spec[0]), float(spec[1]), str(spec[2])
    if family == "channels":
        digits = f"{int(value):03d}"
        return _perm((int(digits[0]), int(digits[1]), int(digits[2])))
    made: dict[str, Callable[[], Transform]] = {
        "transposed": _transposed,
        "scale": lambda: _scale(value, name),
        "gamma": lambda: _gamma(value),
        "srgb": _srgb,
        "wrap": _wrap,
        # judged without the noise; shown as it is (what was taken out is not kept)
        "noise": lambda: noise_transform(value),
    }
    if family not in made:
        raise ValueError(f"no image transform {family!r}")
    return made[family]()


def candidates(image: F32, render: F32) -> list[Transform]:
    """Every transform fitted from the image against the render (same shape, linear)."""
    orders = [(0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    out = [_perm(o) for o in orders]
    if image.shape[0] == image.shape[1]:
        out.append(_transposed())
    out += _fitted_scales(image, render) + _fitted_powers(image, render)
    out.append(_srgb())
    if np.nanmax(render, initial=0.0) > 1.0:
        out.append(_wrap())
    return out


def best(image: F32, render: F32, codes: str) -> tuple[Transform, float, float] | None:
    """The transform that brings the render nearest the image by far (FIT_RATIO, FIT_MIN),
    with the distance as it is and so transformed; None where none does."""
    # Compared on every SUBSAMPLE-th row and column (a dozen candidates at full size cost a
    # third of a second at 640x480); the best is measured again on every pixel.
    found = candidates(image, render)
    if not found:
        return None
    sub_render = render[::SUBSAMPLE, ::SUBSAMPLE]
    target = encoded(image[::SUBSAMPLE, ::SUBSAMPLE], codes)
    scored = [code_distance(encoded(t.apply(sub_render), codes), target) for t in found]
    t = found[int(np.argmin(scored))]
    whole = encoded(image, codes)
    plain = code_distance(encoded(render, codes), whole)
    dist = code_distance(encoded(t.apply(render), codes), whole)
    if dist <= FIT_RATIO * plain and plain - dist >= FIT_MIN:
        return t, plain, dist
    return None
