"""What `rtval check` writes about its results: the terminal table, JSON, JUnit XML (one
testcase per case and effect) and a Markdown summary for CI (GitHub's step summary). Every
file is written atomically and only ever replaces a regular file (safe_files.content); user text
(renderer names, scene names, a renderer's stderr) is escaped for each format
(compare.escape)."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from compare.check.run import WHOLE_IMAGE, CaseResult, exit_code
from compare.escape import markdown_cell, xml_text
from safe_files.content import json_safe
from safe_files.paths import check_output_target, write_atomic

STATUS = ("pass", "warn", "fail")


def table(results: list[CaseResult]) -> str:
    width = max([28, *(len(r.name) for r in results)])
    lines = [
        f"{'case':<{width}} {'status':<8} {'failing px':>10} {'max err':>8} {'SSIM':>8} "
        f"{'time s':>7}  against"
    ]
    order = sorted(results, key=lambda r: ("fail", "warn", "pass").index(r.status))
    for r in order:
        ssim = f"{r.ssim:.5f}" if r.ssim is not None else "-"
        # A baseline --update wrote is the case's outcome: it was not judged against itself.
        status = r.baseline_action or r.status
        px, err = (
            ("-", "-")
            if r.baseline_action == "written"
            else (str(r.failing_pixels), f"{r.max_display_error:.4f}")
        )
        lines.append(
            f"{r.name:<{width}} {status:<8} {px:>10} {err:>8} {ssim:>8} {r.seconds:>7.2f}  "
            f"{r.against}"
        )
    failures = [m for r in results if r.status == "fail" and not r.updated for m in r.reasons]
    if failures:
        lines.append("failures:")
        lines += [f"  {m.splitlines()[0]}" for m in failures]
    lines.append(summary_line(results))
    return "\n".join(lines)


def summary_line(results: list[CaseResult]) -> str:
    """ "3 passed, 1 failed", with the baselines --update wrote or replaced when there are any
    (those cases are neither passes nor failures)."""
    judged = [r for r in results if not r.updated]
    n_fail = sum(r.status == "fail" for r in judged)
    parts = [f"{len(judged) - n_fail} passed", f"{n_fail} failed"]
    for action in ("written", "replaced"):
        n = sum(r.baseline_action == action for r in results)
        if n:
            parts.append(f"{n} baseline{'s' if n > 1 else ''} {action}")
    return ", ".join(parts)


def write_json(results: list[CaseResult], path: Path) -> None:
    data: list[dict[str, Any]] = [r.as_dict() for r in results]
    status = STATUS[exit_code(results)]
    text = json.dumps(json_safe({"status": status, "cases": data}), indent=2, allow_nan=False)
    write_atomic(path, text + "\n")


def _testcases(r: CaseResult) -> list[tuple[str, str, str | None]]:
    """(effect, status, message) for every testcase of one case: the effects that have
    pixels, plus the whole image, plus whatever the failure was filed under."""
    names = [*r.effects, WHOLE_IMAGE]
    names += [n for n in r.failed_effects if n not in names]
    rows: list[tuple[str, str, str | None]] = []
    for n in names:
        if r.status == "fail" and n in r.failed_effects:
            message = next((m for m in r.reasons if m.startswith(f"{r.label}: {n} ")), None)
            rows.append((n, "fail", message or "; ".join(r.reasons)))
        elif n == WHOLE_IMAGE:
            # No image at all (the render failed) fails the image too; otherwise the failure
            # is filed under the effects that failed.
            no_image = r.status == "fail" and "render" in r.failed_effects
            status = "fail" if no_image else (r.status if r.status != "fail" else "pass")
            rows.append((n, status, "; ".join(r.reasons)))
        else:
            e = r.effects[n]
            rows.append((n, "warn" if e.status == "warn" else "pass", "; ".join(e.reasons)))
    return rows


def write_junit(results: list[CaseResult], path: Path) -> None:
    suite = ET.Element("testsuite", name="rtval check")
    tests = failures = 0
    for r in results:
        rows = _testcases(r)
        # Case time on the whole-image testcase: the effects share one render.
        for effect, status, message in rows:
            case = ET.SubElement(
                suite,
                "testcase",
                classname=xml_text(f"rtval.{r.renderer}.{r.scene}"),
                name=xml_text(
                    f"{r.label.split('/', 1)[1] + ':' if '/' in r.label else ''}{effect}"
                ),
                time=f"{r.seconds + r.overhead_seconds:.3f}" if effect == WHOLE_IMAGE else "0",
            )
            ET.SubElement(
                ET.SubElement(case, "properties"), "property", name="against", value=r.against
            )
            tests += 1
            if status == "fail" and not r.updated:
                failures += 1
                text = xml_text(message or "")
                first = text.splitlines()[0] if text else ""
                ET.SubElement(case, "failure", message=first).text = text
            elif status == "warn" or (r.updated and effect == WHOLE_IMAGE):
                note = f"baseline {r.baseline_action}" if r.updated else f"warning: {message}"
                ET.SubElement(case, "system-out").text = xml_text(note)
    suite.set("tests", str(tests))
    suite.set("failures", str(failures))
    write_atomic(path, ET.tostring(suite, encoding="utf-8", xml_declaration=True))


# Every character Markdown (GitHub's included) gives a meaning to inside a line: a name
# `![x](https://...)` would show a picture, `[x](...)` a link, `*`/`_`/backticks emphasis or code.
_MARKDOWN_SPECIAL = re.compile(r"([\\`*_\[\]()!~])")


def markdown_text(text: str) -> str:
    """User text (a path, a case name, a renderer's message) as literal Markdown for one table
    cell or list item: each metacharacter backslash-escaped, then markdown_cell (no HTML, no
    pipe, no line break)."""
    return markdown_cell(_MARKDOWN_SPECIAL.sub(r"\\\1", text))


def markdown_summary(results: list[CaseResult]) -> str:
    status = STATUS[exit_code(results)]
    n_fail = sum(r.status == "fail" and not r.updated for r in results)
    icon = {"pass": "✅", "warn": "⚠️", "fail": "❌"}
    lines = [
        f"### rtval check: {status.upper()} ({len(results) - n_fail} of {len(results)} passed)",
        "",
        "| case | status | failing effects | SSIM | FLIP | renderer s |",
        "|---|---|---|---:|---:|---:|",
    ]
    for r in sorted(results, key=lambda r: ("fail", "warn", "pass").index(r.status)):
        ssim = f"{r.ssim:.4f}" if r.ssim is not None else "-"
        flip = f"{r.flip:.4f}" if r.flip is not None else "-"
        failed = ", ".join(r.failed_effects) if r.status == "fail" else ""
        lines.append(
            f"| {markdown_text(r.name)} | {icon[r.status]} {r.status}{f' (baseline {r.baseline_action})' if r.updated else ''} "
            f"| {markdown_text(failed)} | {ssim} | {flip} | {r.seconds:.2f} |"
        )
    failures = [m for r in results if r.status == "fail" and not r.updated for m in r.reasons]
    if failures:
        lines += ["", "**Failures**", ""] + [
            f"- {markdown_text(m.splitlines()[0])}" for m in failures
        ]
    return "\n".join(lines) + "\n"


def append_step_summary(results: list[CaseResult], path: Path) -> None:
    """Appends to GitHub's step summary (earlier steps' text stays): an append, not a
    replacement, so only the target's kind is checked (a regular file or nothing)."""
    check_output_target(path)
    with path.open("a", encoding="utf-8") as f:
        f.write(markdown_summary(results))
