"""Measures every corpus variant and writes a Markdown table: verdict, score, differing and
unstable pixels per effect, where those pixels are and what their codes are (test
against 255 x the model's value), and what `rtval diagnose` says of the mistake variants.

    .venv/bin/python tests/corpus/measure.py OUT.md [--jobs N] [--only NAME,...]

It uses the render cache of rtval (RTVAL_CACHE, else the user's): run it with
RTVAL_CACHE=$(mktemp -d) for a cold measurement.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests/, for `corpus`

from corpus.programs import Builder, CorpusError, Outcome, differences, missing, run_variant
from corpus.variants import ALL, Variant


def _effects(d: dict[str, int]) -> str:
    shown = [f"{k} {n}" for k, n in d.items() if n]
    return ", ".join(shown) or "-"


def _diagnosis(o: Outcome) -> str:
    if o.diagnosis is None:
        return ""
    d = o.diagnosis
    bits = [f"`{d.get('result', '?')}`"]
    if d.get("causes"):
        bits.append(f"causes: {', '.join(c['name'] for c in d['causes'])}")
    if d.get("unexplained"):
        bits.append(f"unexplained: {', '.join(d['unexplained'])}")
    where = list(d.get("localisation") or []) + list(d.get("unexplained_where") or [])
    steps = sorted({str(w["step"]) for w in where if isinstance(w, dict) and w.get("step")})
    if steps:
        bits.append(f"localised: {', '.join(steps)}")
    if o.variant.causes or o.variant.steps:
        true = ", ".join(sorted(o.variant.causes)) or "none named"
        bits.append(f"true: {true} / {', '.join(sorted(o.variant.steps))}")
    return "; ".join(bits)


def measure(variants: list[Variant], jobs: int) -> list[tuple[Variant, Outcome | str]]:
    folder = Path(tempfile.mkdtemp(prefix="rtval-corpus-"))
    builder = Builder(folder)

    def one(v: Variant) -> tuple[Variant, Outcome | str]:
        why = missing(v.build)
        if why:
            return v, f"skipped: {why}"
        try:
            return v, run_variant(builder, v, folder / v.name, with_diagnosis=v.mistake is not None)
        except CorpusError as e:
            return v, f"error: {e}"

    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(one, variants))


def report(results: list[tuple[Variant, Outcome | str]]) -> str:
    lines = [
        "| variant | build | size | expected | verdict | score | differing px per effect "
        "| unstable px | diagnosis |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    details = []
    for v, o in results:
        expected = "fail" if v.mistake else "pass 100"
        build = f"`{v.build.describe()}`" + (
            f" `{' '.join(v.argv)}`" if v.argv != ("{w}", "{h}", "{out}") else ""
        )
        size = f"{v.size[0]}x{v.size[1]}"
        if isinstance(o, str):
            lines.append(f"| {v.name} | {build} | {size} | {expected} | {o} | | | | |")
            continue
        lines.append(
            f"| {v.name} | {build} | {size} | {expected} | {o.status} | {o.score:.4f} "
            f"| {_effects(o.differing())} | {_effects(o.unstable())} | {_diagnosis(o)} |"
        )
        if v.mistake:
            continue
        pixels = differences(o, limit=100_000)
        shown = [p for p in pixels if p.kind != "slack"]
        slack = len(pixels) - len(shown)
        if pixels:
            details.append(f"\n### {v.name}\n")
            details += [f"- {p.line()}" for p in shown[:60]]
            if len(shown) > 60:
                details.append(f"- ... and {len(shown) - 60} more differing or unstable px")
            details.append(f"- {slack} px more within the 2^-16 value slack of the centre render")
    return "\n".join(lines) + "\n" + "\n".join(details) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="")
    args = ap.parse_args()
    chosen = [v for v in ALL if not args.only or v.name in args.only.split(",")]
    start = time.monotonic()
    results = measure(chosen, args.jobs)
    text = report(results)
    args.out.write_text(text + f"\n(measured in {time.monotonic() - start:.0f} s)\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
