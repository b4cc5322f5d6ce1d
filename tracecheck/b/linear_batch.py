"""How far recorded values of one REAL parameter lie from the allowed set, in many states at
once: the margins replay reports for a whole file.

:mod:`.linear` computes one state's allowed set exactly, with rationals; for the margin of
every infeasible step of a recording that costs a tenth of a millisecond per step. Here the
same disjunctive normal form is built over columns: what does not read the parameter is
evaluated by the batch evaluator (:mod:`.vector`), the linear forms are float arrays, and the
interval each polytope leaves is computed row by row in float arithmetic. A row is
*decided* only where that arithmetic cannot change the answer — every bound finite, no
interval narrower than the rounding, the point clearly outside — and its margin is then the
float distance (within a few units in the last place of the exact one); every other row is
left to the exact path. Only the margin is computed here: whether a step is allowed is the
guard's evaluation, never this.

The same division of work, for one state: :func:`nearest_active_set` finds in float
arithmetic, every candidate at once, which constraints of a polytope over two parameters
hold its nearest point to a given one; :func:`.polytope.nearest_in_polytope` verifies that
hint exactly (and tries every candidate in rationals where it fails).
"""

from __future__ import annotations

from typing import Callable, Optional

import numpy as np

from .cache import Cache
from ..errors import UnsupportedError
from . import ast

__all__ = ["batch_margins", "nearest_active_set"]

#: each operation's guard as a batch of linear forms in its parameter, once per machine
_BATCH_LINEAR: Cache = Cache("batch linear guards")

#: relative width below which a float interval, distance or bound is too close to call
TOLERANCE = 1e-9

Part = tuple  # (rows where the polytope applies, or None for all; [(coef, const, op)])
Form = tuple  # (coefficient of the parameter per row, constant per row)


def batch_margins(machine, op_name: str, cols, values: np.ndarray,
                  space: tuple[float, float] = (-np.inf, np.inf)
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For one-parameter ``op_name`` in the states of ``cols`` (one row per state) and the
    parameter's ``values`` (one per row): (distance to the allowed set over the reals
    within the action ``space``'s closed bounds, as floats; whether nothing is allowed
    there; which rows are decided). Rows not decided — and every row when the guard cannot
    be built here — are for :mod:`.linear`'s exact path."""
    n = cols.n
    none = (np.full(n, np.nan), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool))
    op = machine.operation(op_name)
    if len(op.params) != 1 or not n:
        return none
    try:
        build = machine.cached(_BATCH_LINEAR, op_name, lambda: _BatchLinearizer(
            op.params[0], machine).pred(op.guard, True))
    except UnsupportedError:
        return none
    with np.errstate(all="ignore"):
        try:
            parts = build(cols, {})
        except UnsupportedError:
            return none
        return _distances(parts, np.asarray(values, dtype=float), n, space)


