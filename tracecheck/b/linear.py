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
from dataclasses import dataclass, field, replace
from fractions import Fraction
from functools import cached_property, reduce
from typing import Any, Callable, Mapping, Optional

from .cache import Cache
from ..errors import UnsupportedError
from ..limits import DEEP, deep_recursion, deeply
from . import ast
from .bindings import conjuncts
from .memo import MEMO_KEY, fresh
from .polytope import (Constraint, Form, Interval, bound_constraint, box_constraints, box_of,
                       box_within, constraint_of, distance_to, exact, form_add, form_constant,
                       form_neg, form_times, gap, inner_point, interval_of, merge_intervals,
                       nearest_point, towards)
from .box_search import nearest_in_boxes
from .narrow import NARROW, narrow_witness
from .real_typing import real_parameters, real_typed, typing_conjunct

__all__ = ["Constraint", "AllowedSet", "Interval", "allowed_set", "real_parameters",
           "real_typed", "parameter_range", "guard_with_parameters", "linear_form"]

#: per machine and operation: whether it has REAL parameters, its guard's linear form, the
#: guard with what reads only the state named, and the guard with its parameters bound
_REAL_PARAMETERS: Cache = Cache("real parameters")
_LINEAR_GUARDS: Cache = Cache("linear guards")
_RESIDUAL_GUARDS: Cache = Cache("linear residual guards")
_BOUND_GUARDS: Cache = Cache("guards with parameters bound")

