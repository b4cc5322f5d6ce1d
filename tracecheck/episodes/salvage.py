"""Whether readers leave damaged episodes out with a warning (``--salvage``) or stop.

A context variable, so that a command sets it once for everything it reads; kept apart from
the readers so that setting it imports nothing heavy.
"""

from __future__ import annotations

import contextlib
import contextvars
from typing import Iterator

__all__ = ["salvaging", "salvage_on", "SALVAGE"]

SALVAGE: contextvars.ContextVar[bool] = contextvars.ContextVar("salvage", default=False)


@contextlib.contextmanager
def salvaging(on: bool = True) -> Iterator[None]:
    """Inside this block, readers leave out damaged episodes with a warning instead of
    raising (the ``--salvage`` option)."""
    token = SALVAGE.set(on)
    try:
        yield
    finally:
        SALVAGE.reset(token)


def salvage_on() -> bool:
    return SALVAGE.get()
