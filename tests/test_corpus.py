"""Foreign programs judged against their model (tests/corpus/): "is this implementation
right?" must hold for programs written by other people.

The corpus holds independent implementations of the classic model (C++ float in the
scratchapixel style, C99, C++ double, Rust, Go, JavaScript) and of the paper model (a student's
C++ of the paper's listing), each built the ways people build them (GCC and Clang, -O0 to -O3,
FMA contraction, -ffast-math, -march=native). The design (docs/metrics.md, "Exact match"):

- every correct variant passes against its model: exit 0, every effect passing, score 100;
- every mistake variant fails, and `rtval diagnose` names one of its true causes or, naming
  none, localises it to the step where it lives (a bug that has no name); it never names a
  cause that is not true of the program (tests/corpus/variants.py lists each variant's;
  tests/test_corpus_mistakes.py tests them).

Each variant is built and rendered once per module in a temporary folder (builds and runs
are time-bounded, tests/corpus/programs.py), two at a time (tests/corpus/harness.py); the
tests only read the outcome.
Cases that other work still has to make true are strict xfails naming the missing piece, so
they turn into failures ("XPASS(strict)") the moment that work lands and the marker must go.
`python tests/corpus/measure.py OUT.md` writes the measured table behind the expectations.
"""

from __future__ import annotations

import functools
import subprocess
from collections.abc import Iterator

import pytest
from corpus.harness import Corpus, open_corpus, params, report
from corpus.programs import Variant
from corpus.variants import CORRECT, PAPER_VARIANTS

# --- what the other work has yet to make true ----------------------------------------------


@functools.cache
def _rtdemo_has_direct_light_quirks() -> bool:
    """Whether the installed rtdemo renders Q11-Q13 (the paper's direct light)."""
    from compare.errors import ToolError
    from compare.render.runner import rtdemo_path

    try:
        cmd = [rtdemo_path(), "render", "--help"]
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False, timeout=60)
    except (ToolError, OSError, subprocess.TimeoutExpired):
        return False  # then every judgement fails, and says why
    return "Q13" in proc.stdout + proc.stderr


# Correct variants that pass with a few stray pixels outside the model's spread, within the
# allowance (so they score 100), per effect, measured at the sizes below (tests/corpus/measure.py
# lists the pixels; docs/metrics.md): the paper student's depth-10 chains, where (72, 128) is 15
# in builds without FMA contraction and 36 in the model and every perturbed render of it (an
# arithmetic-order branch), and (54, 136) on a silhouette.
_STRAYS = {
    "paper-gcc-O2": {"refraction": 1, "edges": 1},
    "paper-clang-O2": {"refraction": 1, "edges": 1},
    # At 1200x800 (measured 2026-12-04): one silhouette pixel's green is 237 where every
    # perturbed render gives 235.8-236.1.
    "paper-c-style-full": {"edges": 1},
}
_NO_Q11 = "rtdemo without Q11-Q13 (the paper's direct light): rebuild it (make setup)"


def _not_yet(v: Variant, what: str) -> str | None:
    """Why `what` ("passes", "scores 100") cannot hold for v yet, or None."""
    if v.against == "paper" and not _rtdemo_has_direct_light_quirks() and v.scene == "lit":
        return _NO_Q11
    return None


@pytest.fixture(scope="module")
def corpus(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Corpus]:
    yield from open_corpus(request, tmp_path_factory.mktemp("corpus"))


# --- correct programs ------------------------------------------------------------------------

CORRECT_ALL = CORRECT + [v for v in PAPER_VARIANTS if v.mistake is None]


@pytest.mark.parametrize("variant", params(CORRECT_ALL, "passes", _not_yet))
def test_correct_program_passes(corpus: Corpus, variant: Variant) -> None:
    o = corpus.outcome(variant)
    assert (o.compare_rc, o.status, o.failing_effects) == (0, "pass", []), report(o)
    assert o.compare["exact"]["status"] == "pass", report(o)


@pytest.mark.parametrize("variant", params(CORRECT_ALL, "scores 100", _not_yet))
def test_correct_program_scores_100(corpus: Corpus, variant: Variant) -> None:
    o = corpus.outcome(variant)
    assert o.score == 100.0, report(o)
    strays = {effect: n for effect, n in o.differing().items() if n}
    known = _STRAYS.get(variant.name, {})
    assert all(n <= known.get(effect, 0) for effect, n in strays.items()), report(o)