#: the most polytopes a guard's disjunctions may make (each a conjunction of constraints)
MAX_PARTS = 256


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
    #: (parameter, float type) of those an action space holds in a narrower float type
    floats: tuple[tuple[str, str], ...] = ()

    @cached_property
    def intervals(self) -> Optional[tuple[Interval, ...]]:
        """For one parameter: the allowed set as disjoint intervals in increasing order."""
        if len(self.params) != 1:
            return None
        pieces = [i for i in (interval_of(part) for part in self.parts) if not i.empty]
        return merge_intervals(pieces)

    def within(self, low: Mapping[str, float], high: Mapping[str, float],
               floats: Optional[Mapping[str, str]] = None) -> "AllowedSet":
        """The allowed values that also lie in the box ``low[p] <= p <= high[p]`` (an
        action space's bounds; a parameter missing from either is unbounded that way) and,
        for :meth:`witness`, are values of the float type ``floats[p]`` (:mod:`.narrow`)."""
        extra = box_constraints(self.params, low, high)
        check = self.check
        bounds = [(p, low.get(p, -math.inf), high.get(p, math.inf)) for p in self.params]

        def inside(point: Mapping[str, Any]) -> bool:
            for p, lo, hi in bounds:
                if not lo <= float(point[p]) <= hi:
                    return False
            return check is None or bool(check(point))
        narrow = tuple((p, t) for p, t in (floats or {}).items() if t in NARROW)
        return AllowedSet(self.params, tuple(part + extra for part in self.parts), inside,
                          narrow)

    def bands(self) -> Optional[dict[str, tuple[Interval, ...]]]:
        """Per parameter the intervals it may take, where the allowed set is the product of
        them (one parameter, or a single box): what a plot can draw as a band; None
        otherwise."""
        if len(self.params) == 1:
            return {self.params[0]: self.intervals or ()}
        if not self.separable:
            return None
        boxes = self._boxes
        if not boxes:
            return {p: () for p in self.params}
        # a union is drawn where one of its boxes holds the others (a guard's "any
        # acceleration, or full braking" is [-1, a] × S ∪ {-1} × S)
        whole = next((b for b in boxes if all(box_within(o, b, self.params) for o in boxes)),
                     None)
        return None if whole is None else {p: (whole[p],) for p in self.params}

    def witness(self) -> Optional[dict[str, float]]:
        """An allowed point the evaluator confirms (one well inside, else the one nearest
        0; of the float types of :attr:`floats`), or None when there is none."""
        found = self._witness()
        return narrow_witness(self, found, dict(self.floats), self._boxes if self.separable
                              else None) if self.floats and found is not None else found

    def _witness(self) -> Optional[dict[str, float]]:
        if not self.separable:
            zero = {p: 0.0 for p in self.params}
            found = nearest_point(self, zero)
            if found is None and distance_to(self, zero) is not None:
                raise UnsupportedError(  # the closure: the set itself may be empty
                    "undecided: tracecheck found no float point the guard accepts, nor can "
                    "it say there is none: its constraints, with < read as <=, hold points "
                    "(a face of a polytope over several parameters)")
            return found
        for box in self._boxes:  # a point well inside a box first: one evaluation
            inner = {p: inner_point(box[p], 0.0) for p in self.params}
            if all(box[p].contains(inner[p]) for p in self.params) and self.contains(inner):
                return inner
        return self.nearest({p: 0.0 for p in self.params})

    @cached_property
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
        at = {p: exact(point[p], p) for p in self.params}
        return any(all(c.holds(at) for c in part) for part in self.parts)

    def nearest(self, point: Mapping[str, Any],
                scale: Optional[Mapping[str, float]] = None) -> Optional[dict[str, float]]:
        """The allowed point nearest ``point`` (Euclidean, each parameter's distance divided
        by ``scale[p]``), as floats; where the nearest lies on an open boundary, the float
        next to it inside. None when nothing is allowed or none is confirmed: the caller
        takes its fallback. Polytopes that are not boxes: :mod:`.polytope`."""
        if not self.separable:
            return nearest_point(self, point, scale)
        return nearest_in_boxes(self, self._boxes, point, scale)

    def distance(self, point: Mapping[str, Any]) -> Optional[float]:
        """How far ``point`` lies from the allowed set over the reals (Euclidean, to the
        nearest point of its closure; 0 inside), computed exactly and then rounded: the
        margin of a recorded action. None when nothing is allowed."""
        if not self.separable:
            return distance_to(self, point)
        at = {p: exact(point[p], p) for p in self.params}
        boxes = self._boxes
        if not boxes:
            return None
        if len(self.params) == 1:  # the gap itself, rounded once
            (p,) = self.params
            return float(min(abs(gap(at[p], box[p])) for box in boxes))
        return math.sqrt(min(sum((gap(at[p], box[p]) ** 2 for p in self.params),
                                 Fraction(0)) for box in boxes))

    @cached_property
    def _boxes(self) -> list[dict]:
        """The non-empty boxes of a separable set (each parameter's interval), in the order
        of its polytopes (computed once: nearest, witness and bands all ask)."""
        return [b for b in (box_of(part, self.params) for part in self.parts)
                if b is not None and not any(i.empty for i in b.values())]

    def towards(self, refused: dict, allowed: dict) -> dict:
        """The allowed point nearest ``refused`` on the segment to ``allowed``, to the
        float (see :func:`.polytope.towards`)."""
        return towards(self.contains, self.params, refused, allowed)

    def __str__(self) -> str:
        if len(self.params) == 1:
            shown = " ∪ ".join(str(i) for i in self.intervals or ())
            return f"{self.params[0]} ∈ {shown or '∅'}"
        if self.separable:
            boxes = [" × ".join(str(box[p]) for p in self.params) for box in self._boxes]
            return f"({', '.join(self.params)}) ∈ {' ∪ '.join(boxes) or '∅'}"
        return f"({', '.join(self.params)}): {len(self.parts)} polytope(s)"


def allowed_set(machine, op_name: str, state: Optional[Mapping[str, Any]] = None, *,
                env: Optional[dict] = None) -> AllowedSet:
    """The values of ``op_name``'s REAL parameters its guard allows in ``state`` (or in an
    environment made by ``machine.env``).

    Raises :class:`UnsupportedError` naming the sub-formula when the guard is not linear in
    the parameters once the state is substituted."""
    op = machine.operation(op_name)
    if not machine.cached(_REAL_PARAMETERS, op_name, lambda: real_parameters(op)):
        raise UnsupportedError(f"{op_name} has no parameters typed `p : REAL` in its guard")
    lin = _linearizer(machine, op_name)
    # one copy of the state for every evaluation here: what does not depend on a parameter
    # (a quantifier over the vehicles) is computed once, remembered in it (see .memo), and
    # so is each value the linear form reads from the state (see _Linearizer)
    local = _State(machine.env(state or {}) if env is None else env, lin.fns)
    local.pop(MEMO_KEY, None)
    parts = lin.run(local)
    guard = _residual_guard(machine, op_name)
    params = tuple(op.params)
    answers: dict = {}  # the evaluator's answer by point: asked again, not evaluated again

    def check(point: Mapping[str, Any]) -> bool:
        values = tuple(float(point[p]) for p in params)
        key = values if all(values) else tuple((v, math.copysign(1.0, v)) for v in values)
        known = answers.get(key)
        if known is None:
            bound = _State(local, local.free)  # what the state gave, shared
            bound.update(zip(params, values))
            try:
                known = answers[key] = bool(guard(bound))
            except _Missing as exc:
                raise exc.args[0] from None
        return known
    return AllowedSet(params, tuple(tuple(p) for p in parts), check)


