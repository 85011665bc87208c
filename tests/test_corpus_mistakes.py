"""Mistake variants of the corpus's programs (tests/corpus/variants.py): a C++ program's
compile-time slips and the Rust, Go and JavaScript programs' run-time switches, one to two
changes each, covering every step of the algorithm, plus typos that no catalogue holds.

- every mistake variant fails the verdict (exit 2, status fail, score below 100);
- `rtval diagnose` names one of the variant's true causes (its `causes`) or, naming none,
  localises the error to one of its `steps`; it never names any other cause: a false cause is
  the worst answer (issue 43).

Cases that the diagnosis gets wrong today are strict xfails saying what it said, so that
they turn into failures ("XPASS(strict)") the moment that is fixed and the marker must go.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from corpus.harness import Corpus, open_corpus, params, report
from corpus.programs import Variant
from corpus.variants import MISTAKES, PAPER_VARIANTS

# Diagnoses that are wrong today (measured 2026-12-05 on main 0597f67, 320x240): each says
# what the diagnosis said and what would make it right.
_NO_STEP = "names no cause, and the diagnosis cannot localise an error to its step yet"
_WAITS_B = "the named mistake is not in mistakes.json yet; "
_DIAGNOSIS_PENDING = {
    **dict.fromkeys(
        (
            "scratch-untinted_glass", "rust-fov35", "go-fov_on_x", "rust-eta_inverted", "rust-fresnel_constants_swapped",
            "go-y_by_width", "js-reflect_half", "js-k_eta_unsquared", "go-lambert_unclamped",
        ),
        _NO_STEP,
    ),
    **dict.fromkeys(
        (
            "go-near_root_only", "js-ray_dir_unnormalized", "go-normal_not_normalized",
            "js-reflect_sign", "go-reflection_untinted", "js-fresnel_weights_swapped",
            "js-light_blocks_itself", "go-shadow_dir_unnormalized", "rust-light_dir_reversed",
            "js-refraction_unweighted", "js-tan_full_fov",
            "rust-no_aspect",
        ),
        _WAITS_B + _NO_STEP,
    ),
    "rust-negative_root_hit": _WAITS_B + "it names no_offset, a false cause",
    "rust-refraction_bias_outside": _WAITS_B + "it names no_offset, a false cause",
    "go-fresnel_facing_sign": _WAITS_B
    + "it names +Q7, fresnel_missing and --no-refraction, false causes",
}  # fmt: skip


def _not_yet(v: Variant, what: str) -> str | None:
    """Why `what` ("fails", "diagnosed") cannot hold for v yet, or None."""
    if what == "diagnosed" and v.name in _DIAGNOSIS_PENDING:
        return _DIAGNOSIS_PENDING[v.name]
    return None


@pytest.fixture(scope="module")
def corpus(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Corpus]:
    yield from open_corpus(request, tmp_path_factory.mktemp("corpus-mistakes"))


# variant -> the effects that must fail against the model (measured; more may fail too)
FAILING = {
    "scratch-depth10": {"reflection", "refraction"},
    "scratch-depth3": {"reflection", "refraction"},
    "scratch-eta_inverted": {"refraction"},
    "scratch-fresnel_exponent": {"reflection", "refraction"},
    "scratch-black_background": {"background"},
    "scratch-no_inside_flip": {"refraction"},
    "scratch-no_offset": {"reflection", "refraction"},
    "scratch-half_pixel_offset": {"edges"},
    "scratch-untinted_glass": {"refraction"},
    "scratch-ior1.5": {"refraction"},
    "paper-mirrored": {"background", "reflection", "refraction"},
}
ALL_MISTAKES = MISTAKES + [v for v in PAPER_VARIANTS if v.mistake is not None]


@pytest.mark.parametrize("variant", params(ALL_MISTAKES, "fails", _not_yet))
def test_mistake_fails(corpus: Corpus, variant: Variant) -> None:
    o = corpus.outcome(variant)
    assert (o.compare_rc, o.status) == (2, "fail"), report(o)
    assert FAILING.get(variant.name, set()) <= set(o.failing_effects), report(o)
    assert o.score < 100


def _true(cause: dict[str, Any], causes: frozenset[str]) -> bool:
    """Whether a named cause is true of the program: its name, or one of the alternatives it
    says the image cannot tell from it ("-Q6 (or, as well: max depth 7 or more ...)")."""
    alternatives = [str(a).split(" (")[0] for a in cause.get("alternatives") or []]
    return str(cause["name"]) in causes or any(a in causes for a in alternatives)


def _localised(d: dict[str, Any]) -> set[str]:
    """The steps the diagnosis localises what it does not explain to."""
    where = list(d.get("localisation") or []) + list(d.get("unexplained_where") or [])
    return {str(w["step"]) for w in where if isinstance(w, dict) and w.get("step")}


@pytest.mark.parametrize("variant", params(ALL_MISTAKES, "diagnosed", _not_yet))
def test_diagnosis_names_a_true_cause(corpus: Corpus, variant: Variant) -> None:
    """Every cause the diagnosis names is one of the variant's true causes (a false cause is
    the worst answer); it names one, or, naming none, localises the error to its step."""
    o = corpus.outcome(variant)
    d = o.diagnosis
    assert d is not None
    said = [str(c["name"]) for c in d["causes"]]
    text = f"causes {said}, localised to {sorted(_localised(d))}\n{d.get('text', '')}"
    assert all(_true(c, variant.causes) for c in d["causes"]), "a false cause: " + text
    if not said:
        assert _localised(d) & variant.steps, text
