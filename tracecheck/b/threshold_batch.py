"""The values of a tuned number for which a guard holds, in many states at once: the batch path
of :mod:`.threshold`, which gives the same :class:`~.threshold.Values` for every state it
decides and leaves the others to the exact path.

In one state a guard linear in the number θ is a Boolean combination of relations
``a θ + b  op  0`` (one per relation and element of a quantifier's set); its set of values
changes only at their roots. Here, for a block of states: every relation's coefficients are
computed over columns (what does not read θ by the batch evaluator, :mod:`.vector`), the roots
sorted, and the guard evaluated — as a plain predicate, quantifiers as reductions along the
element axes — at every root and at a point between each two and beyond them. The truths at
those test points are the set; the breakpoints where it changes are then computed exactly,
with rationals, by the exact path's own formulas, in that state alone.

A state is *decided* here only where float arithmetic cannot have changed an answer: at every
test point every relation (but the one whose root it is) is farther from zero than
:data:`TOLERANCE` times the size of the terms it adds up, every coefficient of θ is clearly
non-zero or exactly zero, each root lies between the test points beside it (the relation has
the opposite sign there), and no term is ill-defined or infinite. Every other state — and every
state of a guard this path cannot take (more than two nested quantifiers over θ, sets that are
not masks of elements) — is computed by the exact path, which also gives its refusals.
"""

from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Optional

import numpy as np

from . import ast
from .arrays import NotVectorizable, bool_of, num_of
from .bindings import conjuncts
from .columns import Columns
from .threshold import Values
from .vector import BoundFormulas

__all__ = ["ThresholdBatch", "TOLERANCE"]

#: relative distance from zero below which a relation's value is too close to call
TOLERANCE = 1e-9
#: the most cells (states × elements × test points) of the arrays computed together
_CELLS = 4_000_000
_TYPES = {"REAL": None, "FLOAT": None, "INTEGER": None, "NATURAL": 0, "NATURAL1": 1}
_ALL, _NONE = Values.everything(), Values.nothing()
_Q0, _Q1 = (0, 1), (1, 1)  # rationals as (numerator, denominator): see _symbolic
_CLOSED = {"<": False, "<=": True, ">": False, ">=": True, "=": True, "/=": False}


@dataclass(frozen=True)
class _Relation:
    """``a θ + b  op  0`` under the element variables ``bound``: its batch coefficients (with
    the size of the terms each adds up) and its exact ones, from its terms' values in one
    state and element."""

    op: str
    bound: tuple[str, ...]
    batch: Callable  # (formulas) -> (a, b, size of a's terms, size of b's terms)
    exact: Callable  # (the value of a term there) -> (a, b) as rationals