class _State(dict):
    """A state for the formulas of :class:`_Linearizer`: the value of a sub-formula kept
    under its name is computed when first read (``free``: the compiled sub-formulas by
    name) — a value the linear form did not need (a conjunct after one that failed)."""

    __slots__ = ("free",)

    def __init__(self, env: Mapping, free: dict) -> None:
        super().__init__(env)
        self.free = free

    def __missing__(self, key: Any) -> Any:
        fn = self.free.get(key)
        if fn is None:
            raise KeyError(key)
        try:
            value = self[key] = fn(self)
        except KeyError as exc:  # not the name's own: raised as the whole formula would
            raise _Missing(exc) from None
        return value


class _Missing(Exception):
    pass


def parameter_range(machine, op_name: str) -> Optional[AllowedSet]:
    """What the conjuncts of ``op_name``'s guard that read only its parameters allow
    (``a >= -4.0 & a <= 2.0``), in every state alike: checked against an action space's
    bounds before any episode. One not linear in them (``a * a <= 1.0``) is left out: the
    range holds every value the guard allows, and more. None when no such one is linear."""
    op = machine.operation(op_name)
    own = [c for c in conjuncts(op.guard) if ast.free_names(c) <= set(op.params)
           and _linear_conjunct(machine, op, c)]
    if not own:
        return None
    node = reduce(lambda left, c: ast.And(left, c, pos=c.pos), own)
    parts = _Linearizer(set(op.params), machine.compiler(), machine.source).compile(
        node).run(fresh(machine.base_env))
    return AllowedSet(tuple(op.params), tuple(tuple(p) for p in parts))


def _linear_conjunct(machine, op, conjunct: ast.Node) -> bool:
    try:
        _Linearizer(set(op.params), machine.compiler(), machine.source).compile(conjunct)
    except UnsupportedError:
        return False
    return True


def linear_form(machine, op_name: str) -> Callable[[dict], list]:
    """``op_name``'s guard compiled (once) into a function from a state to its polytopes;
    raises :class:`UnsupportedError` with the reason where its form cannot be linear in
    the parameters (a product of two parameter terms, a parameter inside a function)."""
    return _linearizer(machine, op_name).run


def _linearizer(machine, op_name: str) -> "_Linearizer":
    op = machine.operation(op_name)

    def build() -> "_Linearizer":
        with deep_recursion():  # a guard of 1500 disjuncts nests 1500 deep
            return _Linearizer(set(op.params), machine.compiler(), machine.source
                               ).compile(op.guard)
    return machine.cached(_LINEAR_GUARDS, op_name, build)


def _residual_guard(machine, op_name: str) -> Callable[[dict], Any]:
    """``op_name``'s guard compiled (once) with each sub-formula the linear form reads from
    the state replaced by the name it keeps that value under (in a :class:`_State`): the
    same formula for the evaluator, the same float arithmetic on the same values, but what
    reads only the state is not computed again for every point checked."""
    def compiled() -> Callable[[dict], Any]:
        comp = machine.compiler()
        with comp.binding(tuple(machine.operation(op_name).params)):
            return comp.compile(_linearizer(machine, op_name).residual_guard)
    return machine.cached(_RESIDUAL_GUARDS, op_name, compiled)


def guard_with_parameters(machine, op_name: str) -> Callable[[dict], Any]:
    """``op_name``'s guard compiled (once) with its parameters as bound names: no
    sub-formula that reads one is remembered between evaluations for different values."""
    def compiled() -> Callable[[dict], Any]:
        comp = machine.compiler()
        op = machine.operation(op_name)
        with comp.binding(tuple(op.params)):
            return comp.compile(op.guard)
    return machine.cached(_BOUND_GUARDS, op_name, compiled)


