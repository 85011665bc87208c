"""How near a candidate's render comes to the image the diagnosis explains (diagnose.py), per
effect region: the share of the region's pixels that are not what the candidate computes
(exact_match.py's rule, counted quickly: a code that neither a truncating nor a rounding writer
of the candidate's value stores), plus a smooth term for how far they are off (the mean number
of 8-bit levels beyond one, and the region's mean colour), so that a change that moves pixels
towards the image counts before they match. diagnose_trials.Trials keeps every candidate's
score and judges the ones a claim is made of exactly, as the verdict does.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from compare.diagnose.candidate import Candidate
from compare.judge.arrays import F32
from compare.judge.effects import BOOL, effect_masks
from compare.judge.exact_match import Bounds, ExactMatch, allowed_differing, match_bounds
from compare.judge.images import Image, linear_to_srgb
from compare.judge.target_model import TargetModel
from scene_model.scene import Scene

I16 = NDArray[np.int16]
Px = TypeVar("Px", np.float32, np.int16)

# One unit of distance per effect is the whole region differing; LEVELS_PER_UNIT levels of
# mean excess weigh as much (so a change that halves how far pixels are off counts before
# they match).
LEVELS_PER_UNIT = 4.0
# A change is kept when it lowers some effect's distance by EXPLAINS (and 10 %): small drops
# spread over every effect are noise fitting.
EXPLAINS = 2e-3
# A render differing from the reference in more than this share of its pixels is judged
# whole (gathering the pixels would cost more).
WHOLE_SHARE = 0.15
HALF_FLOAT, HALF_FLOAT_FLOOR = 2.0**-11, 2.0**-14  # the search's float tolerance
MIRRORS = {"lr": "left-right", "ud": "upside down", "lrud": "left-right and upside down"}


class Store(Protocol):
    """Texts and bytes kept between runs under names that carry their inputs' hashes (the
    render cache's derived/, through the renderer's `store`). `identity` names what renders
    the candidates (the renderer, the scene file, the size): a kept diagnosis is used only by
    the same."""

    identity: str

    def get(self, name: str) -> str | None: ...

    def put(self, name: str, text: str) -> None: ...

    def get_bytes(self, name: str, max_bytes: int) -> bytes | None: ...

    def put_bytes(self, name: str, data: bytes) -> None: ...


class Renderer(Protocol):
    """What renders the diagnosis's candidates at the image's size (CandidateRenderer, or a
    FunctionRenderer around an injected function): the render itself, and what the search
    needs to know of it."""

    # Seconds one candidate's render may take before it is stopped and skipped (the search
    # sets it from the start's cost); None: no limit.
    time_limit: float | None
    # Rays one candidate's render may trace before it is stopped and skipped (the search sets
    # it from the starts' rays); None: no limit.
    ray_budget: int | None

    @property
    def turns(self) -> Sequence[tuple[float, float]]:
        """The camera turns (in pixels) exact matching renders a model with."""

    @property
    def grows(self) -> Sequence[int]:
        """The sphere growths (float32 ulps) exact matching renders a model with."""

    @property
    def search_quirks(self) -> tuple[int, ...]:
        """The quirks this renderer can toggle."""

    @property
    def store(self) -> Store | None:
        """Where FLIP numbers, kept codes and diagnoses live between runs (None: nowhere)."""

    def __call__(self, what: TargetModel | Candidate) -> Image:
        """The candidate's render (with its id and depth AOVs for a plain model)."""

    def passing(self, what: TargetModel | Candidate) -> Image:
        """The render of a candidate scored once and dropped."""

    def with_aovs(self, what: TargetModel | Candidate) -> Image:
        """The render with its id and depth AOVs."""

    def cost(self, what: TargetModel | Candidate) -> float:
        """Seconds its render took when made (0 when not known)."""

    def rays(self, what: TargetModel | Candidate) -> int:
        """Rays its render traced (0 when not known)."""

    def path_classes(self, what: TargetModel | Candidate) -> NDArray[np.int64] | None:
        """rtdemo's path-class AOV of the candidate (localise.py), None when not available."""