def _distances(parts: list, x: np.ndarray, n: int,
               space: tuple[float, float] = (-np.inf, np.inf)):
    best = np.full(n, np.inf)
    some = np.zeros(n, dtype=bool)  # some polytope leaves values in the row
    unsure = ~np.isfinite(x)
    for mask, constraints in parts:
        low, high = np.full(n, -np.inf), np.full(n, np.inf)
        impossible = np.zeros(n, dtype=bool)
        for coef, const, op in constraints:
            coef, const = np.broadcast_to(coef, (n,)), np.broadcast_to(const, (n,))
            unsure |= ~np.isfinite(coef) | ~np.isfinite(const)
            flat = coef == 0
            impossible |= flat & ((const > 0) if op != "=" else (const != 0))
            unsure |= flat & (np.abs(const) <= TOLERANCE)  # a constant at zero: too close
            bound = -const / np.where(flat, 1.0, coef)
            upper = ~flat & ((coef > 0) | (op == "="))
            lower = ~flat & ((coef < 0) | (op == "="))
            high = np.where(upper, np.minimum(high, bound), high)
            low = np.where(lower, np.maximum(low, bound), low)
        low, high = np.maximum(low, space[0]), np.minimum(high, space[1])  # the space's
        applies = np.ones(n, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        scale = TOLERANCE * (1.0 + np.maximum(np.abs(np.where(np.isfinite(low), low, 0)),
                                              np.abs(np.where(np.isfinite(high), high, 0))))
        unsure |= applies & ~impossible & (np.abs(high - low) <= scale)  # (near) one point
        empty = impossible | (low > high) | ~applies
        gap = np.where(x < low, low - x, np.where(x > high, x - high, 0.0))
        unsure |= applies & ~empty & ((gap <= scale) | ~np.isfinite(gap))  # at a bound, huge
        best = np.where(empty, best, np.minimum(best, gap))
        some |= ~empty
    return np.where(some, best, np.nan), ~some, ~unsure


class _BatchLinearizer:
    """:class:`.linear._Linearizer` over columns, in float arithmetic (see the module
    docstring)."""

    def __init__(self, param: str, machine) -> None:
        self.param, self.machine = param, machine

    def free(self, node: ast.Node) -> bool:
        return self.param not in ast.free_names(node)

    def evaluated(self, node: ast.Node) -> Callable:
        formula = self.machine.batch(node)
        return lambda cols, memo: formula(cols, memo)

    def pred(self, node: ast.Node, positive: bool) -> Callable:
        if self.free(node):
            fn = self.evaluated(node)

            def truth(cols, memo):
                holds = np.asarray(fn(cols, memo), dtype=bool)
                return [(holds if positive else ~holds, [])]
            return truth
        if isinstance(node, (ast.And, ast.Or)):
            if isinstance(node, ast.And) == positive:
                return self.both(node.left, node.right, positive, positive)
            return self.either(node.left, node.right, positive, positive)
        if isinstance(node, ast.Not):
            return self.pred(node.operand, not positive)
        if isinstance(node, ast.Equiv):
            same = self.both(node.left, node.right, True, positive)
            other = self.both(node.left, node.right, False, not positive)
            return lambda cols, memo: same(cols, memo) + other(cols, memo)
        if isinstance(node, ast.Implies):
            if positive:
                return self.either(node.left, node.right, False, True)
            return self.both(node.left, node.right, True, False)
        if isinstance(node, ast.Rel):
            return self.relation(node, positive)
        raise UnsupportedError(f"a {type(node).__name__} over a parameter")

    def both(self, a, b, first: bool, second: bool) -> Callable:
        left, right = self.pred(a, first), self.pred(b, second)

        def product(cols, memo):
            out = []
            for mx, cx in left(cols, memo):
                for my, cy in right(cols, memo):
                    mask = mx if my is None else my if mx is None else mx & my
                    out.append((mask, cx + cy))
            if len(out) > 256:
                raise UnsupportedError("too many polytopes")
            return out
        return product

    def either(self, a, b, first: bool, second: bool) -> Callable:
        left, right = self.pred(a, first), self.pred(b, second)
        return lambda cols, memo: left(cols, memo) + right(cols, memo)

    def relation(self, node: ast.Rel, positive: bool) -> Callable:
        op = node.op
        if op == ":" and isinstance(node.left, ast.Name) and isinstance(node.right, ast.Name) \
                and node.right.id in ("REAL", "FLOAT"):
            return lambda cols, memo: [(None, [])] if positive else []
        if op not in ("<", "<=", ">", ">=", "=", "/="):
            raise UnsupportedError(f"the relation {op}")
        if not positive:
            op = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "=": "/=", "/=": "="}[op]
        left, right = self.expr(node.left), self.expr(node.right)

        def constraints(cols, memo):
            (lc, lk), (rc, rk) = left(cols, memo), right(cols, memo)
            coef, const = lc - rc, lk - rk  # left - right  op  0
            if op == "/=":
                return [(None, [(coef, const, "<")]), (None, [(-coef, -const, "<")])]
            if op in (">", ">="):
                return [(None, [(-coef, -const, "<=" if op == ">=" else "<")])]
            return [(None, [(coef, const, op)])]
        return constraints

    def expr(self, node: ast.Node) -> Callable:
        if self.free(node):
            fn = self.evaluated(node)
            return lambda cols, memo: (0.0, np.asarray(fn(cols, memo), dtype=float))
        if isinstance(node, ast.Name):
            return lambda cols, memo: (1.0, 0.0)
        if isinstance(node, ast.Neg):
            inner = self.expr(node.operand)
            return lambda cols, memo: tuple(-v for v in inner(cols, memo))
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            left, right = self.expr(node.left), self.expr(node.right)
            sign = 1.0 if node.op == "+" else -1.0
            return lambda cols, memo: _combine(left(cols, memo), right(cols, memo), sign)
        if isinstance(node, ast.BinOp) and node.op == "*" and (
                self.free(node.left) or self.free(node.right)):
            constant, varying = (node.left, node.right) if self.free(node.left) else \
                (node.right, node.left)
            k, form = self.expr(constant), self.expr(varying)
            return lambda cols, memo: _scaled(form(cols, memo), k(cols, memo)[1])
        if isinstance(node, ast.BinOp) and node.op == "/" and self.free(node.right):
            k, form = self.expr(node.right), self.expr(node.left)
            return lambda cols, memo: _scaled(form(cols, memo), 1.0 / k(cols, memo)[1])
        raise UnsupportedError(f"a {type(node).__name__} of a parameter")


