"""The nearest point of a polytope, exactly: for guards whose constraints name several
parameters at once (``a + b <= Gap``), where the allowed set is not a union of boxes.

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

from fractions import Fraction
from itertools import combinations
from math import comb
from typing import Optional, Sequence

from ..errors import UnsupportedError

__all__ = ["nearest_in_polytope", "interior", "nearest_point", "distance_to",
           "MAX_SYSTEMS"]

#: the most active sets tried for one polytope
MAX_SYSTEMS = 20_000

Row = tuple[list[Fraction], Fraction, str]  # coefficients, constant, "<=" / "<" / "="


def nearest_in_polytope(rows: Sequence[Row], point: Sequence[Fraction]
                        ) -> Optional[list[Fraction]]:
    """The point of the closure of ``{x : a·x + c op 0 for each row}`` nearest ``point``
    (Euclidean), exactly; None when the polytope is empty."""
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
    """``point`` projected onto ``{x : a·x + c = 0}`` for the ``active`` rows: ``x = p -
    Aᵀ λ`` with ``(A Aᵀ) λ = A p + c``; None when the rows are dependent."""
    if not active:
        return list(point)
    a = [row[0] for row in active]
    rhs = [sum((ai * pi for ai, pi in zip(row, point)), c) for row, (_, c, _) in
           zip(a, active)]
    gram = [[sum((x * y for x, y in zip(r1, r2)), Fraction(0)) for r2 in a] for r1 in a]
    lam = _solve(gram, rhs)
    if lam is None:
        return None
    return [pi - sum((lj * row[i] for lj, row in zip(lam, a)), Fraction(0))
            for i, pi in enumerate(point)]


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
