"""Sums of indicators of sets of reals, as piecewise-constant functions: the figures of
:mod:`.tuning` for every value of the tuned number at once.

Each set (:class:`~tracecheck.b.threshold.Values`) is given by its breakpoints; the sum over
many is constant between the breakpoints of all of them. One sweep over their union in order
(a difference array over the alternating points and open pieces) gives the sum on each: a
:class:`Piece` per open piece and per breakpoint, inside the range asked for, neighbours
with equal figures merged.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from fractions import Fraction
from typing import Optional

import math

import numpy as np

from ..b.threshold import Values, exact_text

__all__ = ["Figures", "Piece", "FrontPoint", "sweep", "counts", "front", "knee", "inside"]


@dataclass(frozen=True)
class Figures:
    """What replay would say with one value of the tuned number.

    Attributes:
        steps_blocked: recorded steps whose action the shield would block.
        episodes_blocked: episodes with such a step.
        crashes_after_blocked: crashes at or after an episode's first blocked step.
        deadlock_states: states where the shield allows nothing (None: not counted).
    """

    steps_blocked: int
    episodes_blocked: int
    crashes_after_blocked: int
    deadlock_states: Optional[int]


@dataclass(frozen=True)
class Piece:
    """The values ``low``..``high`` (each end in or out by ``low_closed``, ``high_closed``;
    one value where they are equal) and the figures on all of them."""

    low: Fraction
    high: Fraction
    low_closed: bool
    high_closed: bool
    figures: Figures
    #: the whole numbers low..high only (an INTEGER's values)
    whole: bool = False

    def contains(self, x: Fraction) -> bool:
        if self.whole and x.denominator != 1:
            return False
        return (self.low < x or (self.low_closed and x == self.low)) and \
            (x < self.high or (self.high_closed and x == self.high))

    def text(self) -> str:
        if self.whole:
            return str(self.low.numerator) if self.low == self.high else \
                f"{self.low.numerator}..{self.high.numerator}"
        if self.low == self.high:
            return exact_text(self.low)
        return (f"{'[' if self.low_closed else '('}{exact_text(self.low)}, {exact_text(self.high)}"
                f"{']' if self.high_closed else ')'}")



def counts(sets: Counter, points: list[Fraction]) -> np.ndarray:
    """For the sorted breakpoints ``points`` (a superset of every set's), the sum of
    ``sets``' indicators (each weighted by its count) on the 2 m + 1 positions: the open
    piece below ``points[0]``, ``points[0]``, the piece after it, …"""
    m = len(points)
    index = {p: i for i, p in enumerate(points)}
    diff = np.zeros(2 * m + 2, dtype=np.int64)
    for values, weight in sets.items():
        if not weight:
            continue
        g = [index[p] for p in values.points]
        q = len(g)
        for j, inside in enumerate(values.pieces):
            if inside:
                start = 0 if j == 0 else 2 * g[j - 1] + 2
                end = 2 * m if j == q else 2 * g[j]
                diff[start] += weight
                diff[end + 1] -= weight
        for j, inside in enumerate(values.at):
            if inside:
                diff[2 * g[j] + 1] += weight
                diff[2 * g[j] + 2] -= weight
    return np.cumsum(diff)[:2 * m + 1]


def sweep(tally, low: Fraction, high: Fraction, *, deadlocks: bool = True) -> list[Piece]:
    """The :class:`Piece` s of [``low``, ``high``] (see the module docstring) from a
    tally's four Counters of sets (steps, episodes, crashes, deadlocks)."""
    every = [tally.steps, tally.episodes, tally.crashes, tally.deadlocks]
    found = {p for c in every for v in c for p in v.points if low <= p <= high}
    points = sorted(found | {low, high})
    sums = [counts(_within(c, low, high), points) for c in every]
    pieces: list[Piece] = []
    m = len(points)
    for pos in range(1, 2 * m):  # from the point `low` to the point `high`
        k = pos // 2
        figures = Figures(*(int(s[pos]) for s in sums[:3]),
                          int(sums[3][pos]) if deadlocks else None)
        if pos % 2:  # the point points[k]
            piece = Piece(points[k], points[k], True, True, figures)
        else:  # the open piece between points[k - 1] and points[k]
            piece = Piece(points[k - 1], points[k], False, False, figures)
        if pieces and pieces[-1].figures == figures:
            last = pieces[-1]
            piece = Piece(last.low, piece.high, last.low_closed, piece.high_closed, figures)
            pieces[-1] = piece
        else:
            pieces.append(piece)
    return pieces


def whole_numbers(pieces: list[Piece]) -> list[Piece]:
    """The pieces of an INTEGER: the whole numbers in each (pieces without one dropped),
    neighbours with equal figures merged."""
    out: list[Piece] = []
    for p in pieces:
        lo = math.ceil(p.low) + (0 if p.low_closed or p.low.denominator != 1 else 1)
        hi = math.floor(p.high) - (0 if p.high_closed or p.high.denominator != 1 else 1)
        if lo > hi:
            continue
        if out and out[-1].figures == p.figures and out[-1].high + 1 == lo:
            out[-1] = Piece(out[-1].low, Fraction(hi), True, True, p.figures, True)
        else:
            out.append(Piece(Fraction(lo), Fraction(hi), True, True, p.figures, True))
    return out


def _within(sets: Counter, low: Fraction, high: Fraction) -> Counter:
    """Each set with the breakpoints outside [low, high] dropped (the membership inside the
    range kept): the sweep's points are only those inside."""
    out: Counter = Counter()
    for v, w in sets.items():
        if all(low <= p <= high for p in v.points):
            out[v] += w
            continue
        keep = [k for k, p in enumerate(v.points) if low <= p <= high]
        below = sum(1 for p in v.points if p < low)
        pieces = [v.pieces[below]] + [v.pieces[k + 1] for k in keep]
        out[Values(tuple(v.points[k] for k in keep), tuple(v.at[k] for k in keep),
                   tuple(pieces))] += w
    return out


@dataclass(frozen=True)
class FrontPoint:
    """One point of the Pareto front: no value of the tuned number blocks fewer steps
    without letting more crashes through unblocked, or lets fewer through without blocking
    more steps.

    Attributes:
        figures: the figures there.
        crashes_missed: crashes with no blocked step at or before them.
        pieces: the values that give these figures.
        value: one of them (inside the first piece): what ``--at knee`` re-simulates.
    """

    figures: Figures
    crashes_missed: int
    pieces: tuple[Piece, ...]
    value: float


def front(pieces: list[Piece], crashes: int) -> list[FrontPoint]:
    """The Pareto front of ``pieces`` (fewest steps blocked, fewest crashes missed), in
    order of steps blocked: the values of each point have the same figures (two points
    with the same two numbers differ in another figure)."""
    groups: dict[Figures, list[Piece]] = {}
    for p in pieces:
        groups.setdefault(p.figures, []).append(p)

    def pair(f: Figures) -> tuple[int, int]:
        return f.steps_blocked, crashes - f.crashes_after_blocked

    pairs = {pair(f) for f in groups}
    best = {(s, m) for s, m in pairs
            if not any(s2 <= s and m2 <= m and (s2, m2) != (s, m) for s2, m2 in pairs)}
    out = []
    for f, members in sorted(groups.items(), key=lambda kv: pair(kv[0])):
        value = next((v for v in map(inside, members) if v is not None), None)
        if pair(f) in best and value is not None:
            out.append(FrontPoint(f, pair(f)[1], tuple(members), value))
    return out


def inside(piece: Piece) -> Optional[float]:
    """A float in ``piece``: the value itself, else one well inside it (None: no float lies
    in it, a piece narrower than two floats)."""
    if piece.low == piece.high or piece.whole:
        return float(piece.low)
    for v in (float((piece.low + piece.high) / 2),
              math.nextafter(float(piece.low), math.inf),
              math.nextafter(float(piece.high), -math.inf)):
        if piece.contains(Fraction(v)):
            return v
    return None


def knee(points: list[FrontPoint]) -> Optional[FrontPoint]:
    """The front's knee: the point nearest the ideal (fewest steps blocked and fewest
    crashes missed of the front), each figure scaled by its spread along the front; of two
    as near, the one that misses fewer crashes."""
    if not points:
        return None
    steps = [p.figures.steps_blocked for p in points]
    missed = [p.crashes_missed for p in points]
    ds, dm = (max(steps) - min(steps)) or 1, (max(missed) - min(missed)) or 1
    return min(points, key=lambda p: (((p.figures.steps_blocked - min(steps)) / ds) ** 2
                                      + ((p.crashes_missed - min(missed)) / dm) ** 2,
                                      p.crashes_missed))  # a tie: the safer
