"""Interrupts that always stop an rtval command (installed by compare/cli/main.py).

Python raises KeyboardInterrupt wherever the main thread is when SIGINT arrives; inside a
weakref callback or a __del__ (matplotlib's and concurrent.futures' WeakKeyDictionary
callbacks) that exception is printed as "Exception ignored" and dropped, and a command
would go on to finish with exit 0. So the handlers here also remember the signal, and every step
boundary raises again (`check`) until the command ends with 128 + the signal's number.
SIGTERM gets the same treatment, so that temporary files are removed and children killed
instead of the process vanishing mid-write.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Stopped(KeyboardInterrupt):
    """The run was stopped by a signal (a KeyboardInterrupt, so every cleanup path sees it)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    def __reduce__(self) -> tuple[type[Stopped], tuple[int]]:
        return Stopped, (self.signum,)  # it crosses from a pool worker to the report

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


_received: list[int] = []  # the signals received while a guard is installed


def check() -> None:
    """Raises Stopped if a stop signal arrived, even one whose first exception was lost."""
    if _received:
        raise Stopped(_received[0])


def _handler(signum: int, frame: FrameType | None) -> None:
    _received.append(signum)
    if len(_received) == 1:  # a second one must not cut short the cleanup the first began
        raise Stopped(signum)


@contextmanager
def stop_guard() -> Iterator[None]:
    """Installs the handlers for the duration (main thread only; elsewhere signals go to
    whoever installed them) and restores the earlier ones after. Within another guard it
    leaves that one in place."""
    nested = signal.getsignal(signal.SIGINT) is _handler
    if nested or threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()
    before = {s: signal.signal(s, _handler) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in before.items():
            signal.signal(s, h)
