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

# Diagnoses that are wrong today: each says what the diagnosis said and what is wrong with it
# (none since 2026-12-05: the camera and the Fresnel curve's constants are fitted).
_DIAGNOSIS_PENDING: dict[str, str] = {}


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
    """The steps the diagnosis localises what it does not explain to: each localisation's
    step and the steps it says the image cannot tell from it (its tied `alternatives`)."""
    where = list(d.get("localisation") or []) + list(d.get("unexplained_where") or [])
    out: set[str] = set()
    for w in where:
        if isinstance(w, dict) and w.get("step"):
            out |= {str(w["step"]), *(str(a) for a in w.get("alternatives") or [])}
    return out


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
