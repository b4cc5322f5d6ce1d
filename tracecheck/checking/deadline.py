"""z3 stopped at a deadline of wall time, whatever it is doing: its own ``timeout`` counts
only while it checks, not while it rewrites a large term being asserted (which alone took
minutes and gigabytes).
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Iterator

__all__ = ["interrupted_at"]


@contextmanager
def interrupted_at(z3, seconds: float) -> Iterator[None]:
    """z3's context interrupted ``seconds`` from now if the block is still running then
    (never after it: the next question is not interrupted). An interrupt that came just as
    z3 finished leaves its context canceled — every later call, reading the model or the next
    question, would fail with "canceled" until a check runs — so an empty check clears it."""
    lock, live, fired = threading.Lock(), [True], [False]

    def stop() -> None:
        with lock:
            if live[0]:
                z3.main_ctx().interrupt()
                fired[0] = True

    timer = threading.Timer(seconds, stop)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        with lock:
            live[0] = False
        timer.cancel()
        if fired[0]:
            z3.Solver().check()