class DiagnoseError(ValueError):
    """The image cannot be diagnosed against this scene (e.g. a renderer without AOVs)."""


class NoFinitePixels(DiagnoseError):
    """Every pixel of the image is NaN or infinite: no candidate can come nearer than
    another, so there is nothing to explain (`rtval diagnose` exits 4, as for an unusable
    input)."""


def check_finite(image: Image) -> None:
    """Raises NoFinitePixels for an image without one finite pixel value."""
    if image.rgb.size and not np.isfinite(image.rgb).any():
        name = image.path or "the image"
        raise NoFinitePixels(
            f"{name}: no finite pixel (every value is NaN or infinite): nothing to diagnose"
        )


def unmirror(rgb: F32, mirrored: str) -> F32:
    """The image as the program computed it, before it was drawn mirrored ("" : as is)."""
    key = next((k for k, v in MIRRORS.items() if v == mirrored), mirrored)
    out = rgb[:, ::-1] if "lr" in key else rgb
    out = out[::-1] if "ud" in key else out
    return np.ascontiguousarray(out)


def _levels(rgb: F32, codes: str) -> F32:
    """255 x the value an 8-bit writer stores, in the image's own encoding: linear for a PPM
    read as linear, display (sRGB) otherwise. NaN counts as 0, as the paper's PPM writer
    stores it."""
    # fmax/fmin take NaN to 0, +inf to 1, -inf to 0; linear_to_srgb clamps so itself. One new
    # array, changed in place: a render's levels are made by the hundred.
    if codes == "linear":
        out: F32 = np.fmax(rgb, np.float32(0.0))
        np.fmin(out, np.float32(1.0), out=out)
    else:
        out = linear_to_srgb(rgb).astype(np.float32, copy=False)
    out *= np.float32(255.0)
    return out


def encoded(rgb: F32, codes: str) -> I16:
    """Whole 8-bit levels (rounded). Rounding a candidate moves it by at most half a level,
    which the one level that `excess` forgives covers (a truncating writer is at most one
    level below)."""
    out: I16 = np.rint(_levels(rgb, codes)).astype(np.int16)
    return out


def _quick_differing(halves: I16, doubled: I16, rgb: F32 | None, test: F32, encoding: str) -> BOOL:
    """H x W: pixels the search counts as not matching the candidate: an 8-bit code that
    neither a truncating nor a rounding writer of the candidate's value stores (a float image:
    off by more than half-float precision). exact_match's rule without its slack of 2^-16 in
    the value; the search's count only, every claim is exact_match's. With h the candidate's
    half-levels (Codes) and c the code, floor(levels) <= c <= floor(levels + 0.5) is
    h >> 1 <= c <= (h + 1) >> 1, that is |h - 2c| <= 1 (`doubled` holds 2c)."""
    if encoding == "float":
        assert rgb is not None
        with np.errstate(invalid="ignore"):
            ok = np.abs(test - rgb) <= HALF_FLOAT * np.maximum(np.abs(rgb), HALF_FLOAT_FLOOR)
        ok |= np.isnan(test) & np.isnan(rgb)
    else:
        d = halves - doubled
        ok = np.abs(d, out=d) <= 1
    out: BOOL = ~(ok[..., 0] & ok[..., 1] & ok[..., 2])
    return out


def _excess(enc: I16, target: I16) -> I16:
    """Per pixel, the levels by which its worst channel differs beyond one (a reduction over
    the last axis of 3 is slower in numpy than two elementwise maxima)."""
    d = np.abs(enc - target)
    out: I16 = np.maximum(np.maximum(np.maximum(d[..., 0], d[..., 1]), d[..., 2]), 1) - 1
    return out


def _bits_changed(a: F32, b: F32) -> NDArray[np.intp]:
    """The pixels (rows of N x 3) whose values differ bit for bit (compared as integers of
    their width where both are one contiguous float type; else as values, where a NaN always
    differs and -0 equals 0, which every term treats alike)."""
    same = a.dtype == b.dtype and a.dtype.itemsize in (4, 8)
    if same and a.flags.c_contiguous and b.flags.c_contiguous:
        a, b = a.view(f"i{a.dtype.itemsize}"), b.view(f"i{b.dtype.itemsize}")
    ne = a != b
    return np.flatnonzero(ne[:, 0] | ne[:, 1] | ne[:, 2])


