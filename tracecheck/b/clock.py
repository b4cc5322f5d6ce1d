"""A wall-clock limit on tracecheck's own evaluation: ``--step-timeout`` (a script's step)
and ``eval --timeout`` bound the evaluator too, not only what they wait for.

The evaluator's loops that can run long without building anything large — the nested
walks of bound variables (``card({x, y | x : 1..10000 & y : 1..10000 & …})`` is 10^8 pairs
of sets each within the size limit) and the walks of sets — call :func:`tick`; inside
:func:`time_limit` it raises :class:`~tracecheck.errors.EvaluationError` once the limit has
passed (:class:`~tracecheck.errors.TimeLimitError`, a refusal: the evaluation could not
finish, which says nothing of its value; ``eval`` exits 3, unknown).
Outside any limit a tick costs one counter increment.

>>> import time
>>> with time_limit(0.01, "the predicate"):
...     try:
...         while True:
...             tick()
...     except TimeLimitError as exc:
...         print(exc.message)
the predicate: tracecheck's evaluation took longer than 0.01 s
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Iterator, Optional

from ..errors import TimeLimitError

__all__ = ["time_limit", "tick"]

_LIMIT: ContextVar[Optional[tuple[float, float, str]]] = ContextVar("tracecheck_time_limit",
                                                                    default=None)
_count = 0
#: the clock is read every this many ticks (a tick is one value of a walk)
_EVERY = 256


@contextmanager
def time_limit(seconds: Optional[float], what: str) -> Iterator[None]:
    """Evaluation inside the block stops with an :class:`EvaluationError` naming ``what``
    once ``seconds`` of wall time have passed (None: no limit; an outer, earlier limit
    stays in force)."""
    outer = _LIMIT.get()
    if seconds is None:
        yield
        return
    deadline = time.monotonic() + seconds
    if outer is not None and outer[0] <= deadline:
        yield
        return
    token = _LIMIT.set((deadline, seconds, what))
    try:
        yield
    finally:
        _LIMIT.reset(token)


def tick() -> None:
    """One step of a walk: past the limit of the :func:`time_limit` around it, an error."""
    global _count
    _count += 1
    if _count % _EVERY:
        return
    limit = _LIMIT.get()
    if limit is not None and time.monotonic() > limit[0]:
        raise TimeLimitError(f"{limit[2]}: tracecheck's evaluation took longer than "
                             f"{limit[1]:g} s")