class ThresholdBatch:
    """The guards of a machine compiled for the batch path together (see the module
    docstring): their relations' roots are found once for all of them.

    Args:
        machine: the machine.
        param: the name the tuned number goes by in the guards.
        guards: each operation's guard (with the number as ``param``), ones the exact path
            compiles; a guard of a shape this path does not take is left out (:attr:`ops`).
        integer: the number is an INTEGER.
    """

    def __init__(self, machine, param: str, guards: dict[str, ast.Node],
                 integer: bool = False) -> None:
        self.machine, self.param = machine, param
        self.integer = integer
        self.relations: list[_Relation] = []
        self._index: dict = {}
        self._free: dict = {}
        self._plans: dict[str, Callable] = {}
        self._users: dict[int, set[str]] = {}  # the operations each relation is of
        for op, guard in guards.items():
            before = len(self.relations)
            self._op = op
            try:
                self._plans[op] = self._pred(guard, ())
            except NotVectorizable:  # its relations are not wanted: taken back
                del self.relations[before:]
                self._index = {k: v for k, v in self._index.items() if v < before}
                self._users = {k: v - {op} for k, v in self._users.items() if k < before}

    @property
    def ops(self) -> list[str]:
        """The operations whose guards this path takes (one whose shape shows only in a
        state, a quantifier over numbers, is left out from then on)."""
        return list(self._plans)

    def sets(self, cols: Columns) -> dict[str, list[Optional[Values]]]:
        """For each of :attr:`ops`, the values for which its guard holds in each row of
        ``cols``, None where this path does not decide."""
        out: dict[str, list[Optional[Values]]] = {op: [None] * cols.n for op in self._plans}
        if not self._plans or not cols.n:
            return out
        e = max(1, len(cols.elements))
        width = sum(e ** len(r.bound) for r in self.relations)
        deepest = max([e ** len(r.bound) for r in self.relations], default=1)
        chunk = max(16, min(cols.n, _CELLS // (deepest * (2 * width + 1))))
        for lo in range(0, cols.n, chunk):
            rows = np.arange(lo, min(lo + chunk, cols.n))
            part = cols.take(rows) if len(rows) < cols.n else cols
            try:
                self._chunk(part, out, lo)
            except (NotVectorizable, OverflowError, TypeError, ValueError):
                continue
        return out

    # -- compiling -------------------------------------------------------------------------

    def free(self, node: ast.Node) -> bool:
        return self.param not in ast.free_names(node, self._free)

    def _pred(self, node: ast.Node, bound: tuple[str, ...]) -> Callable:
        """A function of (formulas, test points) to the truth at each, shaped (rows,
        elements, elements, points) or broadcastable to it."""
        if self.free(node):
            def truth(f, t, _node=node, _bound=bound):
                return np.asarray(bool_of(f.compile(_node, _bound)()))[..., None]
            return truth
        if isinstance(node, ast.And):
            parts = [self._pred(c, bound) for c in conjuncts(node)]

            def every(f, t):
                out = parts[0](f, t)
                for p in parts[1:]:
                    out = out & p(f, t)
                return out
            return every
        if isinstance(node, (ast.Or, ast.Implies, ast.Equiv)):
            a, b = self._pred(node.left, bound), self._pred(node.right, bound)
            if isinstance(node, ast.Or):
                return lambda f, t: a(f, t) | b(f, t)
            if isinstance(node, ast.Implies):
                return lambda f, t: ~a(f, t) | b(f, t)
            return lambda f, t: a(f, t) == b(f, t)
        if isinstance(node, ast.Not):
            a = self._pred(node.operand, bound)
            return lambda f, t: ~a(f, t)
        if isinstance(node, ast.Rel):
            return self._relation(node, bound)
        if isinstance(node, ast.Quant):
            return self._quantifier(node, bound)
        raise NotVectorizable(type(node).__name__)

    def _relation(self, node: ast.Rel, bound: tuple[str, ...]) -> Callable:
        op = node.op
        if op == ":" and isinstance(node.left, ast.Name) and self.free(node.right):
            return self._membership(node, bound)
        if op in (":", "/:") and isinstance(node.right, ast.BinOp) and node.right.op == "..":
            value, lo, hi = node.left, node.right.left, node.right.right
            low = self._register(lo, value, "<=", bound)  # lo - e <= 0
            high = self._register(value, hi, "<=", bound)  # e - hi <= 0
            if op == ":":
                return lambda f, t: low(f, t) & high(f, t)
            return lambda f, t: ~(low(f, t) & high(f, t))
        if op not in _CLOSED:
            raise NotVectorizable(f"the relation {op}")
        return self._register(node.left, node.right, op, bound)

    def _membership(self, node: ast.Rel, bound: tuple[str, ...]) -> Callable:
        right = node.right
        if isinstance(right, ast.Name) and right.id in _TYPES:
            low = _TYPES[right.id]
            if low is None:
                return lambda f, t: np.ones((1, 1, 1, 1), dtype=bool)
            return self._register(node.left, ast.IntLit(low), ">=", bound)
        if isinstance(right, ast.BinOp) and right.op == "..":
            low = self._register(node.left, right.left, ">=", bound)
            high = self._register(node.left, right.right, "<=", bound)
            return lambda f, t: low(f, t) & high(f, t)
        raise NotVectorizable("a membership")

    def _register(self, left: ast.Node, right: ast.Node, op: str,
                  bound: tuple[str, ...]) -> Callable:
        """The relation ``left op right`` (one entry for equal ones in the same scope)."""
        key = (left, right, op, bound)
        k = self._index.get(key)
        if k is None:
            k = self._index[key] = len(self.relations)
            lf, rf = self._form(left, bound), self._form(right, bound)
            le, re = self._symbolic(left), self._symbolic(right)

            def batch(f, lf=lf, rf=rf):
                (a1, b1, ma1, mb1), (a2, b2, ma2, mb2) = lf(f), rf(f)
                return a1 - a2, b1 - b2, ma1 + ma2, mb1 + mb2

            def exact(get, le=le, re=re):
                (a1, b1), (a2, b2) = le(get), re(get)
                return _q_add(a1, a2, -1), _q_add(b1, b2, -1)
            self.relations.append(_Relation(op, bound, batch, exact))
        self._users.setdefault(k, set()).add(self._op)
        return lambda f, t: t.truth[k]

    def _form(self, node: ast.Node, bound: tuple[str, ...]) -> Callable:
        """A function of the formulas to (a, b, size of a's terms, size of b's terms)."""
        if self.free(node):
            def number(f, _node=node):
                x = np.asarray(num_of(f.compile(_node, bound)()), dtype=float)
                return 0.0, x, 0.0, np.abs(x)
            return number
        if isinstance(node, ast.Name):
            return lambda f: (1.0, 0.0, 1.0, 0.0)
        if isinstance(node, ast.Neg):
            a = self._form(node.operand, bound)
            return lambda f: _negated(a(f))
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            a, b = self._form(node.left, bound), self._form(node.right, bound)
            sign = 1.0 if node.op == "+" else -1.0
            return lambda f: _sum(a(f), b(f), sign)
        if isinstance(node, ast.BinOp) and node.op == "*" and (
                self.free(node.left) != self.free(node.right)):
            k_node, x_node = (node.left, node.right) if self.free(node.left) else \
                (node.right, node.left)
            k, x = self._form(k_node, bound), self._form(x_node, bound)
            return lambda f: _scaled(x(f), k(f)[1], False)
        if isinstance(node, ast.BinOp) and node.op == "/" and self.free(node.right) \
                and not self.integer:
            k, x = self._form(node.right, bound), self._form(node.left, bound)
            return lambda f: _scaled(x(f), k(f)[1], True)
        if isinstance(node, ast.IfExpr) and all(self.free(c) for c, _ in node.branches):
            conds = [c for c, _ in node.branches]
            forms = [self._form(v, bound) for _, v in node.branches] + \
                [self._form(node.else_, bound)]

            def chosen(f):
                out = forms[-1](f)
                for c, form in zip(reversed(conds), reversed(forms[:-1])):
                    pick = np.asarray(bool_of(f.compile(c, bound)()))
                    out = tuple(np.where(pick, x, y) for x, y in zip(form(f), out))
                return out
            return chosen
        raise NotVectorizable(type(node).__name__)

    def _symbolic(self, node: ast.Node) -> Callable:
        """``node`` as :meth:`.ThresholdCompiler.expr` makes it: a function of the values
        of its terms (``get(term)``, the very numbers the exact path's engine computes) to
        (a, b), each an exact rational as a pair of integers (numerator, denominator, not
        reduced); a division by zero raises ZeroDivisionError."""
        if self.free(node):
            return lambda get: (_Q0, _ratio(get(node)))
        if isinstance(node, ast.Name):
            return lambda get: (_Q1, _Q0)
        if isinstance(node, ast.Neg):
            a = self._symbolic(node.operand)
            return lambda get: tuple((-n, d) for n, d in a(get))
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            a, b = self._symbolic(node.left), self._symbolic(node.right)
            sign = 1 if node.op == "+" else -1
            return lambda get: tuple(_q_add(x, y, sign) for x, y in zip(a(get), b(get)))
        if isinstance(node, ast.BinOp) and node.op == "*":
            k, x = (node.left, node.right) if self.free(node.left) else (node.right, node.left)
            form = self._symbolic(x)

            def times(get):
                kn, kd = _ratio(get(k))
                return tuple((n * kn, d * kd) for n, d in form(get))
            return times
        if isinstance(node, ast.BinOp) and node.op == "/":
            form = self._symbolic(node.left)

            def divided(get):
                kn, kd = _ratio(get(node.right))
                if kn == 0:
                    raise ZeroDivisionError
                return tuple((n * kd, d * kn) for n, d in form(get))
            return divided
        if isinstance(node, ast.IfExpr):
            conds = [c for c, _ in node.branches]
            forms = [self._symbolic(v) for _, v in node.branches] + \
                [self._symbolic(node.else_)]

            def chosen(get):
                for c, form in zip(conds, forms):
                    if get(c):
                        return form(get)
                return forms[-1](get)
            return chosen
        raise NotVectorizable(type(node).__name__)

    def _quantifier(self, node: ast.Quant, bound: tuple[str, ...]) -> Callable:
        if len(node.ids) != 1 or len(bound) >= 2 or self.param in node.ids:
            raise NotVectorizable("quantifier shape")
        var = node.ids[0]
        body = node.body
        forall = node.op == "!"
        if forall and not isinstance(body, ast.Implies):
            raise NotVectorizable("a ∀ without =>")
        given, rest = (body.left, body.right) if forall else (body, None)
        conjs = conjuncts(given)
        gen = next((c for c in conjs if isinstance(c, ast.Rel) and c.op == ":"
                    and isinstance(c.left, ast.Name) and c.left.id == var
                    and var not in ast.free_names(c.right) and self.free(c.right)), None)
        if gen is None:
            raise NotVectorizable("no domain")
        inner = bound + (var,)
        parts = [self._pred(c, inner) for c in conjs if c is not gen]
        then = self._pred(rest, inner) if forall else None
        axis = 1 + len(bound)

        def quant(f, t):
            tag, mask = f.compile(gen.right, bound)()
            if tag != "set" or np.ndim(mask) != 2:
                raise NotVectorizable("domain")
            mask = (mask[:, :, None] if axis == 1 else mask[:, None, :])[..., None]
            reach = np.ones((1, 1, 1, 1), dtype=bool)
            for p in parts:
                reach = reach & p(f, t)
            if forall:
                return np.all(~reach | then(f, t) | ~mask, axis=axis, keepdims=True)
            return np.any(reach & mask, axis=axis, keepdims=True)
        return quant

    # -- evaluating ------------------------------------------------------------------------

    def _chunk(self, cols: Columns, out: dict, offset: int) -> None:
        """The sets of the rows of ``cols`` this path decides, into ``out`` from ``offset``."""
        n = cols.n
        f = BoundFormulas(self.machine.base_env, cols)
        with np.errstate(all="ignore"):
            forms = []
            for k, r in enumerate(self.relations):
                try:
                    forms.append(r.batch(f) if self._users[k] & set(self._plans) else None)
                except NotVectorizable:  # a shape seen only now: its operations left out
                    forms.append(None)
                    for op in self._users[k]:
                        self._plans.pop(op, None)
            points = _TestPoints(n, forms, self.relations, f)
            if points.unsure.all():
                return
            tops = {}
            for op, plan in list(self._plans.items()):
                try:
                    tops[op] = np.broadcast_to(plan(f, points), (n, 1, 1, points.p))[:, 0, 0]
                except NotVectorizable:  # a shape seen only now (a set of numbers): left out
                    del self._plans[op]
        unsure = points.unsure.copy()
        if f.bad is not None:
            unsure |= np.broadcast_to(f.bad, (n,))
        c = points.sorted.shape[1]
        # roots equal in floats are one test point: only where they are equal exactly too
        # (else the set may change between them, where no point was tested)
        group = points.group
        shared = (group[:, 1:] == group[:, :-1]) & (group[:, 1:] < c) & ~unsure[:, None]
        for i, k in zip(*(a.tolist() for a in np.nonzero(shared))):
            if points.root(i, int(group[i, k])) is None:
                unsure[i] = True
        valid = (np.arange(c)[None, :] < points.count[:, None]) & ~unsure[:, None]
        for op, top in tops.items():
            pieces, at = top[:, 0::2], top[:, 1::2][:, :c]
            change = valid & ~((at == pieces[:, :-1]) & (at == pieces[:, 1:]))
            first = pieces[:, 0].tolist()
            target = out[op]
            for i in np.flatnonzero(~unsure & ~change.any(axis=1)).tolist():
                target[offset + i] = _ALL if first[i] else _NONE
            rows, js = np.nonzero(change)  # the breakpoints where the set changes, row by row
            at_js = at[rows, js].tolist()
            after = pieces[rows, js + 1].tolist()
            rows, js = rows.tolist(), js.tolist()
            k = 0
            while k < len(rows):
                i, end = rows[k], k
                while end < len(rows) and rows[end] == i:
                    end += 1
                exact = [points.root(i, j) for j in js[k:end]]
                if None not in exact and all(x < y for x, y in zip(exact, exact[1:])):
                    target[offset + i] = Values(tuple(exact), tuple(at_js[k:end]),
                                                (first[i],) + tuple(after[k:end]))
                k = end


class _TestPoints:
    """The roots of a block's relations sorted per row, the test points around them, and
    each relation's truth at each (``truth[k]``: rows, elements, elements, points)."""

    def __init__(self, n: int, forms: list, relations: list[_Relation],
                 formulas: BoundFormulas) -> None:
        self.n, self.relations, self.formulas = n, relations, formulas
        self.terms: dict[tuple, Any] = {}  # each term's values, computed once
        self._rows: Optional[tuple] = None
        self._roots: dict[tuple[int, int], Optional[Fraction]] = {}
        self.unsure = np.zeros(n, dtype=bool)
        shaped, roots, owners = [], [], []
        for k, form in enumerate(forms):
            if form is None:  # a relation of no operation taken
                shaped.append(None)
                roots.append(np.zeros((n, 0)))
                continue
            a, b, ma, mb = form
            a, b, ma, mb = (np.broadcast_to(np.asarray(x, dtype=float), (n, 1, 1))
                            if np.ndim(x) == 0 else _rows3(x, n) for x in (a, b, ma, mb))
            shape = np.broadcast_shapes(a.shape, b.shape, ma.shape, mb.shape)
            a, b, ma, mb = (np.broadcast_to(x, shape) for x in (a, b, ma, mb))
            bad = ~(np.isfinite(a) & np.isfinite(b) & np.isfinite(ma) & np.isfinite(mb))
            flat = np.abs(a) <= TOLERANCE * ma  # zero, or too close to tell
            bad |= flat & (ma > 0)
            self.unsure |= bad.reshape(n, -1).any(axis=1)
            root = np.where(flat | bad, np.nan, -b / np.where(flat, 1.0, a))
            shaped.append((a, b, ma, mb))
            roots.append(root.reshape(n, -1))
            owners.append(np.full(root[0].size, k))
        owners = [np.zeros(0, dtype=int)] + owners
        self.forms = shaped
        cand = np.concatenate(roots, axis=1) if roots else np.zeros((n, 0))
        self.owner = np.concatenate(owners)
        self.offsets = np.cumsum([0] + [r.shape[1] for r in roots])
        c = cand.shape[1]
        order = np.argsort(np.where(np.isnan(cand), np.inf, cand), axis=1, kind="stable")
        ordered = np.take_along_axis(cand, order, axis=1)  # NaN (no root) last
        self.order = order
        valid = ~np.isnan(ordered)
        # equal roots (of several relations or elements) are one test point
        step = np.concatenate([np.zeros((n, min(c, 1)), dtype=bool),
                               ordered[:, 1:] != ordered[:, :-1]], axis=1)
        self.group = np.where(valid, np.cumsum(step, axis=1), c)  # the unique root's number
        self.count = np.where(valid, self.group, -1).max(axis=1, initial=-1) + 1
        self.sorted = np.full((n, c), np.nan)  # the unique roots, in order
        r, j = np.nonzero(valid)
        self.sorted[r, self.group[r, j]] = ordered[r, j]
        rank = np.empty_like(order)
        np.put_along_axis(rank, order, np.arange(c)[None, :].repeat(n, axis=0), axis=1)
        self.rank = np.take_along_axis(self.group, rank, axis=1)  # each root's test point
        self.p = 2 * c + 1
        self.points = self._points()
        self.truth = [self._truth(k) for k in range(len(relations))]

    def _points(self) -> np.ndarray:
        n, c = self.sorted.shape
        s = self.sorted
        first = np.where(self.count > 0, s[:, 0] if c else 0.0, 0.0)
        last = np.where(self.count > 0, s[np.arange(n), np.maximum(self.count - 1, 0)]
                        if c else 0.0, 0.0)
        below = first - np.maximum(1.0, np.abs(first))
        above = last + np.maximum(1.0, np.abs(last))
        t = np.repeat(above[:, None], self.p, axis=1)
        t[:, 0] = below
        if c:
            valid = np.arange(c)[None, :] < self.count[:, None]
            t[:, 1::2] = np.where(valid, s, above[:, None])
            nxt = np.concatenate([s[:, 1:], np.full((n, 1), np.nan)], axis=1)
            both = np.arange(c)[None, :] + 1 < self.count[:, None]
            t[:, 2::2] = np.where(both, s + (nxt - s) / 2, above[:, None])
        self.unsure |= ~np.isfinite(t).all(axis=1)
        return t

    def _truth(self, k: int) -> Optional[np.ndarray]:
        if self.forms[k] is None:
            return None
        a, b, ma, mb = self.forms[k]
        op = self.relations[k].op
        t = self.points[:, None, None, :]
        value = a[..., None] * t + b[..., None]
        # the test point that is each element's own root: the relation holds there if closed
        cols = self.offsets[k] + np.arange(a[0].size).reshape(a.shape[1:])
        own_slot = 2 * np.take_along_axis(self.rank, np.broadcast_to(
            cols.reshape(1, -1), (self.n, cols.size)), axis=1).reshape(a.shape) + 1
        has_root = ~np.isnan(np.where(np.abs(a) <= TOLERANCE * ma, np.nan, a))
        own = (np.arange(self.p)[None, None, None, :] == own_slot[..., None]) & \
            has_root[..., None]
        close = np.abs(value) <= TOLERANCE * (mb[..., None] + ma[..., None] * np.abs(t))
        self.unsure |= (close & ~own).reshape(self.n, -1).any(axis=1)
        holds = {"<": value < 0, "<=": value <= 0, ">": value > 0, ">=": value >= 0,
                 "=": value == 0, "/=": value != 0}[op]
        # each root between its neighbours: the relation's sign differs at the two
        before = np.take_along_axis(value, np.maximum(own_slot - 1, 0)[..., None], axis=3)
        after = np.take_along_axis(value, np.minimum(own_slot + 1, self.p - 1)[..., None],
                                   axis=3)
        crossing = np.sign(before) * np.sign(after) < 0
        self.unsure |= (has_root & ~crossing[..., 0]).reshape(self.n, -1).any(axis=1)
        return np.where(own, _CLOSED[op], holds)

    def root(self, i: int, j: int) -> Optional[Fraction]:
        """Row ``i``'s ``j``-th root, exactly: that of every relation and element there, all
        equal and near the float one (None: not so); computed once for every guard."""
        if (i, j) not in self._roots:
            self._roots[(i, j)] = self._root(i, j)
        return self._roots[(i, j)]

    def _root(self, i: int, j: int) -> Optional[Fraction]:
        if self._rows is None:  # as lists: read one at a time
            self._rows = (self.group.tolist(), self.order.tolist(), self.owner.tolist(),
                          self.offsets.tolist())
        group, order = self._rows[0][i], self._rows[1][i]
        root = None
        for col in order[bisect_left(group, j):bisect_left(group, j + 1)]:  # its members
            got = self._exact(i, col)
            if got is None or (root is not None and got != root):
                return None
            root = got
        if root is None or abs(float(root) - self.sorted.item(i, j)) > TOLERANCE * (
                1.0 + abs(float(root))):
            return None
        return root

    def _exact(self, i: int, col: int) -> Optional[Fraction]:
        """The exact root of candidate ``col`` in row ``i`` (None: no root there)."""
        k = self._rows[2][col]
        rel = self.relations[k]
        e1, e2 = divmod(col - self._rows[3][k], self.forms[k][0].shape[2])
        where = (i, e1, e2)
        terms = self.terms

        def get(node: ast.Node) -> Any:
            key = (id(node), rel.bound)
            value = terms.get(key)
            if value is None:
                value = self.formulas.compile(node, rel.bound)()[1]
                if np.ndim(value):
                    value = np.asarray(value)
                    value = value.reshape(value.shape + (1,) * (3 - value.ndim))
                terms[key] = value
            if np.ndim(value) == 0:
                return value
            shape = value.shape  # (rows or 1, elements or 1, elements or 1)
            return value.item(*(x if s > 1 else 0 for x, s in zip(where, shape)))
        try:
            (an, ad), (bn, bd) = rel.exact(get)
        except ZeroDivisionError:
            return None
        return None if an == 0 else Fraction(-bn * ad, bd * an)


def _ratio(x: Any) -> tuple[int, int]:
    """A term's value (a float or an integer, numpy's or Python's) as the rational it is."""
    if type(x) is float:
        return x.as_integer_ratio()
    if type(x) is int or np.issubdtype(type(x), np.integer):
        return int(x), 1
    return float(x).as_integer_ratio()


def _q_add(x: tuple[int, int], y: tuple[int, int], sign: int) -> tuple[int, int]:
    """x + sign · y, rationals as (numerator, denominator)."""
    (xn, xd), (yn, yd) = x, y
    if xd == yd:
        return xn + sign * yn, xd
    return xn * yd + sign * yn * xd, xd * yd


def _rows3(x: Any, n: int) -> np.ndarray:
    """``x`` (rows or 1, then up to two element axes) as an array of three axes."""
    x = np.asarray(x, dtype=float)
    while x.ndim < 3:
        x = x[..., None]
    return np.broadcast_to(x, (n,) + x.shape[1:])


def _negated(form: tuple) -> tuple:
    a, b, ma, mb = form
    return -np.asarray(a), -np.asarray(b), ma, mb


def _sum(x: tuple, y: tuple, sign: float) -> tuple:
    return x[0] + sign * np.asarray(y[0]), x[1] + sign * np.asarray(y[1]), x[2] + y[2], \
        x[3] + y[3]


def _scaled(form: tuple, k: Any, divide: bool) -> tuple:
    a, b, ma, mb = form
    k = np.asarray(k, dtype=float)
    if divide:
        return a / k, b / k, ma / np.abs(k), mb / np.abs(k)
    return a * k, b * k, ma * np.abs(k), mb * np.abs(k)
