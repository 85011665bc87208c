"""A foreign renderer's stderr in failure messages: escape codes shown escaped (they reached
the terminal raw), only a bounded tail kept (300 MB of stderr made rtval hold 965 MB), and a
child that left the process group holding the pipe does not delay a timeout (it took 30 s)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

from compare.render import foreign


def test_escape_codes_are_shown_escaped(tmp_path: Path) -> None:
    code = "import sys; sys.stderr.write('\\x1b[2J\\x1b[31mboom\\x07\\ttab\\n'); sys.exit(3)"
    with pytest.raises(foreign.RenderFailed) as e:
        foreign._run_plain([sys.executable, "-c", code], "r", tmp_path / "o.ppm", 60)
    text = str(e.value)
    assert "\x1b" not in text and "\x07" not in text
    assert "\\x1b[2J\\x1b[31mboom\\x07\ttab" in text and text.startswith("exit status 3")


def test_only_a_bounded_tail_is_kept() -> None:
    r, w = os.pipe()
    tail = foreign._Tail(r)
    for _ in range(160):  # 10 MB
        os.write(w, b"x" * (1 << 16))
    os.write(w, b"the end")
    os.close(w)
    assert tail.text().endswith("the end") and len(tail.text()) == foreign.STDERR_KEPT
    assert len(tail.kept) <= 4 * foreign.STDERR_KEPT
    os.close(r)


def test_a_detached_child_holding_the_pipe_does_not_delay_the_timeout(tmp_path: Path) -> None:
    child = "import time; time.sleep(60)"
    code = (
        "import subprocess, sys, time; "
        f"subprocess.Popen([sys.executable, '-c', {child!r}], start_new_session=True); "
        "time.sleep(60)"
    )
    start = time.monotonic()
    with pytest.raises(foreign.RenderFailed, match="timed out after 1 s"):
        foreign._run_plain([sys.executable, "-c", code], "r", tmp_path / "o.ppm", 1)
    assert time.monotonic() - start < 45  # the child sleeps 60 s holding stderr
