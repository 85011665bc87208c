"""report.pdf: the report's page printed by headless Chromium, from a script-free copy."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

from compare.errors import ToolError
from compare.pages.security import printable
from safe_files.paths import check_output_target, write_atomic


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
        write_atomic(copy, printable(opened(html.read_text(encoding="utf-8"))))
        _print_pdf(chromium, copy, tmp)
        check_output_target(pdf)
        tmp.replace(pdf)
    finally:  # never a partial PDF or a stray copy left behind
        tmp.unlink(missing_ok=True)
        copy.unlink(missing_ok=True)


_CLOSED_DETAILS = re.compile(r"<details(?![^>]*\bopen\b)([^>]*)>")


def opened(html: str) -> str:
    """Every <details> of the page open: a collapsed section prints with its numbers (the
    print stylesheet does the same where the browser supports ::details-content)."""
    return _CLOSED_DETAILS.sub(r"<details open\1>", html)


# Runs Chromium in place of itself, set to be killed when rtval ends (PR_SET_PDEATHSIG
# survives exec): a `kill -9` of rtval leaves no browser behind. A fresh process sets it, as a
# preexec_fn in the forked child of a threaded parent could deadlock.
_DIE_WITH_PARENT = """
import ctypes, os, signal, sys
ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
if os.getppid() != int(sys.argv[1]):  # the parent ended before the line above
    sys.exit(1)
os.execv(sys.argv[2], sys.argv[2:])
"""
PRINT_SECONDS = 120
ERROR_TAIL = 500  # characters of Chromium's stderr in the error message


def _print_pdf(chromium: str, html: Path, tmp: Path) -> None:
    args = [
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
    ]
    proc = subprocess.Popen(
        [sys.executable, "-c", _DIE_WITH_PARENT, str(os.getpid()), *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        errors="replace",
        start_new_session=True,  # its own process group: stopping takes its helpers too
    )
    try:
        _, err = proc.communicate(timeout=PRINT_SECONDS)
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        raise ToolError(f"Chromium did not print {html} to PDF within {PRINT_SECONDS} s") from None
    except BaseException:  # an interrupt, a stop signal: the browser goes with the report
        _kill_group(proc)
        raise
    if proc.returncode != 0 or not tmp.is_file():
        raise ToolError(f"Chromium could not print {html} to PDF: {err.strip()[-ERROR_TAIL:]}")


def _kill_group(proc: subprocess.Popen[str]) -> None:
    """Kills Chromium and every process of its group, and reaps it."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
