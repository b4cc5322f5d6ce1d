"""The allowed float point nearest a point, in a union of boxes (the allowed set of a guard
whose constraints each name one parameter): each box's nearest point over the reals, its
bounds rounded, confirmed by the evaluator — or, where its float arithmetic refuses that
point, the allowed float nearest it found by bisection towards a point it allows; the
floats of a box only a few wide tried one by one; "undecided" where none is found and
there are too many to try (never "nothing allowed" on a guess)."""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Iterator, Optional

from ..errors import UnsupportedError
from .floats import NUDGES, float_count, float_range, from_index, index, neighbour
from .polytope import clamp, exact, inner_point

__all__ = ["nearest_in_boxes", "scan_boxes", "confirmed", "distance_floor", "FLOAT_SCAN"]


def nearest_in_boxes(allowed, boxes: list[dict], point, scale=None) -> Optional[dict]:
    """:meth:`~tracecheck.b.linear.AllowedSet.nearest` for a union of ``boxes`` (intervals
    by parameter): in each the point nearest ``point``, its bounds rounded, or the allowed
    float nearest that (:func:`confirmed`); the nearest of those (the first box's at a
    tie). A box farther than the best point found cannot hold a nearer one: the boxes are
    taken nearest first, and the evaluator is not asked about points of the others."""
    if not boxes:
        return None
    params = allowed.params
    x = {p: float(point[p]) for p in params}
    s = {p: (scale or {}).get(p, 1.0) for p in params}
    floor = [distance_floor(box, x, s) for box in boxes]
    best, best_d, best_i = None, math.inf, len(boxes)
    for i in sorted(range(len(boxes)), key=lambda i: (floor[i], i)):
        if floor[i] > best_d:
            break
        box = boxes[i]
        candidate = confirmed(allowed, {p: clamp(x[p], box[p]) for p in params}, box)
        if candidate is None:
            continue
        d = sum(((candidate[p] - x[p]) / s[p]) * ((candidate[p] - x[p]) / s[p])
                for p in params)  # (a product: inf past the floats, no OverflowError)
        if best is None or d < best_d or (d == best_d and i < best_i):
            best, best_d, best_i = candidate, d, i
    if best is None:  # non-empty over the reals, yet no float tried was allowed
        return scan_boxes(allowed, boxes, x, s)
    return best


#: The most floats of one box tried one by one, where neither a point well inside it nor
#: its edges nor the floats next to them pass the evaluator, before tracecheck says it
#: cannot tell (a box of a few floats at the edge of an allowed set: its ends' roundings)
FLOAT_SCAN = 1 << 14


def scan_boxes(allowed, boxes: list[dict], x: dict, s: dict) -> Optional[dict]:
    """The allowed float point nearest ``x`` among the float points of ``boxes``: every
    float of each parameter whose interval holds few of them (:data:`FLOAT_SCAN` for all
    boxes together), a point well inside and the one nearest ``x`` for the others. None only
    where every box was searched whole and the evaluator allows none of its floats; raises
    :class:`UnsupportedError` where a box could not be searched whole and none of the
    points tried passed — non-empty over the reals, so "nothing allowed" would be a
    guess."""
    from itertools import product

    params = allowed.params
    best, best_d, whole, budget = None, None, True, FLOAT_SCAN  # for all boxes together
    at, scale = {p: exact(x[p], p) for p in params}, {p: Fraction(s[p]) for p in params}
    for box in boxes:
        ranges = {p: float_range(box[p]) for p in params}
        sizes = {p: float_count(*ranges[p]) if ranges[p] else math.inf for p in params}
        if 0 in sizes.values():  # no float lies in it: no float point of it to allow
            continue
        small = [p for p in params if sizes[p] <= budget]
        if math.prod(sizes[p] for p in small) > budget:
            small = []
        budget -= math.prod(sizes[p] for p in small)
        whole = whole and len(small) == len(params)
        axes = [[from_index(k) for k in range(index(ranges[p][0]), index(ranges[p][1]) + 1)]
                if p in small else
                sorted({inner_point(box[p], x[p]), clamp(x[p], box[p])}) for p in params]
        for values in product(*axes):
            point = dict(zip(params, values))
            d = sum(((Fraction(point[p]) - at[p]) / scale[p]) ** 2 for p in params)  # exact
            if (best_d is None or d < best_d) and allowed.contains(point):
                best, best_d = point, d
    if best is None and not whole:
        raise UnsupportedError(
            "undecided: the guard allows values over the reals (" + " ∪ ".join(
                " × ".join(str(box[p]) for p in params) for box in boxes) + "), but the "
            "evaluator's float arithmetic refuses every float point tracecheck tried, and "
            "there are too many to try them all")
    return best


