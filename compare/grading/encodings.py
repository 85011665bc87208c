"""8-bit files as students write them. A PNG is sRGB by convention and a PPM linear (the
codes a PPM writer stores), but students convert one into the other keeping the bytes: a
correct PPM saved as a PNG holds linear codes. Unless the teacher fixes the encoding
(`grade --test-encoding`), an 8-bit image is judged in both: it passes when it matches in
either, and otherwise counts in the one that looks nearer the model. The scene's row says when the
image was read in the encoding its format does not imply."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from compare.diagnose.transforms import encoding_cause
from compare.judge.arrays import F32
from compare.judge.images import ImageError, linear_to_srgb, read_image
from compare.verdict.against import judge_against_model

if TYPE_CHECKING:
    from compare.grading.results import SceneResult
    from compare.judge.evaluate import Evaluation
    from compare.judge.images import Image
    from compare.judge.rubric import Rubric
    from compare.verdict.against import LoadedModel

ENCODINGS = ("srgb", "linear")
_OTHER = {"srgb": "linear", "linear": "srgb"}
_NOTES = {
    ("png", "linear"): "read as linear: the PNG holds the values a PPM writer stores",
    ("ppm", "srgb"): "read as sRGB: the PPM holds sRGB-encoded values, as a PNG writer stores",
}


# The diagnosis' cause for a file read in the other encoding: what the student's file is.
_CAUSES = {
    ("png", "linear"): "the PNG holds linear values (a PPM writer's bytes saved as PNG)",
    ("ppm", "srgb"): "the PPM holds sRGB values (a PNG writer's bytes saved as PPM)",
}


def _kind(image: Image) -> str:
    return "png" if image.path.lower().endswith(".png") else "ppm"


def _implied(image: Image) -> str:
    """The encoding the file's format implies (images.read_image's default)."""
    return "srgb" if _kind(image) == "png" else "linear"


def encoding_note(image: Image) -> str:
    """The row's words for an image read in the encoding its format does not imply."""
    if image.encoding not in ENCODINGS or image.encoding == _implied(image):
        return ""
    return _NOTES.get((_kind(image), image.encoding), f"read as {image.encoding} (--test-encoding)")


def reread(image: Image, encoding: str) -> Image:
    """The same 8-bit file decoded as `encoding` (a float image is itself)."""
    if image.encoding not in ENCODINGS or image.encoding == encoding:
        return image
    return read_image(image.path, encoding=encoding, expected_size=image.shape)


def choose_encoding(
    image: Image, model: LoadedModel, rubric: Rubric, forced: str | None
) -> tuple[Image, Evaluation]:
    """The image to judge, with its evaluation: decoded as `forced` when the teacher says so;
    else, for an 8-bit file, in whichever encoding passes (the one its format implies
    first); where neither does, the one that looks nearer (its format's own on a tie).
    Against a demo model the choice is made by exact match and a display distance, so no
    FLIP is computed for the encoding not kept."""
    if image.encoding in ENCODINGS and forced is not None:
        image = reread(image, forced)
    first = judge_against_model(image, model, rubric)
    if image.encoding not in ENCODINGS or forced is not None or _passes(first):
        return image, first
    try:
        other = reread(image, _OTHER[image.encoding])
    except ImageError:  # it was readable a moment ago: keep the first reading
        return image, first
    # A look first (exact match, no FLIP): the full verdict only if this reading is kept.
    if _passes(judge_against_model(other, model, rubric, scored=False)) or _looks_nearer(
        other, image, model
    ):
        return other, judge_against_model(other, model, rubric)
    return image, first


def _passes(ev: Evaluation) -> bool:
    if ev.exact is not None:  # a demo model: exact match decides, no FLIP needed
        return ev.exact.passed
    return ev.score is not None and ev.score.status == "pass"


def _looks_nearer(other: Image, implied: Image, model: LoadedModel) -> bool:
    """Whether the image read in the other encoding looks nearer the model: a lower mean
    difference of display values. Not the share of pixels that match: noise on a PPM matches
    a few more pixels read as sRGB, by chance, while it looks seven times further off (FLIP
    0.38 against 0.055, bench_grade.py's noisy students)."""
    ref = _display(model.reference.rgb)
    near_other = np.abs(_display(other.rgb) - ref).mean()
    return bool(near_other < np.abs(_display(implied.rgb) - ref).mean())


def nearer_reading(image: Image, references: Sequence[F32]) -> Image:
    """A PNG read as linear where that reading lies nearer the nearest of `references` (the
    modes' renders; `rtval diagnose` without --encoding) by both measures: more pixels within
    a display code and a lower mean display difference; else as read. Both must agree: noise
    matches a few more pixels by chance in one reading while it looks further off in it
    (_looks_nearer). A PNG of linear values is a program that writes no curve; a PPM of
    gamma-encoded values is the search's double_gamma, an exact fit, so a PPM is read as is."""
    if image.encoding != "srgb" or _kind(image) != "png" or not references:
        return image
    try:
        other = reread(image, "linear")
    except ImageError:  # it was readable a moment ago: keep the first reading
        return image
    (share, distance), (other_share, other_distance) = (
        _nearness(x, references) for x in (image, other)
    )
    return other if other_share > share and other_distance < distance else image


def _nearness(image: Image, references: Sequence[F32]) -> tuple[float, float]:
    """(the largest share of pixels within a display code of a reference, the smallest mean
    display difference from one)."""
    shown = _display(image.rgb)
    diffs = [np.abs(shown - _display(ref)) for ref in references]
    share = max(float((d.max(axis=2) <= 1 / 255).mean()) for d in diffs)
    return share, min(float(d.mean()) for d in diffs)


def _display(rgb: F32) -> F32:
    return linear_to_srgb(np.clip(np.nan_to_num(rgb), 0, 1).astype(np.float32))


def with_encoding(result: SceneResult, image: Image) -> SceneResult:
    """The scene's result naming how its 8-bit image was read: the verdict's `encoding`,
    and the note in the row's reason when it is not the format's own."""
    if result.verdict is None or image.encoding not in ENCODINGS:
        return result
    note = encoding_note(image)
    verdict = {**result.verdict, "encoding": image.encoding, "encoding_note": note}
    reason = "; ".join(x for x in (note, result.reason) if x)
    return dataclasses.replace(result, verdict=verdict, reason=reason)


def with_encoding_cause(diagnosis: dict[str, Any], image: Image) -> dict[str, Any]:
    """The diagnosis of an 8-bit image read in the encoding its format does not claim, with
    that mismatch as its first cause (the rest were found on the image so read)."""
    if image.encoding not in ENCODINGS or image.encoding == _implied(image):
        return diagnosis
    name = _CAUSES.get((_kind(image), image.encoding), f"read as {image.encoding}")
    cause = encoding_cause(name)
    causes = [c for c in diagnosis.get("causes") or [] if c != cause]
    return {**diagnosis, "causes": [cause, *causes]}
