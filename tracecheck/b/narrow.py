"""An allowed point whose values an action space of a narrower float type can hold.

An environment whose action space is ``float32`` receives float32 values: a guard that
allows only ``r = 0.1`` allows nothing it can take (no float32 is 0.1). Where an allowed set
is cut to such a space (:meth:`~tracecheck.b.linear.AllowedSet.within` with the parameters'
float types), its witness must be a value of that type the evaluator confirms:

* the float64 witness itself where it is one;
* else the values of the type next to it, and in each box (a separable set) the least, the
  greatest and the middle value of the type in each parameter's interval — the first the
  evaluator confirms;
* none confirmed: "nothing allowed" where no value of the type lies in the set over the
  exact reals (each box has a parameter whose interval holds none — the rule by which a
  float64 set is empty), else *undecided*, never "nothing allowed" on a guess.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from typing import Iterator, Optional

import numpy as np

from ..errors import UnsupportedError

__all__ = ["narrow_witness", "NARROW"]

#: the float types narrower than a Python float an action space may take
NARROW = ("float16", "float32")


def narrow_witness(allowed, found: Optional[dict], floats: dict[str, str],
                   boxes: Optional[list[dict]]) -> Optional[dict]:
    """A point of ``allowed`` the evaluator confirms whose parameter ``p`` of ``floats``
    is a value of the type ``floats[p]`` (see the module docstring); ``found``: the float64
    witness (None: nothing is allowed over the reals); ``boxes``: a separable set's boxes
    (None for polytopes). Raises :class:`UnsupportedError` where it cannot tell."""
    if found is None:
        return None
    with np.errstate(over="ignore", invalid="ignore"):  # 4e38 is inf as a float32
        return _narrow(allowed, found, {p: np.dtype(t).type for p, t in floats.items()},
                       boxes)


def _narrow(allowed, found: dict, types: dict, boxes: Optional[list[dict]]
            ) -> Optional[dict]:
    """:func:`narrow_witness` with the types as numpy's scalar types."""
    def holds(point: dict) -> bool:
        return all(float(kind(point[p])) == point[p] for p, kind in types.items())
    if holds(found):
        return found
    tried = set()
    for point in _candidates(allowed.params, found, types, boxes or []):
        key = tuple(point[p] for p in allowed.params)
        if key not in tried and holds(point):
            tried.add(key)
            if allowed.contains(point):
                return point
    if boxes is not None and not any(
            all(_has_value(box[p], kind) for p, kind in types.items()) for box in boxes):
        return None
    names = ", ".join(sorted({np.dtype(t).name for t in types.values()}))
    raise UnsupportedError(
        f"undecided: the guard allows values over the reals, but tracecheck found no "
        f"{names} value (the action space's type) it accepts, nor can it say there is none")


def _candidates(params, found: dict, types: dict, boxes: list[dict]) -> Iterator[dict]:
    """The points tried: next to ``found``, then in each box — every combination of the
    parameters' values for up to 3 parameters (at most 27 points a box); beyond, the
    least of each, the greatest of each and the middle of each (3 points a box)."""
    around = [_next_to(found[p], types[p]) if p in types else (found[p],) for p in params]
    for values in itertools.product(*around) if len(params) <= 3 else \
            [[v[0] for v in around if v]] + [[v[-1] for v in around if v]]:
        if len(values) == len(params):
            yield dict(zip(params, values))
    for box in boxes:
        spans = [_ends(box[p], types[p], found[p]) if p in types else (found[p],)
                 for p in params]
        if len(params) <= 3:
            for values in itertools.product(*spans):
                yield dict(zip(params, values))
        elif all(spans):
            for k in range(3):
                yield {p: v[min(k, len(v) - 1)] for p, v in zip(params, spans)}


def _next_to(x: float, kind) -> tuple[float, ...]:
    """The values of the type ``kind`` next to ``x`` (x itself, if it is one)."""
    v = kind(x)
    if not np.isfinite(v):
        return ()
    if float(v) == x:
        return (x,)
    other = np.nextafter(v, kind(-np.inf if float(v) > x else np.inf))
    return tuple(float(w) for w in (v, other) if np.isfinite(w))


def _ends(interval, kind, x: float) -> tuple[float, ...]:
    """The least, the greatest and the middle value of the type ``kind`` in ``interval``
    (an unbounded end: the values next to ``x`` in it; none where it holds none)."""
    if interval.low is None or interval.high is None:  # the type's values near x, or at the
        top = float(np.finfo(kind).max)              # end of its range
        return tuple(v for v in _next_to(min(max(x, -top), top), kind)
                     if interval.contains(v))
    low, high = _edge(interval, kind, 1), _edge(interval, kind, -1)
    if low is None or high is None or low > high:
        return ()
    middle = [m for m in _next_to(low / 2 + high / 2, kind) if interval.contains(m)]
    return tuple(dict.fromkeys((low, high, *middle)))


def _edge(interval, kind, sign: int) -> Optional[float]:
    """The least (``sign`` 1) or the greatest (-1) value of the type ``kind`` on the inner
    side of the interval's low (high) end, which is bounded; None where the type has none
    there (the end lies beyond its range)."""
    end = interval.low if sign > 0 else interval.high
    inward, outward = kind(sign * np.inf), kind(-sign * np.inf)
    top = Fraction(float(np.finfo(kind).max))

    def inside(v) -> bool:  # on the inner side of the end
        order = (Fraction(float(v)) - end) * sign
        return order > 0 or (order == 0 and not (interval.low_open if sign > 0 else
                                                 interval.high_open))
    with np.errstate(over="ignore"):
        return _walk(kind(float(min(max(end, -top), top))), inside,
                     inward, outward)


def _walk(v, inside, inward, outward) -> Optional[float]:
    """From ``v`` (the type's value nearest the end) to the first value inside."""
    while not inside(v):  # a rounding off by a step or two, or the end past the range
        v = np.nextafter(v, inward)
        if not np.isfinite(v):
            return None
    while True:
        w = np.nextafter(v, outward)
        if not (np.isfinite(w) and inside(w)):
            return float(v)
        v = w


def _has_value(interval, kind) -> bool:
    """Whether some value of the type ``kind`` lies in ``interval``, exactly."""
    if interval.empty:
        return False
    if interval.low is None:
        return interval.high is None or _edge(interval, kind, -1) is not None
    low = _edge(interval, kind, 1)
    return low is not None and interval.contains(low)
