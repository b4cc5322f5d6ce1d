"""The interpreter limits the B engine needs, raised only while it needs them and restored
afterwards: how many decimal digits an integer may have when it is read or printed, and how
deep Python may recurse for a deeply nested formula. Importing tracecheck changes neither.

>>> import sys
>>> before = sys.get_int_max_str_digits()
>>> len(int_text(10 ** 5000)), sys.get_int_max_str_digits() == before
(5001, True)
"""

from __future__ import annotations

import sys
import functools
from contextlib import contextmanager
from typing import Callable, Iterator, TypeVar

__all__ = ["MAX_DIGITS", "RECURSION_LIMIT", "DEEP", "long_integers", "deep_recursion",
           "read_int", "int_text", "deeply"]

#: Integers up to this many decimal digits are read and printed — every integer the engine
#: computes has fewer (powers are capped at 10**6 bits, about 301 030 digits); a longer
#: literal is refused with its place. Python's own default limit (4300) is raised to it
#: while the engine reads or prints one.
MAX_DIGITS = 310_000

#: Formulas up to :data:`tracecheck.b.parser.MAX_DEPTH` levels take a few Python frames per
#: level to build, check and evaluate (all Python-level recursion, which does not grow the C
#: stack in Python 3.11+); the recursion limit is raised to this while they do.
RECURSION_LIMIT = 20_000

#: A formula nesting deeper than this is evaluated with the raised recursion limit.
DEEP = 100

F = TypeVar("F", bound=Callable)


@contextmanager
def long_integers() -> Iterator[None]:
    """Inside: integers of up to :data:`MAX_DIGITS` digits convert to and from text."""
    old = sys.get_int_max_str_digits()
    raise_ = 0 < old < MAX_DIGITS
    if raise_:
        sys.set_int_max_str_digits(MAX_DIGITS)
    try:
        yield
    finally:
        if raise_:
            sys.set_int_max_str_digits(old)


@contextmanager
def deep_recursion() -> Iterator[None]:
    """Inside: Python may recurse :data:`RECURSION_LIMIT` frames deep."""
    old = sys.getrecursionlimit()
    raise_ = old < RECURSION_LIMIT
    if raise_:
        sys.setrecursionlimit(RECURSION_LIMIT)
    try:
        yield
    finally:
        if raise_:
            sys.setrecursionlimit(old)


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