def _flip_codes(target: I16, key: str) -> I16:
    out = target[:, ::-1] if "lr" in key else target
    return out[::-1] if "ud" in key else out


def code_distance(enc: I16, target: I16) -> float:
    """How far a render's codes lie from the image's: the share of all pixels off by more
    than one level, plus their mean excess / LEVELS_PER_UNIT."""
    return _mirror_distance(enc, target)


def _mirror_distance(enc: I16, target: I16) -> float:
    """Share of all pixels off by more than one level, plus their mean excess / LEVELS_PER_UNIT."""
    excess = _excess(enc, target)
    return float((excess > 0).mean() + excess.mean() / LEVELS_PER_UNIT)


class Regions:
    """The effect masks as one label per pixel, and the pixels in region order: a render
    judged in that order sums each region over one contiguous run (np.add.reduceat), far
    cheaper than a weighted bincount per term."""

    def __init__(self, masks: dict[str, BOOL]) -> None:
        self.names = list(masks)
        n = len(self.names)
        labels = np.full(next(iter(masks.values())).size, n, np.intp)  # n: in no region
        for i, m in enumerate(masks.values()):
            labels[m.ravel()] = i
        self.labels = labels
        self.counts = np.bincount(labels, minlength=n + 1)[:n].astype(np.float64)
        self.order = np.argsort(labels, kind="stable")
        self.sorted_labels = labels[self.order]
        # Where each region's run starts (every region has pixels: masks are never empty),
        # and the pixels in none after the last.
        self.starts = np.flatnonzero(np.r_[True, self.sorted_labels[1:] != self.sorted_labels[:-1]])
        # Region i's pixels lie in [bounds[i], bounds[i + 1]) of the region order.
        self.bounds = np.r_[self.starts[:n], np.r_[self.starts, labels.size][n]]
        self.digest = hashlib.sha1(
            self.order.astype(np.int64).data.cast("B"), usedforsecurity=False
        ).digest()

    def in_order(self, pixels: NDArray[Px]) -> NDArray[Px]:
        """N x 3: the pixels of an H x W x 3 image (values or codes) in region order."""
        out: NDArray[Px] = np.take(pixels.reshape(-1, 3), self.order, axis=0)
        return out

    def sums(self, labels: NDArray[np.intp], values: NDArray[Any]) -> NDArray[np.float64]:
        """Per region, the sum of `values` (one per entry of `labels`). Every value the score
        sums is a whole number, so sums are exact in any order."""
        n = len(self.names)
        return np.asarray(np.bincount(labels, weights=values, minlength=n + 1)[:n], np.float64)

    def changed_sums(self, idx: NDArray[np.intp], values: NDArray[Any]) -> NDArray[np.float64]:
        """Per region (rows), the column sums of `values`, whose rows are the pixels `idx`
        (ascending, in region order): each region's rows are one run of them, summed from
        one cumulative sum instead of a weighted count per column."""
        cuts: NDArray[np.intp] = np.asarray(np.searchsorted(idx, self.bounds), np.intp)
        cum = np.zeros((len(idx) + 1, values.shape[1]), np.int64)
        np.cumsum(values, axis=0, out=cum[1:])
        return np.asarray(cum[cuts[1:]] - cum[cuts[:-1]], np.float64)

    def run_sums(self, values: NDArray[Any]) -> NDArray[np.float64]:
        """Per region, the sum of `values` given for every pixel in region order."""
        totals = np.add.reduceat(values, self.starts, dtype=np.int64)
        return np.asarray(totals[: len(self.names)], np.float64)

    def colour(self, enc: I16) -> NDArray[np.float64]:
        """Mean colour per region, regions x 3, in levels."""
        flat = enc.reshape(-1, 3)
        sums = [self.sums(self.labels, flat[:, ch]) for ch in range(3)]
        return np.stack(sums, axis=1) / self.counts[:, None]


