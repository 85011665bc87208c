"""Running the corpus inside pytest: the variants a test module asks for are built,
rendered and judged in a pool of threads as soon as the module starts (builds and runs are
time-bounded, programs.py), and each test only reads its variant's outcome.

Each module (tests/test_corpus.py: the correct programs; tests/test_corpus_mistakes.py: the
mistakes) has its own corpus, so that pytest-xdist's `--dist loadscope` runs the two on two
workers at once.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import pytest

from corpus.programs import Builder, Outcome, Variant, differences, missing, run_variant
from corpus.variants import SMALL

JOBS = 2  # the machine's cores; every variant is a single-threaded program


class Corpus:
    """Every variant a test module runs, started two at a time as soon as the module begins."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.builder = Builder(folder)
        self.pool = ThreadPoolExecutor(JOBS)
        self.futures: dict[str, Future[Outcome]] = {}

    def start(self, v: Variant) -> None:
        if v.name not in self.futures and missing(v.build) is None:
            diagnose = v.mistake is not None
            self.futures[v.name] = self.pool.submit(
                run_variant, self.builder, v, self.folder / v.name, with_diagnosis=diagnose
            )

    def outcome(self, v: Variant) -> Outcome:
        why = missing(v.build)
        if why:
            if v.build.tool in ("g++", "gcc") and not v.build.needs_fma:
                pytest.fail(f"{v.name}: {why}; the GNU toolchain is required")
            pytest.skip(f"{v.name}: {why}")
        self.start(v)
        return self.futures[v.name].result()


def open_corpus(request: pytest.FixtureRequest, folder: Path) -> Iterator[Corpus]:
    """A module-scoped fixture's body: starts every variant the module will ask for (after
    -k / -m selection), in order, and waits for the pool at the end."""
    c = Corpus(folder)
    for item in request.session.items:
        spec = getattr(item, "callspec", None)
        if getattr(item, "module", None) is not request.module or spec is None:
            continue
        if isinstance(spec.params.get("variant"), Variant):
            c.start(spec.params["variant"])
    yield c
    c.pool.shutdown(wait=True, cancel_futures=True)


def params(
    variants: list[Variant], what: str, not_yet: Callable[[Variant, str], str | None]
) -> list[object]:
    """The variants as pytest parameters: full-size ones marked slow, and a strict xfail
    where not_yet(variant, what) says why `what` cannot hold yet (a non-strict one where the
    reason starts with "(load)": it holds on an idle machine only)."""
    out = []
    for v in variants:
        marks: list[pytest.MarkDecorator] = []
        if v.size != SMALL and v.size[0] * v.size[1] > SMALL[0] * SMALL[1] * 2:
            marks.append(pytest.mark.slow)
        why = not_yet(v, what)
        if why:
            # "(load)": the outcome depends on how busy the machine is: not strict.
            strict = not why.startswith("(load)")
            marks.append(pytest.mark.xfail(strict=strict, reason=why))
        out.append(pytest.param(v, id=v.name, marks=marks))
    return out


def report(o: Outcome) -> str:
    lines = [
        f"{o.variant.name} ({o.variant.build.describe()}, {o.variant.size[0]}x{o.variant.size[1]}) "
        f"against {o.variant.against}: {o.status}, score {o.score:.4f}, exit {o.compare_rc}",
        f"differing px per effect: {o.differing()}",
        f"unstable px per effect: {o.unstable()}",
        *o.compare.get("reasons", []),
    ]
    try:
        lines += [p.line() for p in differences(o, limit=12) if p.kind == "differs"]
    except Exception as e:  # the listing only explains a failure; never hide the failure
        lines.append(f"(no pixel listing: {e})")
    return "\n".join(lines)
