"""Union, intersection and difference of sets that are not held element by element
(``NATURAL \\ {3}``, ``NAT \\/ {-1}``, ``(900..1100) /\\ {x | x > 1000}``): membership is
decided from the two sides, the elements are walked only where the result is finite and
small, and a side that is small is walked rather than the large one.

:func:`combine` gives the explicit set where that is cheap (both sides small, or the
intersection or difference of a small side), else a :class:`Combined` set.
"""

from __future__ import annotations

from typing import Any, Iterator, Optional

from ..errors import EvaluationError
from .values import (SET_LIMIT, SymbolicSet, cardinality, check_size, contains, finiteness,
                     format_value, make_set, members)

__all__ = ["Combined", "combine", "SYMBOLS"]

#: the operators :func:`combine` takes, with their Unicode symbol for printing
SYMBOLS = {"\\/": "∪", "/\\": "∩", "\\": "∖"}


def _small(s: Any) -> bool:
    if isinstance(s, frozenset):
        return True
    return finiteness(s) is True and cardinality(s) <= SET_LIMIT


def combine(op: str, a: Any, b: Any) -> Any:
    """``a op b`` for ``op`` one of ``\\/ /\\ \\``: explicit where a small side is enough to
    walk, else symbolic."""
    small_a, small_b = _small(a), _small(b)
    if op == "/\\" and (small_a or small_b):
        walk, other = (a, b) if small_a and (not small_b or cardinality(a) <= cardinality(b)) else (b, a)
        return make_set([x for x in members(walk) if contains(other, x)])
    if op == "\\" and small_a:
        return make_set([x for x in members(a) if not contains(b, x)])
    if op == "\\/" and small_a and small_b:
        return make_set(list(members(a)) + list(members(b)))
    return Combined(op, a, b)


class Combined(SymbolicSet):
    """``a op b`` held as its two sides."""

    def __init__(self, op: str, a: Any, b: Any) -> None:
        self.op, self.a, self.b = op, a, b

    @property
    def name(self) -> str:  # written out only for a message
        return f"({format_value(self.a)} {SYMBOLS[self.op]} {format_value(self.b)})"

    def contains(self, value: Any) -> bool:
        if self.op == "\\/":
            return contains(self.a, value) or contains(self.b, value)
        if self.op == "/\\":
            return contains(self.a, value) and contains(self.b, value)
        return contains(self.a, value) and not contains(self.b, value)

    def finiteness(self) -> Optional[bool]:
        fa, fb = finiteness(self.a), finiteness(self.b)
        if self.op == "\\/":
            return True if fa is True and fb is True else \
                False if fa is False or fb is False else None
        if self.op == "/\\":
            return True if fa is True or fb is True else None
        return True if fa is True else False if fa is False and fb is True else None

    def card(self) -> int:
        if self.finiteness() is not True:
            return SymbolicSet.card(self)
        a, b = self.a, self.b
        if self.op == "\\/":  # the large side counted, the small one walked
            big, small = (a, b) if _small(b) else (b, a)
            if not _small(small):
                raise EvaluationError(f"cannot count {self.name}: both sides are large")
            return cardinality(big) + sum(1 for x in members(small) if not contains(big, x))
        if self.op == "\\" and _small(b):
            return cardinality(a) - sum(1 for x in members(b) if contains(a, x))
        check_size(cardinality(self._walked()), self.name)  # the side walked: not too large
        return sum(1 for _ in self.elements())

    def _walked(self) -> Any:
        return self.a if finiteness(self.a) is True else self.b

    def elements(self) -> Iterator[Any]:
        if self.op == "\\/":
            yield from members(self.a)
            yield from (x for x in members(self.b) if not contains(self.a, x))
            return
        yield from (x for x in members(self._walked()) if self.contains(x))

    def key(self) -> tuple:
        return ("combined", self.op, _key(self.a), _key(self.b))


def _key(s: Any) -> Any:
    return s.key() if isinstance(s, SymbolicSet) else s