def confirmed(allowed, candidate: dict, box: dict) -> Optional[dict]:
    """``candidate`` if the evaluator allows it, else the allowed float point nearest it on
    the way into the box (bisection: the evaluator's float arithmetic may refuse the exact
    boundary point) — towards a point well inside, moving first only the parameters whose
    float lies outside their interval over the reals (a bound rounded, an open end), then
    all of them; else towards a closed end of the box; the floats next to the point found
    taken while they are allowed and nearer; None if none is found (fail closed)."""
    if allowed.contains(candidate):
        return candidate
    params = allowed.params
    outside = [p for p in params if not box[p].contains(candidate[p])]
    for anchor in _anchors(box, candidate, outside):
        if anchor != candidate and allowed.contains(anchor):
            return _closer(allowed, allowed.towards(candidate, anchor), candidate)
    return neighbour(allowed.contains, params, candidate)


def _anchors(box: dict, candidate: dict, outside: list) -> Iterator[dict]:
    """Points of ``box`` to bisect towards from ``candidate``: a point well inside moving
    the parameters ``outside``, then moving all; then the box's closed ends, each with the
    other parameters clamped into the box (the nearest end first) — where the evaluator's
    rounding refuses the middle of a box a few floats wide (the allowed [0.0, 1.8e-15) of
    `15.000000000000002 - flow > 15.0` is 0.0 and the floats below 9e-16), an end it
    allows anchors the search. Every one lies in ``box``."""
    params = list(candidate)
    for moving in (outside, params):
        inner = dict(candidate)
        inner.update({p: inner_point(box[p], candidate[p]) for p in moving})
        yield inner
    inside = {p: clamp(candidate[p], box[p]) for p in params}
    ends = [(p, float(end)) for p in params
            for end, closed in ((box[p].low, not box[p].low_open),
                                (box[p].high, not box[p].high_open))
            if end is not None and closed]
    for p, end in sorted(ends, key=lambda e: abs(e[1] - candidate[e[0]])):
        yield dict(inside, **{p: end})


def _closer(allowed, found: dict, candidate: dict) -> dict:
    """``found`` moved float by float towards ``candidate`` while the evaluator allows it
    (bisection over the segment's fraction can stop a float short of the floats' own)."""
    for _ in range(NUDGES):
        step = {p: math.nextafter(v, candidate[p]) for p, v in found.items()}
        if step == found or not allowed.contains(step):
            break
        found = step
    return found


def distance_floor(box: dict, x: dict, scale: dict) -> float:
    """At most the squared distance, as :meth:`~tracecheck.b.linear.AllowedSet.nearest`
    computes it in floats (each parameter's divided by ``scale``), from the float point
    ``x`` to any point of ``box`` (intervals by parameter) or a few floats outside it: a
    box with a larger one cannot hold the nearest point. 0 where ``x`` is not finite, or
    a number overflows."""
    total = 0.0
    for p, interval in box.items():
        v = x[p]
        if not math.isfinite(v):
            return 0.0
        low, high = interval._floats
        g = low - v if v < low else v - high if v > high else 0.0
        if g > 0.0:  # less a margin far above every rounding on the way
            ends = [abs(e) for e in (low, high, v) if math.isfinite(e)]
            g = g * (1 - 1e-9) - 64 * math.ulp(max(ends))
            try:
                total += (g / scale[p]) ** 2 if g > 0.0 else 0.0
            except (ArithmeticError, TypeError):
                return 0.0
    return total * (1 - 1e-9)