@dataclass
class Codes:
    """A render's pixels (N x 3) as the score sees them: their whole codes (rounded levels,
    _levels) and half-levels floor(2 x levels). A pixel's terms depend on its value only
    through its code and half-levels: the floors that _quick_differing compares are
    floor(levels) = halves >> 1 and floor(levels + 0.5) = (halves + 1) >> 1 (levels lie in
    [0, 255], where levels + 0.5 rounds to no other integer part). `rgb`, the values, only
    where the image is a float one (its terms compare values); `digest` is the codes' sha1."""

    rgb: F32 | None
    enc: I16
    halves: I16
    digest: bytes

    @classmethod
    def of(cls, rgb: F32, codes: str, *, values: bool = True) -> Codes:
        levels = _levels(rgb, codes)  # its own array: changed in place below
        enc: I16 = np.empty(levels.shape, np.int16)
        np.rint(levels, out=enc, casting="unsafe")
        levels *= np.float32(2.0)  # exact: a power of two
        halves: I16 = np.empty(levels.shape, np.int16)
        np.floor(levels, out=halves, casting="unsafe")
        return cls(rgb if values else None, enc, halves, codes_digest(enc))

    def at(self, idx: NDArray[np.intp]) -> Codes:
        rgb = None if self.rgb is None else _rows(self.rgb, idx)
        return Codes(rgb, _rows(self.enc, idx), _rows(self.halves, idx), b"")


def _rows(a: NDArray[Px], idx: NDArray[np.intp]) -> NDArray[Px]:
    """a[idx] (np.take along the rows gathers several times faster than indexing)."""
    out: NDArray[Px] = np.take(a, idx, axis=0)
    return out


def codes_digest(enc: I16) -> bytes:
    """Equal digests, equal codes: how the search tells renders that change no pixel."""
    return hashlib.sha1(np.ascontiguousarray(enc).data.cast("B"), usedforsecurity=False).digest()


@dataclass
class _Terms:
    """Per-pixel terms of one render against the target (pixels flattened): its codes,
    whether each pixel differs, its excess levels; and their per-region sums."""

    codes: Codes
    off: BOOL  # N
    excess: I16  # N
    sums: NDArray[np.float64]  # regions x 5: off, excess, then colour (r, g, b)


@dataclass(frozen=True)
class Score:
    """A candidate against the image, per effect region."""

    differing: dict[str, int]  # pixels that are not an exact match of the candidate's render
    share: dict[str, float]  # ... as a share of the region
    pixels: dict[str, float]  # mean levels beyond one
    tone: dict[str, float]  # how far the mean colour is off, levels beyond one
    digest: bytes  # of the encoded candidate: equal digests, equal images

    def per_effect(self) -> dict[str, float]:
        # The tone term: where float rounding decides each pixel (acne), two programs with the
        # same mistake differ pixel by pixel but agree on average.
        return {
            k: self.share[k] + (self.pixels[k] + self.tone[k]) / LEVELS_PER_UNIT
            for k in self.pixels
        }


def objective(per: dict[str, float]) -> float:
    return float(sum(per.values()))  # every effect counts alike, whatever its size


def explained(
    before: dict[str, float], after: dict[str, float], open_effects: set[str]
) -> tuple[str, ...]:
    """The effects still to explain whose distance a change lowers clearly (by EXPLAINS and
    10 %). An effect already within the exact-match allowance has nothing left to explain:
    moving its last stray pixels is float noise (a float64 program's rounding)."""
    return tuple(
        k
        for k in before
        if k in open_effects and before[k] - after[k] > max(EXPLAINS, 0.1 * before[k])
    )


def worsened(before: Score, after: Score, allowance: dict[str, int]) -> tuple[str, ...]:
    """The effects a change makes clearly worse: more pixels differing than before beyond the
    exact-match allowance, and a distance up by EXPLAINS and 10 % (explained's mirror)."""
    b, a = before.per_effect(), after.per_effect()
    return tuple(
        k
        for k in b
        if after.differing[k] - before.differing[k] > allowance.get(k, 0)
        and a[k] - b[k] > max(EXPLAINS, 0.1 * b[k])
    )


