"""The geometry of an allowed set (:mod:`.linear`): its constraints, exact; the interval
each parameter may take where every constraint names one parameter (a union of boxes); the
nearest point of a polytope where constraints name several at once (``a + b <= Gap``); and
the float point near either that the evaluator confirms.

Linear forms are kept as integers over a common denominator while they are built (a
Fraction normalises itself at every operation: that is what makes Fractions slow), and
made Fractions once, in the constraint. Intervals are exact (rational ends); comparing a
float with an end compares floats first (rounding is monotone: a float below the end's
rounding lies below the end) and exactly only a float equal to that rounding.

The nearest point of a closed convex polytope to a point ``p`` is the projection of ``p``
onto the affine hull of some set of its constraints taken as equalities (its *active* set,
at most as many as there are parameters, and linearly independent). So every such set is
tried — each a small linear system solved in rational arithmetic — and the nearest
projection that satisfies every constraint is the answer, exactly (a strict constraint is
taken as its closure; the caller confirms the float it executes with the evaluator). With
m constraints over k parameters that is Σ_{r ≤ k} C(m, r) systems: a few hundred for two
or three parameters, refused beyond :data:`MAX_SYSTEMS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property, lru_cache
from itertools import combinations
from math import comb, gcd
from typing import Any, Mapping, Optional, Sequence

from ..errors import UnsupportedError
from .floats import (DOUBLINGS, NUDGES, float_range, neighbour, towards)

__all__ = ["Constraint", "Form", "exact", "form_constant", "form_add", "form_times",
           "form_neg", "constraint_of", "bound_constraint", "box_constraints", "Interval",
           "interval_of", "box_of", "merge_intervals", "gap", "clamp", "inner_point", "towards",
           "neighbour", "nearest_in_polytope", "interior", "nearest_point", "distance_to",
           "MAX_SYSTEMS", "box_within", "NUDGES", "DOUBLINGS", "float_range"]


@dataclass(frozen=True)
class Constraint:
    """``Σ coeffs[p]·p + const  op  0`` with ``op`` one of ``<=``, ``<``, ``=``: one of the
    constraints whose conjunction is a polytope, exact."""

    coeffs: tuple[tuple[str, Fraction], ...]
    const: Fraction
    op: str

    def holds(self, point: Mapping[str, Fraction]) -> bool:
        value = sum((c * point[p] for p, c in self.coeffs), self.const)
        return value <= 0 if self.op == "<=" else value < 0 if self.op == "<" else value == 0

    @cached_property
    def limit(self) -> tuple[Fraction, float, bool]:
        """For one parameter, ``k·p + const op 0``: its bound ``-const / k``, that rounded
        (infinite beyond the floats), and whether it bounds ``p`` from above (``k > 0``)."""
        (_, k), = self.coeffs
        c = self.const
        return _limit(-c.numerator * k.denominator, c.denominator * k.numerator, k > 0)


def _limit(num: int, den: int, upper: bool) -> tuple[Fraction, float, bool]:
    """:attr:`Constraint.limit` for the bound ``num / den``."""
    try:
        rounded = num / den
    except OverflowError:
        rounded = math.inf if (num > 0) == (den > 0) else -math.inf
    return Fraction(num, den), rounded, upper


def exact(value: Any, what: str) -> Fraction:
    """``value`` (a number the engine computed) as the rational it is."""
    if isinstance(value, bool) or not isinstance(value, (int, float, Fraction)):
        raise UnsupportedError(f"{what} is not a number: {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise UnsupportedError(f"{what} is not finite: {value!r}")
    return Fraction(value)


#: a linear form over the parameters: (its numerators, one per parameter in a fixed order
#: and then the constant; their common denominator > 0). Exact integers: arithmetic on
#: them makes no Fraction (each one's normalisation is what makes Fractions slow)
Form = tuple


def form_constant(form: Form) -> Optional[tuple[int, int]]:
    """The form's value as (numerator, denominator) where no parameter's coefficient is
    other than 0, else None."""
    nums, den = form
    return None if any(nums[:-1]) else (nums[-1], den)


def form_add(a: Form, b: Form, sign: int = 1) -> Form:
    """``a + b`` (``a - b`` with ``sign`` -1)."""
    (na, da), (nb, db) = a, b
    if da == db:
        return tuple(x + sign * y for x, y in zip(na, nb)), da
    g = gcd(da, db)
    ma, mb = db // g, sign * (da // g)
    return tuple(x * ma + y * mb for x, y in zip(na, nb)), da * ma


def form_times(a: Form, k: tuple[int, int]) -> Form:
    """``a`` times the rational ``k[0] / k[1]`` (``k[1]`` not 0)."""
    n, d = k
    if d < 0:
        n, d = -n, -d
    return tuple(x * n for x in a[0]), a[1] * d


def form_neg(a: Form) -> Form:
    return tuple(-x for x in a[0]), a[1]


_ONE, _MINUS_ONE = Fraction(1), Fraction(-1)


def constraint_of(form: Form, op: str, order: Sequence[str]) -> Constraint:
    """``form op 0`` (the parameters of ``order``, in that order)."""
    nums, den = form
    coeffs = []
    for p, n in zip(order, nums):
        if n:
            coeffs.append((p, _ONE if n == den else _MINUS_ONE if n == -den else
                           Fraction(n, den)))
    c = Constraint(tuple(coeffs), Fraction(nums[-1], den), op)
    if len(coeffs) == 1:  # its limit, from the integers (kept where Constraint.limit keeps it)
        n = next(n for n in nums if n)
        c.__dict__["limit"] = _limit(-nums[-1], n, n > 0)
    return c


def bound_constraint(p: str, value: tuple[int, int], upper: bool, op: str) -> Constraint:
    """``p - v op 0`` (``upper``) or ``v - p op 0`` for the rational ``v`` (numerator,
    denominator > 0): what :func:`constraint_of` makes of that form."""
    n, d = value
    c = Constraint(((p, _ONE if upper else _MINUS_ONE),), Fraction(-n if upper else n, d), op)
    c.__dict__["limit"] = _limit(n, d, upper)
    return c


def box_constraints(params: Sequence[str], low: Mapping[str, Any], high: Mapping[str, Any]
                    ) -> tuple[Constraint, ...]:
    """``low[p] <= p <= high[p]`` for each parameter (none for a bound that is missing or
    infinite); the same bounds in every state: made once."""
    bounds = tuple((p, lo, hi, type(lo), type(hi)) for p in params
                   for lo, hi in [(low.get(p, _NONE), high.get(p, _NONE))])
    try:
        return _box_constraints(bounds)
    except TypeError:  # a bound that cannot be a key
        return _box_constraints.__wrapped__(bounds)


_NONE = object()


@lru_cache(maxsize=64)
def _box_constraints(bounds: tuple) -> tuple[Constraint, ...]:
    extra = []
    for p, low, high, *_ in bounds:
        if low is not _NONE and math.isfinite(low):
            extra.append(Constraint(((p, Fraction(-1)),), exact(low, p), "<="))
        if high is not _NONE and math.isfinite(high):
            extra.append(Constraint(((p, Fraction(1)),), -exact(high, p), "<="))
    return tuple(extra)


@dataclass(frozen=True)
class Interval:
    """A set of reals from ``low`` to ``high`` (None: unbounded), each end open or closed."""

    low: Optional[Fraction]
    high: Optional[Fraction]
    low_open: bool = False
    high_open: bool = False

    @cached_property
    def _floats(self) -> tuple[float, float]:
        """The ends rounded (monotone; beyond the floats' range: infinite)."""
        return (-math.inf if self.low is None else _rounded(self.low),
                math.inf if self.high is None else _rounded(self.high))

    @property
    def empty(self) -> bool:
        if self.low is None or self.high is None:
            return False
        low, high = self._floats
        if low != high:  # rounding is monotone: the ends are ordered as their roundings
            return low > high
        order = _order(self.low, self.high)
        return order > 0 or (order == 0 and (self.low_open or self.high_open))

    def contains(self, x: Any) -> bool:
        """Whether the number ``x`` (a Fraction, or a float) lies in the interval."""
        if type(x) is float:
            if not math.isfinite(x):
                x = Fraction(x)  # raises, as for any number that is not a real
            else:
                low, high = self._floats
                if low < x < high:
                    return True
                if x < low or x > high:
                    return False
                x = Fraction(x)  # at an end's rounding: exactly
        if self.low is not None and (x < self.low or (self.low_open and x == self.low)):
            return False
        return not (self.high is not None
                    and (x > self.high or (self.high_open and x == self.high)))

    def __str__(self) -> str:
        low = "-∞" if self.low is None else _number(self.low)
        high = "∞" if self.high is None else _number(self.high)
        if self.low is not None and self.low == self.high:
            return "{" + low + "}"
        return (f"{'(' if self.low_open or self.low is None else '['}{low}, {high}"
                f"{')' if self.high_open or self.high is None else ']'}")


def interval_of(part: Sequence) -> Interval:
    """The interval a conjunction of one-parameter constraints leaves (a constant constraint
    that fails empties it): their :attr:`Constraint.limit` compared as floats, and exactly
    where those are equal."""
    low = high = None
    flow = fhigh = 0.0
    low_open = high_open = False
    for c in part:
        if not c.coeffs:
            if not c.holds({}):
                return Interval(Fraction(1), Fraction(0))
            continue
        value, fvalue, upper = c.limit
        if c.op == "=":
            candidates = ((False, True), (False, False))
        else:  # k·x + const < / <= 0: an upper bound when k > 0, a lower one when k < 0
            candidates = ((c.op == "<", upper),)
        for is_open, up in candidates:  # the floats first, exactly where they are equal
            if up and (high is None or fvalue < fhigh or (fvalue == fhigh and (
                    (o := _order(value, high)) < 0 or (o == 0 and is_open)))):
                high, fhigh, high_open = value, fvalue, is_open
            if not up and (low is None or fvalue > flow or (fvalue == flow and (
                    (o := _order(value, low)) > 0 or (o == 0 and is_open)))):
                low, flow, low_open = value, fvalue, is_open
    interval = Interval(low, high, low_open, high_open)
    interval.__dict__["_floats"] = (-math.inf if low is None else flow,  # kept, as computed
                                    math.inf if high is None else fhigh)
    return interval


def box_of(part: Sequence, params: tuple[str, ...]) -> Optional[dict]:
    """Per parameter its interval, for a conjunction of one-parameter constraints."""
    constant: list = []
    named: dict[str, list] = {p: [] for p in params}
    for c in part:
        if len(c.coeffs) > 1:
            return None
        (named[c.coeffs[0][0]] if c.coeffs else constant).append(c)
    return {p: interval_of(constant + named[p]) for p in params}


def merge_intervals(pieces: list[Interval]) -> tuple[Interval, ...]:
    """Intervals as disjoint ones in increasing order."""
    def start(i: Interval):
        return (-math.inf if i.low is None else i.low, i.low_open)

    out: list[Interval] = []
    for i in sorted(pieces, key=start):
        if out and _touches(out[-1], i):
            last = out[-1]
            if last.high is None or (i.high is not None and (
                    i.high < last.high or (i.high == last.high and not last.high_open))):
                continue  # inside the last one
            out[-1] = Interval(last.low, i.high, last.low_open, i.high_open)
        else:
            out.append(i)
    return tuple(out)


def _touches(a: Interval, b: Interval) -> bool:
    """Whether ``b`` (starting at or after ``a``'s start) overlaps or adjoins ``a``."""
    if a.high is None or b.low is None:
        return True
    return b.low < a.high or (b.low == a.high and not (a.high_open and b.low_open))


def gap(x: Fraction, interval: Interval) -> Fraction:
    """How far ``x`` lies outside the closure of ``interval`` (0 inside)."""
    if interval.low is not None and x < interval.low:
        return interval.low - x
    if interval.high is not None and x > interval.high:
        return x - interval.high
    return Fraction(0)


def clamp(x: float, interval: Interval) -> float:
    """The float nearest ``x`` on ``interval`` over the reals (its bound rounded; the
    evaluator then confirms it, or a float next to it)."""
    if interval.contains(x):
        return x
    if interval.low is not None and x <= interval._floats[0] and \
            (x < interval._floats[0] or Fraction(x) <= interval.low):
        return float(interval.low)
    return float(interval.high)


def inner_point(i: Interval, x: float) -> float:
    """A point well inside ``i`` (its middle; a step past a lone bound), to bisect
    towards from ``x`` on its boundary."""
    if i.low is not None and i.high is not None:  # float((low + high) / 2), one division
        a, b = i.low, i.high
        return (a.numerator * b.denominator + b.numerator * a.denominator) / \
            (2 * a.denominator * b.denominator)
    if i.low is not None:
        return float(i.low) + max(1.0, abs(float(i.low)))
    if i.high is not None:
        return float(i.high) - max(1.0, abs(float(i.high)))
    return x


def _order(a: Fraction, b: Fraction) -> int:
    """The sign of ``a - b``, in integers (no Fraction made)."""
    x, y = a.numerator * b.denominator, b.numerator * a.denominator
    return (x > y) - (x < y)


def _rounded(value: Fraction) -> float:
    try:
        return value.numerator / value.denominator
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _number(value: Fraction) -> str:
    as_float = float(value)
    return repr(as_float) if Fraction(as_float) == value else f"{as_float!r}…"


#: the most active sets tried for one polytope
MAX_SYSTEMS = 20_000

Row = tuple[list[Fraction], Fraction, str]  # coefficients, constant, "<=" / "<" / "="


def nearest_in_polytope(rows: Sequence[Row], point: Sequence[Fraction]
                        ) -> Optional[list[Fraction]]:
    """The point of the closure of ``{x : a·x + c op 0 for each row}`` nearest ``point``
    (Euclidean), exactly; None when the polytope is empty. The active set that floats find
    (:func:`.linear_batch.nearest_active_set`) is taken where its projection ``x``
    satisfies every row and ``point - x`` is a non-negative combination of its inequalities'
    normals (the optimality conditions; the nearest point is unique: it is the one trying
    every active set in rationals gives); else every one is tried."""
    k = len(point)
    if any(not _holds(r, point) for r in rows if not any(r[0])):
        return None  # a constraint without a parameter that fails: empty
    rows = [r for r in rows if any(r[0])]
    equal = _independent([i for i, r in enumerate(rows) if r[2] == "="], rows)
    count = sum(comb(len(rows), r) for r in range(min(k, len(rows)) + 1))
    if count > MAX_SYSTEMS:
        raise UnsupportedError(f"projecting onto a polytope of {len(rows)} constraints over "
                               f"{k} parameters would try {count} active sets (at most "
                               f"{MAX_SYSTEMS})")
    from .linear_batch import nearest_active_set  # numpy: not for every machine loaded

    hint = nearest_active_set(rows, point, equal)
    solved = None if hint is None else _projection([rows[i] for i in hint], point)
    if solved is not None and all(_holds(row, solved[0]) for row in rows) and all(
            lam >= 0 for lam, i in zip(solved[1], hint) if rows[i][2] != "="):
        return solved[0]
    best: Optional[list[Fraction]] = None
    best_d: Optional[Fraction] = None
    for r in range(min(k, len(rows)) + 1):
        for active in combinations(range(len(rows)), r):
            if not set(equal) <= set(active):
                continue
            x = _project([rows[i] for i in active], point)
            if x is None or not all(_holds(row, x) for row in rows):
                continue
            d = sum(((xi - pi) ** 2 for xi, pi in zip(x, point)), Fraction(0))
            if best_d is None or d < best_d:
                best, best_d = x, d
    return best


def interior(rows: Sequence[Row], k: int) -> Optional[list[float]]:
    """A point well inside the polytope (its constraints' closure shifted inwards by as
    much as it allows, up to 1: the Chebyshev centre, by linear programming in floats),
    for an open boundary point to move towards; None when there is none. Only a hint: the
    evaluator confirms or refuses what it leads to."""
    from scipy.optimize import linprog

    rows = [r for r in rows if any(r[0])]
    if not rows:
        return [0.0] * k
    bounds = [r for r in rows if r[2] != "="]
    equal = [r for r in rows if r[2] == "="]
    a = [[float(x) for x in coef] + [sum(float(x) ** 2 for x in coef) ** 0.5]
         for coef, _, _ in bounds] or None
    b = [-float(c) for _, c, _ in bounds] or None
    result = linprog([0.0] * k + [-1.0], A_ub=a, b_ub=b,
                     A_eq=[[float(x) for x in coef] + [0.0] for coef, _, _ in equal] or None,
                     b_eq=[-float(c) for _, c, _ in equal] or None,
                     bounds=[(None, None)] * k + [(0.0, 1.0)], method="highs")
    if not result.success or (bounds and result.x[-1] <= 0):
        return None
    return [float(v) for v in result.x[:k]]


def _independent(which: list[int], rows: Sequence[Row]) -> list[int]:
    """The rows of ``which`` whose coefficients are linearly independent of those before
    them (a dependent equality is implied by the others, or contradicts them: either way
    the feasibility check of every candidate decides)."""
    kept: list[int] = []
    for i in which:
        if _project([rows[j] for j in kept] + [rows[i]], [Fraction(0)] * len(rows[i][0])) \
                is not None:
            kept.append(i)
    return kept


def _holds(row: Row, x: Sequence[Fraction]) -> bool:
    """The closure of the row's constraint at ``x``."""
    a, c, op = row
    value = sum((ai * xi for ai, xi in zip(a, x)), c)
    return value == 0 if op == "=" else value <= 0


def _project(active: list[Row], point: Sequence[Fraction]) -> Optional[list[Fraction]]:
    """``point`` projected onto ``{x : a·x + c = 0}`` for the ``active`` rows; None when
    the rows are dependent."""
    solved = _projection(active, point)
    return None if solved is None else solved[0]


def _projection(active: list[Row], point: Sequence[Fraction]):
    """(``x = p - Aᵀ λ``, ``λ``) with ``(A Aᵀ) λ = A p + c``; None for dependent rows."""
    if not active:
        return list(point), []
    a = [row[0] for row in active]
    rhs = [sum((ai * pi for ai, pi in zip(row, point)), c) for row, (_, c, _) in
           zip(a, active)]
    gram = [[sum((x * y for x, y in zip(r1, r2)), Fraction(0)) for r2 in a] for r1 in a]
    lam = _solve(gram, rhs)
    if lam is None:
        return None
    return [pi - sum((lj * row[i] for lj, row in zip(lam, a)), Fraction(0))
            for i, pi in enumerate(point)], lam


def _solve(m: list[list[Fraction]], b: list[Fraction]) -> Optional[list[Fraction]]:
    """Gaussian elimination in rationals; None for a singular ``m``."""
    n = len(b)
    aug = [row[:] + [b[i]] for i, row in enumerate(m)]
    for col in range(n):
        pivot = next((r for r in range(col, n) if aug[r][col] != 0), None)
        if pivot is None:
            return None
        aug[col], aug[pivot] = aug[pivot], aug[col]
        for r in range(n):
            if r != col and aug[r][col] != 0:
                f = aug[r][col] / aug[col][col]
                aug[r] = [x - f * y for x, y in zip(aug[r], aug[col])]
    return [aug[i][n] / aug[i][i] for i in range(n)]


def _rows(part, params: Sequence[str], scale: Sequence[float]) -> list[Row]:
    """One polytope's constraints (:class:`~tracecheck.b.linear.Constraint`) as rows over
    the parameters divided by their ``scale``."""
    out = []
    for c in part:
        coeffs = dict(c.coeffs)
        out.append(([coeffs.get(p, Fraction(0)) * Fraction(s) for p, s in zip(params, scale)],
                     c.const, c.op))
    return out


def nearest_point(allowed, point, scale=None) -> Optional[dict[str, float]]:
    """:meth:`~tracecheck.b.linear.AllowedSet.nearest` for polytopes that are not boxes:
    each one's nearest point, exactly, then the float the evaluator allows (moved towards
    a point well inside where the exact point lies on an open face); None when none is
    confirmed."""
    params = allowed.params
    s = [float((scale or {}).get(p, 1.0)) for p in params]
    target = [Fraction(float(point[p])) / Fraction(k) for p, k in zip(params, s)]
    best, best_d = None, None
    for part in allowed.parts:
        rows = _rows(part, params, s)
        q = nearest_in_polytope(rows, target)
        if q is None:
            continue
        candidate = {p: float(y * Fraction(k)) for p, y, k in zip(params, q, s)}
        if not allowed.contains(candidate):
            centre = interior(rows, len(params))
            inner = None if centre is None else {p: y * k for p, y, k in zip(params, centre, s)}
            if inner is None or not allowed.contains(inner):
                continue  # none confirmed: fail closed
            candidate = allowed.towards(candidate, inner)
        d = sum(((candidate[p] - float(point[p])) / k) ** 2 for p, k in zip(params, s))
        if best_d is None or d < best_d:
            best, best_d = candidate, d
    return best


def distance_to(allowed, point) -> Optional[float]:
    """:meth:`~tracecheck.b.linear.AllowedSet.distance` for polytopes that are not boxes."""
    params = allowed.params
    target = [Fraction(float(point[p])) for p in params]
    best: Optional[Fraction] = None
    for part in allowed.parts:
        q = nearest_in_polytope(_rows(part, params, [1.0] * len(params)), target)
        if q is not None:
            d = sum(((x - y) ** 2 for x, y in zip(q, target)), Fraction(0))
            best = d if best is None or d < best else best
    return None if best is None else float(best) ** 0.5


def box_within(inner: dict, outer: dict, params) -> bool:
    """Whether the box ``inner`` lies in the box ``outer`` (open and closed ends alike)."""
    return all(_interval_within(inner[p], outer[p]) for p in params)


def _interval_within(a, b) -> bool:
    low = b.low is None or (a.low is not None and (
        a.low > b.low or (a.low == b.low and (a.low_open or not b.low_open))))
    high = b.high is None or (a.high is not None and (
        a.high < b.high or (a.high == b.high and (a.high_open or not b.high_open))))
    return low and high
