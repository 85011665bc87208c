"""8-bit files as students write them. A PNG is sRGB by convention and a PPM linear (the
codes a PPM writer stores), but students convert one into the other keeping the bytes: a
correct PPM saved as a PNG holds linear codes. Unless the teacher fixes the encoding
(`grade --test-encoding`), an 8-bit image is judged in both: it passes when it matches in
either, and otherwise counts in the one that looks nearer the model (mean FLIP). The scene's row says when the
image was read in the encoding its format does not imply."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from compare.diagnosis.transforms import encoding_cause
from compare.judge.images import ImageError, read_image
from compare.verdict.against import judge_against_model

if TYPE_CHECKING:
    from compare.grading.results import SceneResult
    from compare.judge.images import Image
    from compare.judge.rubric import Rubric
    from compare.judge.scoring import Score
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


def choose_encoding(image: Image, model: LoadedModel, rubric: Rubric, forced: str | None) -> Image:
    """The image to judge: decoded as `forced` when the teacher says so; else, for an
    8-bit file, in whichever encoding passes (the one its format implies first); where
    neither does, the one that looks nearer (its format's own on a tie)."""
    if image.encoding not in ENCODINGS:
        return image
    if forced is not None:
        return reread(image, forced)
    first = judge_against_model(image, model, rubric).score
    if first is None or first.status == "pass":
        return image
    try:
        other = reread(image, _OTHER[image.encoding])
    except ImageError:  # it was readable a moment ago: keep the first reading
        return image
    second = judge_against_model(other, model, rubric).score
    if second is not None and (second.status == "pass" or _looks_nearer(second, first)):
        return other
    return image


def _looks_nearer(other: Score, implied: Score) -> bool:
    """Whether the image read in the other encoding looks nearer the model: its mean FLIP
    over the effects, weighted by their pixels, is lower. Not the score (the share of
    pixels that match): noise on a PPM matches a few more pixels read as sRGB, by chance,
    while it looks seven times further off (FLIP 0.38 against 0.055, bench_grade.py's noisy
    students)."""
    return _mean_flip(other) < _mean_flip(implied)


def _mean_flip(score: Score) -> float:
    pixels = sum(e.pixels for e in score.effects.values())
    flips = sum((e.flip or 0.0) * e.pixels for e in score.effects.values())
    return flips / pixels if pixels else 0.0


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