class Target:
    """The image as the search judges it: its 8-bit codes (un-mirrored once that is decided)
    and, from the first render's AOVs, the effect regions and the exact-match allowance.

    Scores are counted against a reference render: a candidate differs from its neighbour
    in the search in a few regions only, so only the pixels whose values differ from the
    reference's are judged again, and the region sums are the reference's plus the change
    (whole numbers: the same sums as judging every pixel)."""

    def __init__(self, image: Image, scene: Scene) -> None:
        self.image, self.scene = image, scene
        self.codes = "linear" if image.encoding == "linear" else "srgb"
        self.masks: dict[str, BOOL] = {}
        self.regions: Regions | None = None
        self.target_colour: NDArray[np.float64] | None = None
        self.allowance: dict[str, int] = {}  # differing pixels an exact match allows
        self.reference: _Terms | None = None
        # The image's pixels in region order, once the regions are known (check).
        self._test_flat: F32 = np.empty((0, 3), np.float32)
        self._target_flat: I16 = np.empty((0, 3), np.int16)
        self._doubled_flat: I16 = self._target_flat
        self._set(image.rgb)

    def _set(self, rgb: F32) -> None:
        self.test = rgb
        self.target = encoded(rgb, self.codes)
        self.reference = None
        if self.regions is not None:
            self.target_colour = self.regions.colour(self.target)
            # The search judges pixels in region order (Regions); the target's once.
            self._test_flat = self.regions.in_order(rgb)
            self._target_flat = self.regions.in_order(self.target)
            self._doubled_flat = self._target_flat * np.int16(2)

    def set_test(self, rgb: F32) -> None:
        """Judge against `rgb` from now on (the un-mirrored image)."""
        self._set(rgb)

    def check(self, c: Candidate, im: Image, masks: dict[str, BOOL] | None = None) -> None:
        """A render of the image's size; the first one's AOVs give the effect regions (or
        `masks`, the ones they gave before)."""
        if im.rgb.shape != self.image.rgb.shape:
            h, w = self.image.shape
            raise DiagnoseError(
                f"the renderer made {im.shape[1]}x{im.shape[0]} for {w}x{h} ({c.name})"
            )
        if self.regions is not None:
            return
        if masks is None:
            if "id" not in im.aovs or "depth" not in im.aovs:
                raise DiagnoseError(f"render of {c.name} has no id/depth AOVs")
            found = effect_masks(self.scene, im.aovs["id"], im.aovs["depth"])
            masks = {k: v for k, v in found.items() if v.any()}
        self.masks.update(masks)
        self.regions = Regions(self.masks)
        self._set(self.test)
        self.allowance = {k: allowed_differing(int(m.sum())) for k, m in self.masks.items()}

    def _terms(self, c: Codes, idx: NDArray[np.intp] | None) -> tuple[BOOL, I16]:
        """(differs, excess) of the pixels idx (None: all) of a render in region order."""
        target = self._target_flat if idx is None else _rows(self._target_flat, idx)
        doubled = self._doubled_flat if idx is None else _rows(self._doubled_flat, idx)
        test = self._test_flat if idx is None or c.rgb is None else _rows(self._test_flat, idx)
        off = _quick_differing(c.halves, doubled, c.rgb, test, self.image.encoding)
        return off, _excess(c.enc, target)

    def _full(self, c: Codes) -> _Terms:
        assert self.regions is not None
        off, excess = self._terms(c, None)
        sums = [self.regions.run_sums(v) for v in (off, excess, *c.enc.T)]
        return _Terms(c, off, excess, np.stack(sums, axis=1))

    def use_reference(self, rgb: F32) -> None:
        """Count the next scores against this render (a neighbour of what comes next)."""
        self.use_reference_codes(self.codes_of(rgb))

    def use_reference_codes(self, codes: Codes) -> None:
        """use_reference of the render with these codes (codes_of)."""
        assert self.regions is not None
        self.reference = self._full(codes)

    def _changed(self, c: Codes, ref: _Terms) -> NDArray[np.intp]:
        """The pixels whose terms can differ from the reference's. Against 8-bit codes a
        pixel's terms are its code and its half-levels (Codes), so a pixel whose value
        moved by float noise and kept both is not judged again; against floats, every pixel
        whose value changed bit for bit."""
        if c.rgb is not None and ref.codes.rgb is not None:  # a float image
            return _bits_changed(c.rgb, ref.codes.rgb)
        ne = (c.enc != ref.codes.enc) | (c.halves != ref.codes.halves)
        return np.flatnonzero(ne[:, 0] | ne[:, 1] | ne[:, 2])

    def _sums(self, codes: Codes) -> NDArray[np.float64]:
        """The region sums of a render, judged again only where its terms can differ from
        the reference's (_changed); judged whole when most pixels do. Without a reference
        the render becomes it: the sums are the same against any reference, so threads
        scoring at once may each set it."""
        ref = self.reference
        assert self.regions is not None
        if ref is None:
            self.reference = self._full(codes)
            return self.reference.sums
        idx = self._changed(codes, ref)
        if idx.size > WHOLE_SHARE * len(codes.enc):
            return self._full(codes).sums
        at = codes.at(idx)
        off_i, excess_i = self._terms(at, idx)
        changes = np.empty((len(idx), 5), np.int32)
        np.subtract(off_i, np.take(ref.off, idx), out=changes[:, 0], dtype=np.int32)
        np.subtract(excess_i, np.take(ref.excess, idx), out=changes[:, 1], dtype=np.int32)
        np.subtract(at.enc, _rows(ref.codes.enc, idx), out=changes[:, 2:], dtype=np.int32)
        return ref.sums + self.regions.changed_sums(idx, changes)

    @property
    def values_judged(self) -> bool:
        """Whether scores compare values, not only codes (a float image)."""
        return self.image.encoding == "float"

    def codes_of(self, rgb: F32) -> Codes:
        """A render's pixels as the score sees them, in region order."""
        assert self.regions is not None
        return Codes.of(self.regions.in_order(rgb), self.codes, values=self.values_judged)

    def total_pixels_ordered(self) -> int:
        """Pixels of a render in region order (every pixel of the image)."""
        assert self.regions is not None
        return len(self.regions.order)

    def codes_kind(self) -> tuple[str, bytes]:
        """What a render's Codes depend on besides the render: the codes and the region
        order (a digest of it)."""
        assert self.regions is not None
        return self.codes, self.regions.digest

    def score(self, rgb: F32) -> Score:
        """The render against the image, per region (thread-safe once `check` has set the
        regions: nothing else is written)."""
        return self.score_codes(self.codes_of(rgb))

    def score_codes(self, codes: Codes) -> Score:
        """score() of the render with these codes (codes_of)."""
        assert self.regions is not None and self.target_colour is not None
        sums = self._sums(codes)
        counts = self.regions.counts
        share = sums[:, 0] / counts
        excess = sums[:, 1] / counts
        colour = sums[:, 2:] / counts[:, None]
        tone = np.maximum(np.abs(colour - self.target_colour).max(axis=1) - 1.0, 0.0)
        names = self.regions.names
        return Score(
            {k: round(float(v * n)) for k, v, n in zip(names, share, counts, strict=True)},
            dict(zip(names, share.tolist(), strict=True)),
            dict(zip(names, excess.tolist(), strict=True)),
            dict(zip(names, tone.tolist(), strict=True)),
            codes.digest,
        )

    def exact(self, c: Candidate, pair: tuple[Bounds, Bounds], renders: int) -> ExactMatch:
        """The verdict's own judging of the image against c's bounds (model_bounds of its
        `renders` renders)."""
        return match_bounds(
            pair, renders, self.test, self.image.encoding, model=c.name, masks=self.masks
        )

    def mirror_distances(self, renders: Sequence[Image]) -> dict[str, float]:
        """Per orientation ("" as is, and each of MIRRORS), the nearest render's distance."""
        encs = [encoded(im.rgb, self.codes) for im in renders]
        return {
            key: min(_mirror_distance(e, _flip_codes(self.target, key)) for e in encs)
            for key in ("", *MIRRORS)
        }
