"""Progress of long steps on stderr.

On a terminal a step redraws one line in place (`\\r`): samples done, elapsed time and an
estimate of the time left. Anywhere else (a pipe, a log file, CI) each step prints one line
when it ends, so logs stay readable and tests can count the lines.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


def _clock(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.1f} min"


class Progress:
    def __init__(self, stream: TextIO | None = None, *, tty: bool | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.tty = self.stream.isatty() if tty is None else tty
        self._live = False  # a \r line is on screen
        self._last = 0.0

    def update(self, step: str, done: int, total: int, elapsed: float, unit: str = "spp") -> None:
        """Within a step: `done` of `total` units after `elapsed` seconds (terminal only)."""
        if not self.tty:
            return
        now = time.monotonic()
        if done < total and now - self._last < 0.1:  # redraw at most 10 times a second
            return
        self._last = now
        left = ""
        if 0 < done < total and elapsed > 0:
            left = f", ~{_clock(elapsed / done * (total - done))} left"
        width = 30
        filled = int(width * min(done, total) / max(total, 1))
        bar = "#" * filled + "." * (width - filled)
        text = f"{step} [{bar}] {done}/{total} {unit}, {elapsed:.1f} s{left}"
        self.stream.write("\r" + text[:150] + "\x1b[K")
        self.stream.flush()
        self._live = True

    def line(self, text: str) -> None:
        """A finished step (or any message): its own line, replacing a live one."""
        if self._live:
            self.stream.write("\r\x1b[K")
            self._live = False
        self.stream.write(text + "\n")
        self.stream.flush()

    __call__ = line  # usable where a Callable[[str], None] is expected