def _combine(a: Form, b: Form, sign: float) -> Form:
    return a[0] + sign * b[0], a[1] + sign * b[1]


def _scaled(form: Form, k) -> Form:
    return form[0] * k, form[1] * k


def nearest_active_set(rows, point, required=()) -> Optional[tuple[int, ...]]:
    """The rows (indices) of ``rows`` (coefficients, constant, op: ``a·x + c op 0``, each
    naming a parameter) whose hyperplanes hold the point of the polytope's closure nearest
    ``point``, over at most two parameters, found in floats: the projection onto every set
    of at most two rows including ``required`` at once, the nearest that every row allows
    within :data:`TOLERANCE`. A hint, None where floats find none (or there are more
    parameters, or a number beyond the floats)."""
    k, m = len(point), len(rows)
    if k > 2 or not m:
        return None
    with np.errstate(all="ignore"):
        try:
            a = np.array([[float(x) for x in r[0]] for r in rows]).reshape(m, k)
            c = np.array([float(r[1]) for r in rows])
            p = np.array([float(x) for x in point])
        except OverflowError:
            return None
        if not (np.isfinite(a).all() and np.isfinite(c).all() and np.isfinite(p).all()):
            return None
        sets = [s for s in [()] + [(i,) for i in range(m)] + (
            [(i, j) for i in range(m) for j in range(i + 1, m)] if k == 2 else [])
            if set(required) <= set(s)]
        r = a @ p + c  # each row's value at the point
        g = a @ a.T  # the rows' Gram matrix
        x = np.empty((len(sets), k))
        for n, s in enumerate(sets):  # few: a Python loop, each a closed form
            if not s:
                x[n] = p
            elif len(s) == 1:
                x[n] = p - r[s[0]] / g[s[0], s[0]] * a[s[0]]
            else:
                i, j = s
                det = g[i, i] * g[j, j] - g[i, j] ** 2
                if not abs(det) > TOLERANCE * g[i, i] * g[j, j]:
                    x[n] = np.nan  # dependent, or nearly: left to the exact path
                    continue
                li, lj = (g[j, j] * r[i] - g[i, j] * r[j]) / det, \
                    (g[i, i] * r[j] - g[i, j] * r[i]) / det
                x[n] = p - li * a[i] - lj * a[j]
        values = x @ a.T + c
        slack = TOLERANCE * (1.0 + np.abs(x) @ np.abs(a).T + np.abs(c))
        equal = np.array([op == "=" for _, _, op in rows])
        ok = np.all(np.where(equal, np.abs(values), values) <= slack, axis=1)
        d = np.where(ok, np.sum((x - p) ** 2, axis=1), np.inf)
    best = int(np.argmin(d)) if len(d) else 0
    return sets[best] if len(d) and np.isfinite(d[best]) else None
