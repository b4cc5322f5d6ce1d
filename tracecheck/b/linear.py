"""The allowed values of an operation's REAL parameters in a state: exact, when the guard is
linear in them.

A shield for continuous actions is an operation with parameters (``ACCELERATE(a) = PRE
a : REAL & a >= -4.0 & a <= 2.0 & Gap - (EgoSpeed + a) * Headway > MinGap THEN … END``).
Once the state is substituted, such a guard is a Boolean combination of linear
(in)equalities in the parameters; its solutions are a union of polytopes — in one dimension
a union of intervals. Every coefficient is the exact rational value of the number the
engine computed (a float is the binary fraction it is), so membership and the bounds are
exact; a guard that is not linear in the parameters (``a * a < 4``, ``f(a)``) is refused
with the reason, never approximated.

>>> from tracecheck.b import load_machine_text
>>> m = load_machine_text('''MACHINE Acc
... VARIABLES Gap, Speed
... INVARIANT Gap : REAL & Speed : REAL
... INITIALISATION Gap, Speed := 50.0, 20.0
... OPERATIONS Accelerate(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 &
...                              Gap - (Speed + a) * 1.5 > 10.0 THEN Speed := Speed + a END
... END''')
>>> allowed = allowed_set(m, "Accelerate", {"Gap": 40.0, "Speed": 20.0})
>>> print(allowed)
a ∈ [-4.0, 0.0)
>>> allowed.contains({"a": -1.0}), allowed.contains({"a": 0.0})
(True, False)
>>> allowed.nearest({"a": 1.5})["a"] < 0.0
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Mapping, Optional

from ..errors import UnsupportedError
from . import ast
from .bindings import conjuncts

__all__ = ["Constraint", "AllowedSet", "Interval", "allowed_set", "real_parameters"]

#: the most polytopes a guard's disjunctions may make (each a conjunction of constraints)
MAX_PARTS = 256

Linear = dict  # parameter (or "" for the constant) -> Fraction


@dataclass(frozen=True)
class Constraint:
    """``Σ coeffs[p]·p + const  op  0`` with ``op`` one of ``<=``, ``<``, ``=``."""

    coeffs: tuple[tuple[str, Fraction], ...]
    const: Fraction
    op: str

    def holds(self, point: Mapping[str, Fraction]) -> bool:
        value = sum((c * point[p] for p, c in self.coeffs), self.const)
        return value <= 0 if self.op == "<=" else value < 0 if self.op == "<" else value == 0


@dataclass(frozen=True)
class Interval:
    """A set of reals from ``low`` to ``high`` (None: unbounded), each end open or closed."""

    low: Optional[Fraction]
    high: Optional[Fraction]
    low_open: bool = False
    high_open: bool = False

    @property
    def empty(self) -> bool:
        if self.low is None or self.high is None:
            return False
        return self.low > self.high or (self.low == self.high
                                        and (self.low_open or self.high_open))

    def contains(self, x: Fraction) -> bool:
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


@dataclass(frozen=True)
class AllowedSet:
    """The parameter values a guard allows in one state: a union of polytopes (each a
    conjunction of :class:`Constraint`), computed over the reals with exact rationals;
    ``intervals`` per parameter when there is one.

    The engine evaluates REALs as floats (as ProB does), so right at a bound a float can be
    allowed over the reals and refused by the evaluator (``3.0 * a > 1.0`` for the float
    just above 1/3: its product rounds to 1.0). :meth:`contains` and :meth:`nearest`
    therefore answer as the ordinary guard evaluation does; :meth:`contains_exact` gives
    the answer over the reals."""

    params: tuple[str, ...]
    parts: tuple[tuple[Constraint, ...], ...]
    check: Any = field(default=None, compare=False, repr=False)  # point -> the evaluator's

    @property
    def intervals(self) -> Optional[tuple[Interval, ...]]:
        """For one parameter: the allowed set as disjoint intervals in increasing order."""
        if len(self.params) != 1:
            return None
        pieces = [i for i in (_interval(part) for part in self.parts) if not i.empty]
        return _merge(pieces)

    def witness(self) -> Optional[dict[str, float]]:
        """An allowed point the evaluator confirms (the one nearest 0), or None when there
        is none. Raises :class:`UnsupportedError` when the polytopes are not boxes."""
        if not self.separable:
            self._empty_by_solver()
        return self.nearest({p: 0.0 for p in self.params})

    @property
    def separable(self) -> bool:
        """Whether every constraint names one parameter (each polytope is a box)."""
        return all(len(c.coeffs) <= 1 for part in self.parts for c in part)

    def contains(self, point: Mapping[str, Any]) -> bool:
        """Whether the guard allows ``point`` (parameter -> number): the evaluator's answer
        (over the reals when the set was made without one)."""
        if self.check is not None:
            return bool(self.check(point))
        return self.contains_exact(point)

    def contains_exact(self, point: Mapping[str, Any]) -> bool:
        """Whether ``point`` satisfies the constraints over the reals, exactly."""
        exact = {p: _exact(point[p], p) for p in self.params}
        return any(all(c.holds(exact) for c in part) for part in self.parts)

    def nearest(self, point: Mapping[str, Any],
                scale: Optional[Mapping[str, float]] = None) -> Optional[dict[str, float]]:
        """The allowed point nearest ``point`` (Euclidean, each parameter's distance divided
        by ``scale[p]``), as floats; where the nearest lies on an open boundary, the float
        next to it inside. None when nothing is allowed, or the polytopes are not boxes
        (:attr:`separable`): the caller takes its fallback."""
        if not self.separable:
            return None
        best, best_d = None, math.inf
        for part in self.parts:
            box = _box(part, self.params)
            if box is None or any(i.empty for i in box.values()):
                continue
            candidate = self._confirmed(
                {p: _clamp(float(point[p]), box[p]) for p in self.params}, box)
            if candidate is None:
                continue
            d = sum(((candidate[p] - float(point[p])) / (scale or {}).get(p, 1.0)) ** 2
                    for p in self.params)
            if d < best_d:
                best, best_d = candidate, d
        return best

    def _confirmed(self, candidate: dict, box: dict) -> Optional[dict]:
        """``candidate`` if the evaluator allows it, else the allowed float point nearest it
        on the way into the box (bisection: the evaluator's float arithmetic may refuse the
        exact boundary point); None if none is found (fail closed)."""
        if self.contains(candidate):
            return candidate
        inner = {p: _inside(box[p], candidate[p]) for p in self.params}
        if inner == candidate or not self.contains(inner):
            return self._neighbour(candidate)
        lo, hi = 0.0, 1.0  # along candidate + t·(inner − candidate): refused at lo, allowed at hi

        def at(t: float) -> dict:
            return {p: candidate[p] + t * (inner[p] - candidate[p]) for p in self.params}
        for _ in range(BISECTIONS):
            mid = (lo + hi) / 2
            if mid in (lo, hi) or at(mid) in (at(lo), at(hi)):
                break
            if self.contains(at(mid)):
                hi = mid
            else:
                lo = mid
        return at(hi)

    def _neighbour(self, candidate: dict) -> Optional[dict]:
        """For a point set (``3.0 * a = 1.0``): the floats next to it that the evaluator
        allows, nearest first."""
        for steps in range(1, NUDGES + 1):
            for direction in (-math.inf, math.inf):
                point = dict(candidate)
                for p in self.params:
                    for _ in range(steps):
                        point[p] = math.nextafter(point[p], direction)
                if self.contains(point):
                    return point
        return None

    def _empty_by_solver(self) -> None:
        raise UnsupportedError("tracecheck decides whether a guard leaves some values of "
                               "several parameters only when each constraint names one "
                               "parameter")

    def __str__(self) -> str:
        if len(self.params) == 1:
            shown = " ∪ ".join(str(i) for i in self.intervals or ())
            return f"{self.params[0]} ∈ {shown or '∅'}"
        if self.separable:
            boxes = []
            for part in self.parts:
                box = _box(part, self.params)
                if box is not None and not any(i.empty for i in box.values()):
                    boxes.append(" × ".join(str(box[p]) for p in self.params))
            return f"({', '.join(self.params)}) ∈ {' ∪ '.join(boxes) or '∅'}"
        return f"({', '.join(self.params)}): {len(self.parts)} polytope(s)"


def real_parameters(op) -> bool:
    """Whether every parameter of ``op`` is typed REAL by a conjunct ``p : REAL`` of its
    guard (the operations :func:`allowed_set` is for)."""
    if not op.params or op.guard is None:
        return False
    typed = {c.left.id for c in conjuncts(op.guard)
             if isinstance(c, ast.Rel) and c.op == ":" and isinstance(c.left, ast.Name)
             and isinstance(c.right, ast.Name) and c.right.id in ("REAL", "FLOAT")}
    return set(op.params) <= typed


def allowed_set(machine, op_name: str, state: Optional[Mapping[str, Any]] = None, *,
                env: Optional[dict] = None) -> AllowedSet:
    """The values of ``op_name``'s REAL parameters its guard allows in ``state`` (or in an
    environment made by ``machine.env``).

    Raises :class:`UnsupportedError` naming the sub-formula when the guard is not linear in
    the parameters once the state is substituted."""
    op = machine.operation(op_name)
    if not real_parameters(op):
        raise UnsupportedError(f"{op_name} has no parameters typed `p : REAL` in its guard")
    env = machine.env(state or {}) if env is None else env
    comp = machine.compiler()
    parts = _Linearizer(set(op.params), env, comp, machine.source).pred(op.guard, True)
    guard = machine.cached("guards with parameters bound", op_name,
                           lambda: comp.compile(op.guard))

    def check(point: Mapping[str, Any]) -> bool:
        bound = dict(env)
        bound.update({p: float(point[p]) for p in op.params})
        return bool(guard(bound))
    return AllowedSet(tuple(op.params), tuple(tuple(p) for p in parts), check)


class _Linearizer:
    """Turns a guard into disjunctive normal form over linear constraints."""

    def __init__(self, params: set[str], env: dict, comp, source: str) -> None:
        self.params, self.env, self.comp, self.source = params, env, comp, source

    def refuse(self, node: ast.Node, why: str) -> UnsupportedError:
        from .scope import render

        return UnsupportedError(f"the guard is not linear in its parameters: {why} in "
                                f"`{render(node, self.source)[:80]}`")

    def free(self, node: ast.Node) -> bool:
        return not (ast.free_names(node) & self.params)

    def pred(self, node: ast.Node, positive: bool) -> list[list[Constraint]]:
        if self.free(node):  # no parameter: true or false here
            value = bool(self.comp.compile(node)(dict(self.env)))
            return [[]] if value == positive else []
        if isinstance(node, (ast.And, ast.Or)):  # ¬(A ∧ B) = ¬A ∨ ¬B, ¬(A ∨ B) = ¬A ∧ ¬B
            if isinstance(node, ast.And) == positive:
                return self.both(node.left, node.right, positive)
            return self.either(node.left, node.right, positive)
        if isinstance(node, ast.Not):
            return self.pred(node.operand, not positive)
        if isinstance(node, ast.Equiv):  # (A ∧ B) ∨ (¬A ∧ ¬B), negated (A ∧ ¬B) ∨ (¬A ∧ B)
            return _cap(self.both(node.left, node.right, True, second_positive=positive)
                        + self.both(node.left, node.right, False,
                                    second_positive=not positive), node, self)
        if isinstance(node, ast.Implies):
            if positive:  # ¬A ∨ B
                return _cap(self.pred(node.left, False) + self.pred(node.right, True), node,
                            self)
            return self.both(node.left, node.right, True, second_positive=False)
        if isinstance(node, ast.Rel):
            return self.relation(node, positive)
        raise self.refuse(node, f"a {type(node).__name__} over a parameter")

    def both(self, a, b, positive, second_positive=None) -> list[list[Constraint]]:
        left = self.pred(a, positive)
        right = self.pred(b, positive if second_positive is None else second_positive)
        return _cap([x + y for x in left for y in right], a, self)

    def either(self, a, b, positive) -> list[list[Constraint]]:
        return _cap(self.pred(a, positive) + self.pred(b, positive), a, self)

    def relation(self, node: ast.Rel, positive: bool) -> list[list[Constraint]]:
        op = node.op
        if op == ":" and isinstance(node.left, ast.Name) and isinstance(node.right, ast.Name) \
                and node.right.id in ("REAL", "FLOAT"):
            return [[]] if positive else []
        if op not in ("<", "<=", ">", ">=", "=", "/="):
            raise self.refuse(node, f"the relation {op}")
        diff = _sub(self.expr(node.left), self.expr(node.right))  # left - right
        if not positive:
            op = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "=": "/=", "/=": "="}[op]
        if op == "/=":
            return [[_constraint(diff, "<")], [_constraint(_neg(diff), "<")]]
        if op in (">", ">="):
            diff, op = _neg(diff), {">": "<", ">=": "<="}[op]
        return [[_constraint(diff, op)]]

    def expr(self, node: ast.Node) -> Linear:
        if self.free(node):
            value = self.comp.compile(node)(dict(self.env))
            return {"": _exact(value, "a value")}
        if isinstance(node, ast.Name):
            return {node.id: Fraction(1), "": Fraction(0)}
        if isinstance(node, ast.Neg):
            return _neg(self.expr(node.operand))
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            left, right = self.expr(node.left), self.expr(node.right)
            return _add(left, right) if node.op == "+" else _sub(left, right)
        if isinstance(node, ast.BinOp) and node.op == "*":
            left, right = self.expr(node.left), self.expr(node.right)
            if _constant(left) is not None:
                return _scale(right, _constant(left))
            if _constant(right) is not None:
                return _scale(left, _constant(right))
            raise self.refuse(node, "a product of two parameter terms")
        if isinstance(node, ast.BinOp) and node.op == "/":
            left, right = self.expr(node.left), self.expr(node.right)
            divisor = _constant(right)
            if divisor is None:
                raise self.refuse(node, "a division by a parameter term")
            if divisor == 0:
                raise self.refuse(node, "a division by zero")
            return _scale(left, 1 / divisor)
        raise self.refuse(node, f"a {type(node).__name__} of a parameter")


def _cap(parts, node, lin) -> list:
    if len(parts) > MAX_PARTS:
        raise lin.refuse(node, f"more than {MAX_PARTS} cases (disjunctions)")
    return parts


def _exact(value: Any, what: str) -> Fraction:
    if isinstance(value, bool) or not isinstance(value, (int, float, Fraction)):
        raise UnsupportedError(f"{what} is not a number: {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise UnsupportedError(f"{what} is not finite: {value!r}")
    return Fraction(value)


def _constant(form: Linear) -> Optional[Fraction]:
    return form[""] if all(c == 0 for p, c in form.items() if p) else None


def _add(a: Linear, b: Linear) -> Linear:
    out = dict(a)
    for p, c in b.items():
        out[p] = out.get(p, Fraction(0)) + c
    return out


def _scale(a: Linear, k: Fraction) -> Linear:
    return {p: c * k for p, c in a.items()}


def _neg(a: Linear) -> Linear:
    return _scale(a, Fraction(-1))


def _sub(a: Linear, b: Linear) -> Linear:
    return _add(a, _neg(b))


def _constraint(form: Linear, op: str) -> Constraint:
    coeffs = tuple(sorted((p, c) for p, c in form.items() if p and c != 0))
    return Constraint(coeffs, form.get("", Fraction(0)), op)


def _interval(part: tuple[Constraint, ...]) -> Interval:
    """The interval a conjunction of one-parameter constraints leaves (a constant constraint
    that fails empties it)."""
    low = high = None
    low_open = high_open = False
    for c in part:
        if not c.coeffs:
            if not c.holds({}):
                return Interval(Fraction(1), Fraction(0))
            continue
        (_, k), = c.coeffs
        bound = -c.const / k
        if c.op == "=":
            candidates = [(bound, False, True), (bound, False, False)]
        else:  # k·x + const < / <= 0: an upper bound when k > 0, a lower one when k < 0
            candidates = [(bound, c.op == "<", k > 0)]
        for value, is_open, upper in candidates:
            if upper and (high is None or value < high or (value == high and is_open)):
                high, high_open = value, is_open
            if not upper and (low is None or value > low or (value == low and is_open)):
                low, low_open = value, is_open
    return Interval(low, high, low_open, high_open)


def _box(part: tuple[Constraint, ...], params: tuple[str, ...]) -> Optional[dict]:
    """Per parameter its interval, for a conjunction of one-parameter constraints."""
    if any(len(c.coeffs) > 1 for c in part):
        return None
    constant = tuple(c for c in part if not c.coeffs)
    return {p: _interval(constant + tuple(c for c in part if c.coeffs and c.coeffs[0][0] == p))
            for p in params}


def _merge(pieces: list[Interval]) -> tuple[Interval, ...]:
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


def _clamp(x: float, interval: Interval) -> float:
    """The float nearest ``x`` on ``interval`` over the reals (its bound rounded; the
    evaluator then confirms it, or a float next to it)."""
    if interval.contains(Fraction(x)):
        return x
    if interval.low is not None and Fraction(x) <= interval.low:
        return float(interval.low)
    return float(interval.high)


#: how many floats on either side of a point set :meth:`AllowedSet.nearest` tries, and
#: how many halvings it takes to find the float boundary of an interval
NUDGES = 4
BISECTIONS = 200


def _inside(i: Interval, x: float) -> float:
    """A point well inside ``i`` (its middle; a step past a lone bound), to bisect
    towards from ``x`` on its boundary."""
    if i.low is not None and i.high is not None:
        return float((i.low + i.high) / 2)
    if i.low is not None:
        return float(i.low) + max(1.0, abs(float(i.low)))
    if i.high is not None:
        return float(i.high) - max(1.0, abs(float(i.high)))
    return x


def _number(value: Fraction) -> str:
    as_float = float(value)
    return repr(as_float) if Fraction(as_float) == value else f"{as_float!r}…"
