"""The interpreter limits the B engine needs, raised only while it needs them and restored
afterwards: how many decimal digits an integer may have when it is read or printed, and how
deep Python may recurse for a deeply nested formula. Importing tracecheck changes neither.

The library raises them where it needs them: reading, printing and writing as JSON
(:func:`tracecheck.jsontext.json_text`) long integers, and parsing, checking, evaluating,
printing (:func:`tracecheck.b.printer.to_b`) and proving (:func:`tracecheck.checking.prove`)
deeply nested formulas. Your own code that turns an integer the engine computed into text
with ``str()`` or ``json.dumps`` (over 4300 digits: ``2 ** 40000``), or that compares,
hashes or pickles a formula nested hundreds of levels deep, does so inside
:func:`long_integers` / :func:`deep_recursion` (or uses :func:`int_text`). Both are safe
to enter from several threads at once.

>>> import sys
>>> before = sys.get_int_max_str_digits()
>>> len(int_text(10 ** 5000)), sys.get_int_max_str_digits() == before
(5001, True)
"""

from __future__ import annotations

import functools
import sys
import threading
from contextlib import contextmanager
from typing import Callable, Iterator, Optional, TypeVar

__all__ = ["MAX_DIGITS", "MAX_INT_BITS", "RECURSION_LIMIT", "DEEP", "long_integers", "deep_recursion",
           "read_int", "int_text", "deeply"]

#: Integers up to this many decimal digits are read and printed — every integer the engine
#: computes has fewer (powers are capped at 10**6 bits, about 301 030 digits); a longer
#: literal is refused with its place. Python's own default limit (4300) is raised to it
#: while the engine reads or prints one.
MAX_DIGITS = 310_000

#: The most bits an integer the engine computes may have (``*``, ``**``, PI, a card): a
#: larger result is refused before it is computed (about 301 030 digits, under MAX_DIGITS)
MAX_INT_BITS = 1_000_000

#: Formulas up to :data:`tracecheck.b.parser.MAX_DEPTH` levels take a few Python frames per
#: level to build, check and evaluate (all Python-level recursion, which does not grow the C
#: stack in Python 3.11+); the recursion limit is raised to this while they do.
RECURSION_LIMIT = 20_000

#: A formula nesting deeper than this is evaluated with the raised recursion limit.
DEEP = 100

F = TypeVar("F", bound=Callable)


class _Raised:
    """One interpreter setting raised while any caller needs it: the first to enter raises
    it, the last to leave restores what it was — so that threads (a vector environment's
    workers, a Ray worker's tasks) that need it at the same time do not restore it under
    each other. (A program that itself changes the setting meanwhile gets its value back
    when the last caller leaves.)"""

    def __init__(self, get: Callable[[], int], set_: Callable[[int], None], needed: int,
                 raise_when: Callable[[int], bool]) -> None:
        self.get, self.set, self.needed, self.raise_when = get, set_, needed, raise_when
        self.lock = threading.Lock()
        self.holders = 0
        self.old: Optional[int] = None

    @contextmanager
    def held(self) -> Iterator[None]:
        with self.lock:
            if self.holders == 0:
                old = self.get()
                self.old = old if self.raise_when(old) else None
                if self.old is not None:
                    self.set(self.needed)
            self.holders += 1
        try:
            yield
        finally:
            with self.lock:
                self.holders -= 1
                if self.holders == 0 and self.old is not None:
                    self.set(self.old)
                    self.old = None


_DIGITS = _Raised(sys.get_int_max_str_digits, sys.set_int_max_str_digits, MAX_DIGITS,
                  lambda old: 0 < old < MAX_DIGITS)
_RECURSION = _Raised(sys.getrecursionlimit, sys.setrecursionlimit, RECURSION_LIMIT,
                     lambda old: old < RECURSION_LIMIT)


def long_integers():
    """Inside: integers of up to :data:`MAX_DIGITS` digits convert to and from text."""
    return _DIGITS.held()


def deep_recursion():
    """Inside: Python may recurse :data:`RECURSION_LIMIT` frames deep."""
    return _RECURSION.held()


def read_int(text: str) -> int:
    """The integer written in ``text`` (a ``ValueError`` saying so above :data:`MAX_DIGITS`)."""
    if len(text) > MAX_DIGITS + 1:
        raise ValueError(f"an integer of {len(text.lstrip('-'))} digits is longer than the "
                         f"{MAX_DIGITS} digits tracecheck reads")
    try:
        return int(text)
    except ValueError:  # more digits than Python converts by default, or not an integer
        with long_integers():
            return int(text)


def int_text(n: int) -> str:
    """``str(n)``, for integers of up to :data:`MAX_DIGITS` digits."""
    try:
        return str(n)
    except ValueError:  # more digits than Python converts by default
        with long_integers():
            return str(n)


def deeply(fn: F) -> F:
    """``fn``, called with the raised recursion limit (for a deeply nested formula)."""
    @functools.wraps(fn)
    def call(*args, **kwargs):
        with deep_recursion():
            return fn(*args, **kwargs)
    return call  # type: ignore[return-value]