#: the formulas evaluated in the environment of the formula around them (no binders):
#: where a sub-formula the state determines may be read from a name instead
_SAME_ENV = (ast.BinOp, ast.Neg, ast.Call, ast.SetExt, ast.Apply, ast.IfExpr, ast.Pair,
             ast.Rel, ast.And, ast.Or, ast.Not, ast.Implies, ast.Equiv)


class _Linearizer:
    """Compiles a guard, once per operation, into a function from the state to its
    disjunctive normal form over linear constraints in the parameters: a form that cannot
    be linear (a product of two parameter terms) is refused here, one that turns out not
    to be in a state (a division by zero) when it is evaluated there.

    What does not depend on a parameter is compiled by the engine's compiler and evaluated
    in the state, its value kept in the state's dict (a :class:`_State`) under a name no B
    identifier has, and so is each sub-formula found in several of them (the ego's speed
    in every bound): evaluated once per state, where first read. The guard with those names
    (:attr:`residual_guard`) is what :func:`allowed_set`'s check evaluates. The linear
    forms are exact integers (see :data:`.polytope.Form`); a relation over the parameters and
    literals alone is computed once."""

    def __init__(self, params: set[str], comp, source: str) -> None:
        self.params, self.comp, self.source = params, comp, source
        self.order = tuple(sorted(params))
        self.names: dict[ast.Node, str] = {}  # sub-formulas read from the state, by name
        self.fns: dict[str, Callable] = {}  # … compiled (reading the names inside them)
        self.form: Callable[[dict], list] = lambda env: []
        self.residual_guard: Optional[ast.Node] = None
        self._free: dict = {}  # free names by node identity (see free_names)

    def compile(self, guard: ast.Node) -> "_Linearizer":
        self.residual_guard = self.residual(guard)  # names each sub-formula of the state
        seen: dict[ast.Node, int] = {}

        def walk(n: ast.Node) -> None:  # each one's sub-formulas, once per distinct parent
            seen[n] = seen.get(n, 0) + 1
            if seen[n] == 1 and isinstance(n, _SAME_ENV):
                for c in n.args if isinstance(n, ast.Apply) else ast.children(n):
                    walk(c)
        for n in list(self.names):
            walk(n)
        for n, count in seen.items():
            if count > 1 and n not in self.names and self.free_names(n) and _nodes(n, 4) >= 4:
                self.names[n] = f"$linear{len(self.names)}"
        self.fns.update({key: self.comp.compile(self.definition(n))
                         for n, key in self.names.items()})
        self.form = self.pred(guard, True)
        if ast.depth(guard) > DEEP:  # its forms call each other once per level
            self.form = deeply(self.form)
        return self

    def run(self, env: dict) -> list:
        """The polytopes in the state ``env`` (a :class:`_State` keeps what was read)."""
        state = env if isinstance(env, _State) else _State(env, self.fns)
        try:
            return self.form(state)
        except _Missing as exc:
            raise exc.args[0] from None

    def refuse(self, node: ast.Node, why: str) -> UnsupportedError:
        from .scope import render

        return UnsupportedError(f"the guard is not linear in its parameters: {why} in "
                                f"`{render(node, self.source)[:80]}`")

    def free_names(self, node: ast.Node) -> frozenset[str]:  # remembered: asked at every
        return ast.free_names(node, self._free)  # level (1500 disjuncts: 18 M calls, 19 s)

    def free(self, node: ast.Node) -> bool:
        return not (self.free_names(node) & self.params)

    def slot(self, node: ast.Node) -> Optional[str]:
        """The name a sub-formula free of parameters is kept under in the state's dict;
        None for one without names (literals: the compiler folds it)."""
        if not self.free_names(node):
            return None
        return self.names.setdefault(node, f"$linear{len(self.names)}")

    def definition(self, node: ast.Node, top: bool = True) -> ast.Node:
        """``node`` reading each named sub-formula from its name (not a function applied:
        that stays as written)."""
        if not top and node in self.names:
            return ast.Name(self.names[node], pos=node.pos)
        if not isinstance(node, _SAME_ENV):
            return node
        if isinstance(node, ast.Apply):
            return replace(node, args=tuple(self.definition(a, False) for a in node.args))
        return ast.map_children(node, lambda c: self.definition(c, False))

    def evaluated(self, node: ast.Node, then: Callable[[Any], Any]) -> Callable[[dict], Any]:
        """``then`` of ``node``'s value in the state: computed once when ``node`` reads no
        name (unless that fails: then in each state, where it fails as it would)."""
        key = self.slot(node)
        if key is None:
            fn = self.comp.compile(node)
            try:
                value = then(fn({}))
                return lambda env: value
            except Exception:  # noqa: BLE001 - raised again, where the state is evaluated
                return lambda env: then(fn(env))
        fn = self.fns.get(key) or self.comp.compile(self.definition(node))

        def read(env: dict) -> Any:
            value = env[key] = fn(env)
            return then(value)
        return read

    def residual(self, node: ast.Node) -> ast.Node:
        """The guard with each sub-formula the linear form reads from the state replaced by
        the name it keeps that value under (the same walk as :meth:`pred`, :meth:`expr`)."""
        if self.free(node):
            key = self.slot(node)
            return node if key is None else ast.Name(key, pos=node.pos)
        if isinstance(node, (ast.And, ast.Or, ast.Equiv, ast.Implies)) or (
                isinstance(node, ast.BinOp) and node.op in ("+", "-", "*", "/")) or (
                isinstance(node, ast.Rel) and not typing_conjunct(node)):
            return replace(node, left=self.residual(node.left),
                           right=self.residual(node.right))
        if isinstance(node, (ast.Not, ast.Neg)):
            return replace(node, operand=self.residual(node.operand))
        return node

    def pred(self, node: ast.Node, positive: bool) -> Callable[[dict], list]:
        if self.free(node):  # no parameter: true or false here
            return self.evaluated(node, lambda v: [[]] if bool(v) == positive else [])
        if isinstance(node, (ast.And, ast.Or)):  # ¬(A ∧ B) = ¬A ∨ ¬B, ¬(A ∨ B) = ¬A ∧ ¬B
            if isinstance(node, ast.And) == positive:
                return self.chain(node, positive)
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
        raise self.refuse(node, f"{ast.described(node)} over a parameter")

    def chain(self, node: ast.Node, positive: bool) -> Callable[[dict], list]:
        """A conjunction (``A & B``, or ``not(A or B)``) nested to its left as one product:
        the same order, and the same checks, as :meth:`both` nested."""
        levels, kind = [], type(node)
        while type(node) is kind and not self.free(node):
            levels.append(node)
            node = node.left
        first = self.pred(node, positive)
        rest = [(self.pred(level.right, positive), level.left) for level in reversed(levels)]

        def product(env: dict) -> list:
            out = first(env)
            for right, left in rest:
                if not out:
                    return out  # the others are not evaluated: nothing to combine them with
                second = right(env)
                out = _cap([x + y for x in out for y in second], left, self)
            return out
        return product

    def both(self, a, b, positive, second_positive=None) -> Callable[[dict], list]:
        left = self.pred(a, positive)
        right = self.pred(b, positive if second_positive is None else second_positive)

        def product(env: dict) -> list:
            first = left(env)
            if not first:
                return first  # the second is not evaluated: nothing to combine it with
            second = right(env)
            return _cap([x + y for x in first for y in second], a, self)
        return product

    def either(self, a, b, positive, node, second_positive=None) -> Callable[[dict], list]:
        left = self.pred(a, positive)
        right = self.pred(b, positive if second_positive is None else second_positive)
        return lambda env: _cap(left(env) + right(env), node, self)

    def relation(self, node: ast.Rel, positive: bool) -> Callable[[dict], list]:
        op = node.op
        if typing_conjunct(node):
            return lambda env: [[]] if positive else []
        if op not in ("<", "<=", ">", ">=", "=", "/="):
            raise self.refuse(node, f"the relation {op}")
        left, right = self.expr(node.left), self.expr(node.right)
        if not positive:
            op = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "=": "/=", "/=": "="}[op]
        simple = self.bound(node, op)
        if simple is not None:
            return simple
        order = self.order
        if op == "/=":
            def parts(env: dict) -> list:
                d = form_add(left(env), right(env), -1)
                return [[constraint_of(d, "<", order)], [constraint_of(form_neg(d), "<", order)]]
        elif op in (">", ">="):  # left > right: right - left < 0
            strict = {">": "<", ">=": "<="}[op]

            def parts(env: dict) -> list:
                return [[constraint_of(form_add(right(env), left(env), -1), strict, order)]]
        else:
            def parts(env: dict) -> list:
                return [[constraint_of(form_add(left(env), right(env), -1), op, order)]]
        if self.free_names(node) - self.params:
            return parts
        made: list = []  # over the parameters and literals alone: the same in every state

        def once(env: dict) -> list:
            if not made:
                made.append(parts(env))
            return [list(p) for p in made[0]]
        return once

    def bound(self, node: ast.Rel, op: str) -> Optional[Callable[[dict], list]]:
        """``p op v`` or ``v op p`` (``op`` one of < <= > >=) for a parameter ``p`` and a
        value ``v`` of the state: its constraint made directly, the same as
        :meth:`relation` makes it (``p - v op 0`` or ``v - p op 0``, its limit ``v``)."""
        sides = (node.left, node.right)
        names = [isinstance(s, ast.Name) and s.id in self.params for s in sides]
        if op not in ("<", "<=", ">", ">=") or names.count(True) != 1:
            return None
        p, other = sides[names.index(True)].id, sides[names.index(False)]
        key = self.slot(other) if self.free(other) else None
        if key is None:
            return None
        fn = self.fns.get(key) or self.comp.compile(self.definition(other))
        upper = (op[0] == "<") == names[0]  # p below v: p - v op 0
        kind = "<" if op in ("<", ">") else "<="

        def parts(env: dict) -> list:
            value = env[key] = fn(env)
            return [[bound_constraint(p, _ratio(value, "a value"), upper, kind)]]
        return parts

    def expr(self, node: ast.Node) -> Callable[[dict], Form]:
        fn = self.linear(node)
        if self.free(node) or self.free_names(node) - self.params:
            return fn
        made: list = []  # over the parameters and literals alone: the same in every state

        def once(env: dict) -> Form:
            if not made:
                made.append(fn(env))
            return made[0]
        return once

    def linear(self, node: ast.Node) -> Callable[[dict], Form]:
        if self.free(node):
            zero = (0,) * len(self.order)

            def number(value: Any) -> Form:
                n, d = _ratio(value, "a value")
                return zero + (n,), d
            return self.evaluated(node, number)
        if isinstance(node, ast.Name):
            unit = (tuple(int(p == node.id) for p in self.order) + (0,), 1)
            return lambda env: unit
        if isinstance(node, ast.Neg):
            operand = self.expr(node.operand)
            return lambda env: form_neg(operand(env))
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            left, right = self.expr(node.left), self.expr(node.right)
            if node.op == "+":
                return lambda env: form_add(left(env), right(env))
            return lambda env: form_add(left(env), right(env), -1)
        if isinstance(node, ast.BinOp) and node.op in ("*", "/"):
            left, right = self.expr(node.left), self.expr(node.right)
            if not (self.free(node.left) or self.free(node.right)) and node.op == "*":
                raise self.refuse(node, "a product of two parameter terms")
            if not self.free(node.right) and node.op == "/":
                raise self.refuse(node, "a division by a parameter term")
            product = node.op == "*"
            by_left = product and self.free(node.left)  # which side is a number (no parameter)

            def combine(env: dict) -> Form:
                a, b = left(env), right(env)
                if by_left:
                    return form_times(b, form_constant(a))
                divisor = form_constant(b)
                if not product and divisor[0] == 0:
                    raise self.refuse(node, "a division by zero")
                return form_times(a, divisor if product else (divisor[1], divisor[0]))
            return combine
        raise self.refuse(node, f"{ast.described(node)} of a parameter")


def _nodes(node: ast.Node, most: int) -> int:
    """How many nodes ``node`` has, counted up to ``most``."""
    count, todo = 0, [node]
    while todo and count < most:
        count += 1
        todo.extend(ast.children(todo.pop()))
    return count


def _ratio(value: Any, what: str) -> tuple[int, int]:
    """:func:`.polytope.exact` as (numerator, denominator), without making a Fraction."""
    if type(value) is float and math.isfinite(value):
        return value.as_integer_ratio()
    return exact(value, what).as_integer_ratio()


def _cap(parts, node, lin) -> list:
    if len(parts) > MAX_PARTS:
        raise lin.refuse(node, f"more than {MAX_PARTS} cases (disjunctions)")
    return parts
