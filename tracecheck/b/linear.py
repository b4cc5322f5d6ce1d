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
import struct
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable, Mapping, Optional

from ..errors import UnsupportedError
from . import ast
from .bindings import conjuncts
from .memo import fresh
from .polytope import distance_to, nearest_point

__all__ = ["Constraint", "AllowedSet", "Interval", "allowed_set", "real_parameters",
           "parameter_range", "guard_with_parameters", "linear_form"]

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

    def within(self, low: Mapping[str, float], high: Mapping[str, float]) -> "AllowedSet":
        """The allowed values that also lie in the box ``low[p] <= p <= high[p]`` (an
        action space's bounds; a parameter missing from either is unbounded that way)."""
        extra = []
        for p in self.params:
            if p in low and math.isfinite(low[p]):
                extra.append(Constraint(((p, Fraction(-1)),), _exact(low[p], p), "<="))
            if p in high and math.isfinite(high[p]):
                extra.append(Constraint(((p, Fraction(1)),), -_exact(high[p], p), "<="))
        check = self.check

        def inside(point: Mapping[str, Any]) -> bool:
            return all(low.get(p, -math.inf) <= float(point[p]) <= high.get(p, math.inf)
                       for p in self.params) and (check is None or bool(check(point)))
        return AllowedSet(self.params, tuple(part + tuple(extra) for part in self.parts),
                          inside)

    def bands(self) -> Optional[dict[str, tuple[Interval, ...]]]:
        """Per parameter the intervals it may take, where the allowed set is the product of
        them (one parameter, or a single box): what a plot can draw as a band; None
        otherwise."""
        if len(self.params) == 1:
            return {self.params[0]: self.intervals or ()}
        if not self.separable:
            return None
        boxes = self._boxes()
        if not boxes:
            return {p: () for p in self.params}
        if len(boxes) > 1:
            return None
        return {p: (boxes[0][p],) for p in self.params}

    def witness(self) -> Optional[dict[str, float]]:
        """An allowed point the evaluator confirms (one well inside, else the one nearest
        0), or None when there is none."""
        if not self.separable:
            zero = {p: 0.0 for p in self.params}
            found = nearest_point(self, zero)
            if found is None and distance_to(self, zero) is not None:
                raise UnsupportedError(
                    "undecided: the guard allows values over the reals (on a face of a "
                    "polytope over several parameters), but tracecheck found no float point "
                    "it accepts, nor can it say there is none")
            return found
        for box in self._boxes():  # a point well inside a box first: one evaluation
            inner = {p: _inside(box[p], 0.0) for p in self.params}
            if all(box[p].contains(Fraction(inner[p])) for p in self.params) and \
                    self.contains(inner):
                return inner
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
        next to it inside. None when nothing is allowed or none is confirmed: the caller
        takes its fallback. Polytopes that are not boxes: :mod:`.polytope`."""
        if not self.separable:
            return nearest_point(self, point, scale)
        best, best_d = None, math.inf
        for box in self._boxes():
            candidate = self._confirmed(
                {p: _clamp(float(point[p]), box[p]) for p in self.params}, box)
            if candidate is None:
                continue
            d = sum(((candidate[p] - float(point[p])) / (scale or {}).get(p, 1.0)) ** 2
                    for p in self.params)
            if d < best_d:
                best, best_d = candidate, d
        return best

    def distance(self, point: Mapping[str, Any]) -> Optional[float]:
        """How far ``point`` lies from the allowed set over the reals (Euclidean, to the
        nearest point of its closure; 0 inside), computed exactly and then rounded: the
        margin of a recorded action. None when nothing is allowed."""
        if not self.separable:
            return distance_to(self, point)
        exact = {p: _exact(point[p], p) for p in self.params}
        boxes = self._boxes()
        if not boxes:
            return None
        if len(self.params) == 1:  # the gap itself, rounded once
            (p,) = self.params
            return float(min(abs(_gap(exact[p], box[p])) for box in boxes))
        return math.sqrt(min(sum((_gap(exact[p], box[p]) ** 2 for p in self.params),
                                 Fraction(0)) for box in boxes))

    def _boxes(self) -> list[dict]:
        """The non-empty boxes of a separable set (each parameter's interval), in the order
        of its polytopes."""
        return [b for b in (_box(part, self.params) for part in self.parts)
                if b is not None and not any(i.empty for i in b.values())]

    def _confirmed(self, candidate: dict, box: dict) -> Optional[dict]:
        """``candidate`` if the evaluator allows it, else the allowed float point nearest it
        on the way into the box (bisection: the evaluator's float arithmetic may refuse the
        exact boundary point) — moving first only the parameters whose float lies outside
        their interval over the reals (a bound rounded, an open end), then all of them;
        None if none is found (fail closed)."""
        if self.contains(candidate):
            return candidate
        outside = [p for p in self.params if not box[p].contains(Fraction(candidate[p]))]
        for moving in (outside, list(self.params)):
            inner = dict(candidate)
            inner.update({p: _inside(box[p], candidate[p]) for p in moving})
            if inner == candidate or not self.contains(inner):
                continue
            return self.towards(candidate, inner)
        return self._neighbour(candidate)

    def towards(self, refused: dict, allowed: dict) -> dict:
        """The allowed point nearest ``refused`` on the segment to ``allowed``, to the
        float: steps doubling from one float away (the evaluator's rounding usually refuses
        only a few floats past a bound), then halving the rest in the floats' own order (at
        most 64 halvings, whatever the magnitudes)."""
        direction = {p: allowed[p] - refused[p] for p in self.params}

        def at(t: float) -> dict:
            return {p: refused[p] + t * direction[p] for p in self.params}
        moving = [p for p in self.params if direction[p] != 0.0]
        t = min(1.0, max([math.ulp(refused[p]) / abs(direction[p]) for p in moving]
                         + [math.ulp(0.0)]))
        lo = 0.0  # refused at lo, allowed at hi
        for _ in range(DOUBLINGS):
            if t >= 1.0 or self.contains(at(t)):
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
            if self.contains(at(mid)):
                hi = mid
            else:
                lo = mid

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
            boxes = [" × ".join(str(box[p]) for p in self.params) for box in self._boxes()]
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
    # one copy of the state for every evaluation here: what does not depend on a parameter
    # (a quantifier over the vehicles) is computed once, remembered in it (see .memo)
    local = fresh(machine.env(state or {}) if env is None else env)
    parts = linear_form(machine, op_name)(local)
    guard = guard_with_parameters(machine, op_name)

    def check(point: Mapping[str, Any]) -> bool:
        bound = dict(local)  # the remembered values shared: none depends on a parameter
        bound.update({p: float(point[p]) for p in op.params})
        return bool(guard(bound))
    return AllowedSet(tuple(op.params), tuple(tuple(p) for p in parts), check)


def parameter_range(machine, op_name: str) -> Optional[AllowedSet]:
    """What the conjuncts of ``op_name``'s guard that read only its parameters allow
    (``a >= -4.0 & a <= 2.0``), in every state alike: checked against an action space's
    bounds before any episode. None when it has no such conjunct."""
    op = machine.operation(op_name)
    own = [c for c in conjuncts(op.guard) if ast.free_names(c) <= set(op.params)]
    if not own:
        return None
    node = own[0]
    for c in own[1:]:
        node = ast.And(node, c, pos=c.pos)
    parts = _Linearizer(set(op.params), machine.compiler(), machine.source).pred(node, True)(
        fresh(machine.base_env))
    return AllowedSet(tuple(op.params), tuple(tuple(p) for p in parts))


def linear_form(machine, op_name: str) -> Callable[[dict], list]:
    """``op_name``'s guard compiled (once) into a function from a state to its polytopes;
    raises :class:`UnsupportedError` with the reason where its form cannot be linear in
    the parameters (a product of two parameter terms, a parameter inside a function)."""
    op = machine.operation(op_name)
    return machine.cached("linear guards", op_name, lambda: _Linearizer(
        set(op.params), machine.compiler(), machine.source).pred(op.guard, True))


def guard_with_parameters(machine, op_name: str) -> Callable[[dict], Any]:
    """``op_name``'s guard compiled (once) with its parameters as bound names: no
    sub-formula that reads one is remembered between evaluations for different values."""
    def compiled() -> Callable[[dict], Any]:
        comp = machine.compiler()
        op = machine.operation(op_name)
        with comp.binding(tuple(op.params)):
            return comp.compile(op.guard)
    return machine.cached("guards with parameters bound", op_name, compiled)


class _Linearizer:
    """Compiles a guard, once per operation, into a function from the state to its
    disjunctive normal form over linear constraints in the parameters: what does not depend
    on a parameter is compiled by the engine's compiler and evaluated in the state; a form
    that cannot be linear (a product of two parameter terms) is refused here, one that turns
    out not to be in a state (a division by zero) when it is evaluated there."""

    def __init__(self, params: set[str], comp, source: str) -> None:
        self.params, self.comp, self.source = params, comp, source

    def refuse(self, node: ast.Node, why: str) -> UnsupportedError:
        from .scope import render

        return UnsupportedError(f"the guard is not linear in its parameters: {why} in "
                                f"`{render(node, self.source)[:80]}`")

    def free(self, node: ast.Node) -> bool:
        return not (ast.free_names(node) & self.params)

    def pred(self, node: ast.Node, positive: bool) -> Callable[[dict], list]:
        if self.free(node):  # no parameter: true or false here
            fn = self.comp.compile(node)
            return lambda env: [[]] if bool(fn(env)) == positive else []
        if isinstance(node, (ast.And, ast.Or)):  # ¬(A ∧ B) = ¬A ∨ ¬B, ¬(A ∨ B) = ¬A ∧ ¬B
            if isinstance(node, ast.And) == positive:
                return self.both(node.left, node.right, positive)
            return self.either(node.left, node.right, positive, node)
        if isinstance(node, ast.Not):
            return self.pred(node.operand, not positive)
        if isinstance(node, ast.Equiv):  # (A ∧ B) ∨ (¬A ∧ ¬B), negated (A ∧ ¬B) ∨ (¬A ∧ B)
            same = self.both(node.left, node.right, True, second_positive=positive)
            other = self.both(node.left, node.right, False, second_positive=not positive)
            return lambda env: _cap(same(env) + other(env), node, self)
        if isinstance(node, ast.Implies):
            if positive:  # ¬A ∨ B
                return self.either(node.left, node.right, False, node, second_positive=True)
            return self.both(node.left, node.right, True, second_positive=False)
        if isinstance(node, ast.Rel):
            return self.relation(node, positive)
        raise self.refuse(node, f"a {type(node).__name__} over a parameter")

    def both(self, a, b, positive, second_positive=None) -> Callable[[dict], list]:
        left = self.pred(a, positive)
        right = self.pred(b, positive if second_positive is None else second_positive)
        return lambda env: _cap([x + y for x in left(env) for y in right(env)], a, self)

    def either(self, a, b, positive, node, second_positive=None) -> Callable[[dict], list]:
        left = self.pred(a, positive)
        right = self.pred(b, positive if second_positive is None else second_positive)
        return lambda env: _cap(left(env) + right(env), node, self)

    def relation(self, node: ast.Rel, positive: bool) -> Callable[[dict], list]:
        op = node.op
        if op == ":" and isinstance(node.left, ast.Name) and isinstance(node.right, ast.Name) \
                and node.right.id in ("REAL", "FLOAT"):
            return lambda env: [[]] if positive else []
        if op not in ("<", "<=", ">", ">=", "=", "/="):
            raise self.refuse(node, f"the relation {op}")
        left, right = self.expr(node.left), self.expr(node.right)
        if not positive:
            op = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "=": "/=", "/=": "="}[op]
        if op == "/=":
            return lambda env: (lambda d: [[_constraint(d, "<")], [_constraint(_neg(d), "<")]])(
                _sub(left(env), right(env)))
        if op in (">", ">="):  # left > right: right - left < 0
            strict = {">": "<", ">=": "<="}[op]
            return lambda env: [[_constraint(_sub(right(env), left(env)), strict)]]
        return lambda env: [[_constraint(_sub(left(env), right(env)), op)]]

    def expr(self, node: ast.Node) -> Callable[[dict], Linear]:
        if self.free(node):
            fn = self.comp.compile(node)
            return lambda env: {"": _exact(fn(env), "a value")}
        if isinstance(node, ast.Name):
            name = node.id
            return lambda env: {name: Fraction(1), "": Fraction(0)}
        if isinstance(node, ast.Neg):
            operand = self.expr(node.operand)
            return lambda env: _neg(operand(env))
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            left, right = self.expr(node.left), self.expr(node.right)
            if node.op == "+":
                return lambda env: _add(left(env), right(env))
            return lambda env: _sub(left(env), right(env))
        if isinstance(node, ast.BinOp) and node.op in ("*", "/"):
            left, right = self.expr(node.left), self.expr(node.right)
            if not (self.free(node.left) or self.free(node.right)) and node.op == "*":
                raise self.refuse(node, "a product of two parameter terms")
            if not self.free(node.right) and node.op == "/":
                raise self.refuse(node, "a division by a parameter term")
            product = node.op == "*"

            def combine(env: dict) -> Linear:
                a, b = left(env), right(env)
                if product and _constant(a) is not None:
                    return _scale(b, _constant(a))
                divisor = _constant(b)
                if divisor is None:  # not reached: one side is free of parameters
                    raise self.refuse(node, "a product of two parameter terms")
                if not product and divisor == 0:
                    raise self.refuse(node, "a division by zero")
                return _scale(a, divisor if product else 1 / divisor)
            return combine
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


def _gap(x: Fraction, interval: Interval) -> Fraction:
    """How far ``x`` lies outside the closure of ``interval`` (0 inside)."""
    if interval.low is not None and x < interval.low:
        return interval.low - x
    if interval.high is not None and x > interval.high:
        return x - interval.high
    return Fraction(0)


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
DOUBLINGS = 12


def _float_between(lo: float, hi: float) -> Optional[float]:
    """The float halfway between ``0 <= lo < hi`` in the order of floats (their bit
    patterns); None when they are next to each other."""
    a, b = (struct.unpack("<q", struct.pack("<d", x))[0] for x in (lo, hi))
    if b - a <= 1:
        return None
    return struct.unpack("<d", struct.pack("<q", (a + b) // 2))[0]


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
