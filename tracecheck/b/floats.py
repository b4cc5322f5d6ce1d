"""The floats in their own order, for searches that must not skip one: the float points of
an interval (its least and greatest float, how many there are, the k-th), the allowed float
nearest a refused one on a segment, and the floats next to a point. The evaluator computes
with floats, so "allowed over the reals" must still be confirmed float by float."""

from __future__ import annotations

import math
import struct
from typing import Callable, Optional, Sequence

__all__ = ["float_range", "float_count", "index", "from_index", "towards", "neighbour",
           "NUDGES", "DOUBLINGS"]


def float_range(i) -> Optional[tuple[float, float]]:
    """The least and the greatest float in ``i`` (None where an end is unbounded or beyond
    the floats; lowest above highest where no float lies in it)."""
    low, high = i._floats
    if not (math.isfinite(low) and math.isfinite(high)):
        return None
    if not i.contains(low):
        low = math.nextafter(low, math.inf)
    if not i.contains(high):
        high = math.nextafter(high, -math.inf)
    return low, high


def index(x: float) -> int:
    """The float's place in the order of all floats (0.0 and -0.0 both at 0)."""
    k = struct.unpack("<q", struct.pack("<d", x))[0]
    return k if k >= 0 else -(k & 0x7FFF_FFFF_FFFF_FFFF)


def from_index(k: int) -> float:
    """The float at place ``k`` of :func:`index`."""
    return struct.unpack("<d", struct.pack("<q", k if k >= 0 else (-k) | -(1 << 63)))[0]


def float_count(low: float, high: float) -> int:
    """How many floats lie from ``low`` to ``high`` (0 where ``low`` is above)."""
    return max(0, index(high) - index(low) + 1)


#: how many floats on either side of a point set :func:`neighbour` tries, and how many
#: doublings :func:`towards` takes before it halves
NUDGES = 4
DOUBLINGS = 12

Contains = Callable[[dict], bool]


def towards(contains: Contains, params: Sequence[str], refused: dict, allowed: dict) -> dict:
    """The point ``contains`` allows nearest ``refused`` on the segment to ``allowed``, to
    the float: steps doubling from one float away (the evaluator's rounding usually refuses
    only a few floats past a bound), then halving the rest in the floats' own order (at
    most 64 halvings, whatever the magnitudes)."""
    direction = {p: allowed[p] - refused[p] for p in params}

    def at(t: float) -> dict:
        return {p: refused[p] + t * direction[p] for p in params}
    moving = [p for p in params if direction[p] != 0.0]
    t = min(1.0, max([math.ulp(refused[p]) / abs(direction[p]) for p in moving]
                     + [math.ulp(0.0)]))
    lo = 0.0  # refused at lo, allowed at hi
    for _ in range(DOUBLINGS):
        if t >= 1.0 or contains(at(t)):
            break
        lo, t = t, min(1.0, 2.0 * t)
    else:
        t = 1.0
    hi = t

    def end(t: float) -> dict:  # at 1 the allowed point itself, not a rounding of it
        return dict(allowed) if t >= 1.0 else at(t)
    while True:
        mid = _float_between(lo, hi)
        low, high = at(lo), end(hi)
        if mid is None or all(math.nextafter(low[p], high[p]) == high[p]
                              or low[p] == high[p] for p in moving):
            return high
        if contains(at(mid)):
            hi = mid
        else:
            lo = mid


def neighbour(contains: Contains, params: Sequence[str], candidate: dict) -> Optional[dict]:
    """For a point set (``3.0 * a = 1.0``): the floats next to ``candidate`` that
    ``contains`` allows, nearest first."""
    for steps in range(1, NUDGES + 1):
        for direction in (-math.inf, math.inf):
            point = dict(candidate)
            for p in params:
                for _ in range(steps):
                    point[p] = math.nextafter(point[p], direction)
            if contains(point):
                return point
    return None


def _float_between(lo: float, hi: float) -> Optional[float]:
    """The float halfway between ``0 <= lo < hi`` in the order of floats (their bit
    patterns); None when they are next to each other."""
    a, b = (struct.unpack("<q", struct.pack("<d", x))[0] for x in (lo, hi))
    if b - a <= 1:
        return None
    return struct.unpack("<d", struct.pack("<q", (a + b) // 2))[0]
