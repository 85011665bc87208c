"""report.pdf: the report's page printed by headless Chromium, from a script-free copy."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from compare.apps.page_security import printable
from compare.files import write_atomic
from compare.render.runner import ToolError
from scene_model.safe_paths import check_output_target


def _sandbox_flags() -> list[str]:
    """Chromium refuses to start its sandbox as root; only then is it switched off. The
    copy it prints holds no script and a policy that forbids them (page_security.printable):
    nothing runs in the unsandboxed browser. (--blink-settings=scriptEnabled=false would
    say the same, but headless Chromium then writes no PDF at all.)"""
    return ["--no-sandbox"] if hasattr(os, "geteuid") and os.geteuid() == 0 else []


def write_pdf(html: Path, pdf: Path) -> None:
    """The same page printed by headless Chromium."""
    chromium = (
        shutil.which("chromium")
        or shutil.which("chromium-browser")
        or shutil.which("google-chrome")
    )
    if not chromium:
        raise ToolError(
            "report.pdf needs Chromium (make setup installs Debian's chromium); or pass --no-pdf"
        )
    check_output_target(pdf)
    tmp = pdf.with_name(f".{pdf.stem}.{os.getpid()}.tmp.pdf")
    # Printed from a script-free copy beside the page (so its relative images resolve).
    copy = html.with_name(f".{html.stem}.{os.getpid()}.print.html")
    try:
        write_atomic(copy, printable(html.read_text(encoding="utf-8")))
        _print_pdf(chromium, copy, tmp)
        check_output_target(pdf)
        tmp.replace(pdf)
    finally:  # never a partial PDF or a stray copy left behind
        tmp.unlink(missing_ok=True)
        copy.unlink(missing_ok=True)


def _print_pdf(chromium: str, html: Path, tmp: Path) -> None:
    proc = subprocess.run(
        [
            chromium,
            "--headless",
            *_sandbox_flags(),
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-pdf-header-footer",
            f"--print-to-pdf={tmp}",
            html.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    if proc.returncode != 0 or not tmp.is_file():
        raise ToolError(f"Chromium could not print {html} to PDF: {proc.stderr.strip()[-500:]}")
