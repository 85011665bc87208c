"""Where `rtval grade`'s tasks run: in this process, in a local process pool, or on a Dask
cluster. Each result is handed to `arrived` as it comes, in completion order.

Pool workers die with grade (`kill -9` or `kill -TERM` included): each asks the kernel for
SIGKILL when its parent goes (Linux's PR_SET_PDEATHSIG), instead of sitting forever under
init. A Dask scheduler is tried first within --scheduler-timeout: a port that refuses, one that
accepts and never answers, and one that speaks something else are each a clear error
(SchedulerError, an OSError: exit 4), never a hang. On Dask, run_on_dask sends what every task
shares once per worker, and a task whose worker died or was lost arrives as its failure in
words, so one machine's trouble is one row, never the end of the class.
"""

from __future__ import annotations

import asyncio
import ctypes
import ctypes.util
import os
import signal
import socket
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as pool_completed
from dataclasses import dataclass
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")
S = TypeVar("S")

SCHEDULER_TIMEOUT = 10.0  # seconds; --scheduler-timeout
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
# What a Dask scheduler sends first on every connection: its handshake, a msgpack map.
_HANDSHAKE_WORDS = (b"compression", b"pickle-protocol")


class SchedulerError(OSError):
    """The Dask scheduler could not be reached or is not one (the message names it)."""


@dataclass(frozen=True)
class Executor:
    """Where tasks run: `local` (a pool of `jobs` processes; 1: this process) or `dask` (the
    cluster at `scheduler`, reached within `scheduler_timeout` seconds)."""

    kind: str = "local"
    scheduler: str | None = None
    jobs: int = 2
    scheduler_timeout: float = SCHEDULER_TIMEOUT

    def check(self) -> None:
        """A usage error (ValueError: exit 64) before any work."""
        if self.kind not in ("local", "dask"):
            raise ValueError(f"unknown executor {self.kind!r} (expected local or dask)")
        if self.kind == "dask" and not self.scheduler:
            raise ValueError(
                "--executor dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)"
            )

    @property
    def side_by_side(self) -> bool:
        """Whether tasks run at the same time (each then gets fewer threads of its own)."""
        return self.kind == "dask" or self.jobs > 1


def run_tasks(
    work: Callable[[T], R], tasks: Sequence[T], arrived: Callable[[R], None], where: Executor
) -> None:
    where.check()
    if where.kind == "dask":
        assert where.scheduler is not None
        _on_dask(work, tasks, arrived, where.scheduler, where.scheduler_timeout)
    elif where.jobs <= 1:
        for t in tasks:
            arrived(work(t))
    else:
        with ProcessPoolExecutor(
            max_workers=where.jobs, initializer=die_with_parent, initargs=(os.getpid(),)
        ) as pool:
            for f in pool_completed([pool.submit(work, t) for t in tasks]):
                arrived(f.result())


def die_with_parent(parent: int) -> None:
    """In a pool worker: SIGKILL when the parent dies; exit now if it already has (it may
    have died before the request was made). Elsewhere than Linux, nothing."""
    if not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) != 0:
        return  # not allowed here (a seccomp filter): the pool still works
    if os.getppid() != parent:
        os._exit(1)


def _on_dask(
    work: Callable[[T], R],
    tasks: Sequence[T],
    arrived: Callable[[R], None],
    scheduler: str,
    timeout: float,
) -> None:
    with _dask_client(scheduler, timeout) as client:
        for future in _completed(client.map(work, tasks, pure=False)):
            arrived(future.result())


def run_on_dask(
    work: Callable[[T, S], R],
    tasks: Sequence[T],
    shared: S,
    arrived: Callable[[R], None],
    failed: Callable[[T, str], R],
    where: Executor,
) -> None:
    """Each task as work(task, shared) on the cluster: `shared` travels once per worker
    (scattered), not once per task. A task whose worker died (Dask's KilledWorker after its
    retries) or was lost arrives as failed(task, why): the rest of the class goes on."""
    assert where.scheduler is not None
    with _dask_client(where.scheduler, where.scheduler_timeout) as client:
        [common] = client.scatter([shared], broadcast=False)
        futures = client.map(work, tasks, [common] * len(tasks), pure=False)
        task_of = {f.key: t for f, t in zip(futures, tasks, strict=True)}
        for future in _completed(futures):
            try:
                value = future.result()
            except (Exception, asyncio.CancelledError) as e:  # the worker's failure: one row
                arrived(failed(task_of[future.key], worker_failure(e)))
                continue
            arrived(value)


def worker_failure(e: BaseException) -> str:
    """A Dask failure in words (never an exception's name)."""
    name = type(e).__name__
    if name == "KilledWorker":
        return "the Dask worker grading it died (out of memory, or killed)"
    if isinstance(e, asyncio.CancelledError) or "Cancelled" in name:
        return "the Dask scheduler dropped it (restarted, or the connection to it was lost)"
    if isinstance(e, (OSError, EOFError)) or "Comm" in name:
        return "the connection to the Dask worker grading it was lost"
    return f"the Dask worker grading it failed: {str(e)[:200] or 'no message'}"


def _dask_client(scheduler: str, timeout: float) -> Any:
    from dask.distributed import Client

    probe_scheduler(scheduler, timeout)
    try:
        return Client(scheduler, timeout=timeout)
    except (OSError, ValueError) as e:  # TimeoutError is an OSError
        raise SchedulerError(f"{scheduler}: cannot connect to the Dask scheduler: {e}") from None


def _completed(futures: list[Any]) -> Any:
    from dask.distributed import as_completed

    return as_completed(futures)


def probe_scheduler(address: str, timeout: float) -> None:
    """Connects to a tcp:// scheduler (or HOST:PORT) and waits for its handshake, all within
    `timeout` seconds; SchedulerError naming the address otherwise. Other transports (tls://,
    ucx://, inproc://) are left to Dask."""
    host_port = address.removeprefix("tcp://")
    if "://" in host_port:
        return
    host, _, port = host_port.rpartition(":")
    if not host or not port.isdigit():
        raise SchedulerError(f"{address}: not a scheduler address (expected tcp://HOST:PORT)")
    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout) as s:
            seen = _first_bytes(s, deadline)
    except TimeoutError:
        raise SchedulerError(
            f"{address}: no Dask scheduler answered within {timeout:g} s (--scheduler-timeout)"
        ) from None
    except OSError as e:
        raise SchedulerError(f"{address}: cannot connect to the Dask scheduler: {e}") from None
    if not all(w in seen for w in _HANDSHAKE_WORDS):
        raise SchedulerError(f"{address}: does not speak the Dask protocol (is it a scheduler?)")


def _first_bytes(s: socket.socket, deadline: float, limit: int = 4096) -> bytes:
    """What the peer sends first, until it has said its handshake, stopped, or `limit`."""
    seen = b""
    while len(seen) < limit and not all(w in seen for w in _HANDSHAKE_WORDS):
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        s.settimeout(left)
        chunk = s.recv(limit - len(seen))
        if not chunk:
            break
        seen += chunk
    return seen
