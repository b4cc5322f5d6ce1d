"""Worker processes of a command (recording, falsification, checking with ``--workers``):
started by fork where the system has it, quiet on Ctrl-C (it reaches the whole process group;
the command stops its workers itself), and ended with the command however it ends."""

from __future__ import annotations

import multiprocessing as mp
import signal
import threading
from collections import deque
from typing import Callable, Iterable, Iterator, TypeVar

__all__ = ["worker_context", "quiet_worker", "worker_pool", "in_order"]

J = TypeVar("J")
H = TypeVar("H")
R = TypeVar("R")
_END = object()


def worker_context():
    """The multiprocessing context workers start in: fork (the command's modules and data
    are there already), else spawn."""
    return mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")


def quiet_worker() -> None:
    """In a worker, first: leave Ctrl-C to the command (which stops its pool), let SIGTERM
    end it, and ask Linux to end it when the command's process ends, SIGKILL included,
    instead of leaving it to fail writing to a closed pipe."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the pool's terminate() still ends it
        pass


def worker_pool(workers: int, initializer=None, initargs: tuple = ()):
    """A pool of ``workers`` processes (:func:`worker_context`) that end at once when the
    command stops them: they are forked with Ctrl-C ignored and SIGTERM at its default, so
    a pool stopped before a worker ran its ``initializer`` does not leave that worker with
    the command's own handlers, waiting for ever (an import of a few traces hung so)."""
    if threading.current_thread() is not threading.main_thread():
        return worker_context().Pool(workers, initializer=initializer, initargs=initargs)
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        return worker_context().Pool(workers, initializer=initializer, initargs=initargs)
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)


def in_order(submit: Callable[[J], H], jobs: Iterable[J], limit: int,
             result: Callable[[H], R]) -> Iterator[R]:
    """``result(submit(job))`` for each of ``jobs``, in order, with at most ``limit`` jobs
    submitted and not yet given (``submit`` starts a job and returns a handle; ``result``
    waits for it). The writer is often slower than the workers, and a finished job waits in
    this process until it is written: an unbounded queue held 2.4 GB after 5000 grid-world
    episodes."""
    if limit < 1:
        raise ValueError(f"limit must be at least 1, not {limit}")
    ahead: deque[H] = deque()
    jobs = iter(jobs)
    while True:
        while len(ahead) < limit:
            job = next(jobs, _END)
            if job is _END:
                break
            ahead.append(submit(job))
        if not ahead:
            return
        yield result(ahead.popleft())
