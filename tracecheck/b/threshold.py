"""The values of one number of a machine for which a predicate holds in a state — exactly, as
a union of intervals of the reals.

A shield's thresholds (``45.0`` in a guard, an RSS constant) are numbers written once in the
machine; tuning one asks, for every recorded state, *for which values* of it the guard allows
the recorded action. With the state substituted, a guard is a Boolean combination of
relations between numbers, and where the number enters them linearly each relation holds on
a half-line of its values; quantifiers over the state's finite sets (``#v.(v : Others & …)``)
are unions and intersections over their elements. The answer is a :class:`Values`: finitely
many breakpoints, and whether the predicate holds at each and between them — computed with
exact rationals from the numbers the engine gives (a float is the binary fraction it is).
What cannot be linear in the number (a product with it, a function of it, a condition on it
inside ``IF``) is refused with the reason, never approximated.

>>> from tracecheck.b import load_machine_text
>>> m = load_machine_text('''MACHINE Gap
... VARIABLES d
... INVARIANT d : REAL
... INITIALISATION d := 50.0
... OPERATIONS Faster = SELECT d > 40.0 + 5.0 THEN skip END
... END''')
>>> guard = threshold_guard(m, m.operations["Faster"].guard, "D", lambda n: (
...     isinstance(n, ast.RealLit) and n.value == 40.0))
>>> print(values_of(m, guard, "D", {"d": 47.5}))
θ < 42.5
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Optional

from ..errors import UnsupportedError
from . import ast
from .bindings import conjuncts
from .values import SymbolicSet

__all__ = ["Values", "threshold_guard", "values_of", "ThresholdCompiler", "exact_number",
           "exact_text"]

Form = tuple[Fraction, Fraction]  # a * θ + b
#: the built-in sets a number can be typed by, with their least element (None: unbounded)
#: what a kind of formula is, in the words of a refusal
_KINDS = {"Call": "a call (max, min, card, …)", "Apply": "a function applied to it",
          "SetExt": "a set", "Pair": "a pair (|->)", "Image": "a relational image",
          "Comprehension": "a set comprehension", "QuantExpr": "a SIGMA/PI/UNION/INTER",
          "Let": "a LET", "Record": "a record", "Lambda": "a lambda"}
_TYPES = {"REAL": None, "FLOAT": None, "INTEGER": None, "NATURAL": 0, "NATURAL1": 1}
_ZERO, _ONE = Fraction(0), Fraction(1)


@dataclass(frozen=True)
class Values:
    """A set of reals given by sorted breakpoints ``points``; whether each breakpoint is in
    it (``at``) and whether each open piece is (``pieces``: ``len(points) + 1`` of them, the
    first below every breakpoint, the last above)."""

    points: tuple[Fraction, ...]
    at: tuple[bool, ...]
    pieces: tuple[bool, ...]

    @staticmethod
    def everything() -> "Values":
        return _ALL

    @staticmethod
    def nothing() -> "Values":
        return _NONE

    @staticmethod
    def half(point: Fraction, above: bool, closed: bool) -> "Values":
        """``θ > point`` (``above``) or ``θ < point``, ``>=``/``<=`` where ``closed``."""
        return Values((point,), (closed,), (not above, above))

    @property
    def empty(self) -> bool:
        return not any(self.at) and not any(self.pieces)

    @property
    def full(self) -> bool:
        return all(self.at) and all(self.pieces)

    def contains(self, x: Fraction | float) -> bool:
        x = Fraction(x)
        i = bisect.bisect_left(self.points, x)
        if i < len(self.points) and self.points[i] == x:
            return self.at[i]
        return self.pieces[i]

    def complement(self) -> "Values":
        return Values(self.points, tuple(not a for a in self.at),
                      tuple(not p for p in self.pieces))

    def intersect(self, other: "Values") -> "Values":
        return self._combine(other, _and_op)

    def union(self, other: "Values") -> "Values":
        return self._combine(other, _or_op)

    def __hash__(self) -> int:  # kept: sets are counted by the thousand (tune)
        h = self.__dict__.get("_hash")
        if h is None:
            h = hash((self.points, self.at, self.pieces))
            object.__setattr__(self, "_hash", h)
        return h

    def _combine(self, other: "Values", op: Callable[[bool, bool], bool]) -> "Values":
        if not other.points:
            return _constant(self, other.pieces[0], op is _and_op)
        if not self.points:
            return _constant(other, self.pieces[0], op is _and_op)
        if self == other:
            return self
        if len(self.points) == 1 and len(other.points) == 1:  # two half-lines, often
            return _two(self, other, op)
        points = sorted(set(self.points) | set(other.points))
        a_at, a_pc = self._on(points)
        b_at, b_pc = other._on(points)
        return _normal(points, [op(x, y) for x, y in zip(a_at, b_at)],
                       [op(x, y) for x, y in zip(a_pc, b_pc)])

    def _on(self, points: list[Fraction]) -> tuple[list[bool], list[bool]]:
        """Membership at each of ``points`` (a superset of this set's, sorted) and on each
        open piece between them."""
        at, pieces, i = [], [self.pieces[0]], 0
        for p in points:
            while i < len(self.points) and self.points[i] < p:
                i += 1
            if i < len(self.points) and self.points[i] == p:
                at.append(self.at[i])
                pieces.append(self.pieces[i + 1])
            else:
                at.append(self.pieces[i])
                pieces.append(self.pieces[i])
        return at, pieces

    def intervals(self) -> list[tuple[Optional[Fraction], Optional[Fraction], bool, bool]]:
        """The set as disjoint intervals (low, high, low closed, high closed), None for an
        infinite end, in increasing order."""
        out: list = []
        inside, start, start_closed = self.pieces[0], None, False
        for k, p in enumerate(self.points):
            after = self.pieces[k + 1]
            if inside and not self.at[k]:  # ends before p (and may start again after it)
                out.append((start, p, start_closed, False))
                inside, start, start_closed = after, p, False
            elif inside and not after:  # ends at p
                out.append((start, p, start_closed, True))
                inside = False
            elif not inside and after:  # starts at p (or just after)
                inside, start, start_closed = True, p, self.at[k]
            elif not inside and self.at[k]:  # p alone
                out.append((p, p, True, True))
        if inside:
            out.append((start, None, start_closed, False))
        return out

    def text(self, name: str = "θ") -> str:
        """The set as conditions on ``name`` (``2.0 < d <= 5.0 or d = 7.0``)."""
        if self.empty:
            return "no value"
        if self.full:
            return "every value"
        parts = []
        for lo, hi, lc, hc in self.intervals():
            if lo is not None and lo == hi:
                parts.append(f"{name} = {exact_text(lo)}")
            elif lo is None:
                parts.append(f"{name} {'<=' if hc else '<'} {exact_text(hi)}")
            elif hi is None:
                parts.append(f"{name} {'>=' if lc else '>'} {exact_text(lo)}")
            else:
                parts.append(f"{exact_text(lo)} {'<=' if lc else '<'} {name} {'<=' if hc else '<'} "
                             f"{exact_text(hi)}")
        return " or ".join(parts)

    def __str__(self) -> str:
        return self.text()


def _and_op(a: bool, b: bool) -> bool:
    return a and b


def _or_op(a: bool, b: bool) -> bool:
    return a or b


def _constant(values: Values, constant: bool, conjunction: bool) -> Values:
    """``values`` and (or, not ``conjunction``) every value (``constant``) or none."""
    if constant == conjunction:  # A ∩ ℝ, A ∪ ∅
        return values
    return _ALL if constant else _NONE


def exact_text(x: Fraction) -> str:
    """``x`` as the float it is, or the float nearest it followed by … where it is none."""
    return repr(float(x)) if float(x) == x else f"{float(x)!r}…"


def _two(x: Values, y: Values, op: Callable[[bool, bool], bool]) -> Values:
    """``x`` op ``y`` for sets of one breakpoint each."""
    (p,), (q,) = x.points, y.points
    if p == q:
        return _normal([p], [op(x.at[0], y.at[0])],
                       [op(x.pieces[0], y.pieces[0]), op(x.pieces[1], y.pieces[1])])
    if q < p:
        x, y, p, q = y, x, q, p
    (xl, xr), (yl, yr) = x.pieces, y.pieces
    return _normal([p, q], [op(x.at[0], yl), op(xr, y.at[0])],
                   [op(xl, yl), op(xr, yl), op(xr, yr)])


def _normal(points: list, at: list, pieces: list) -> Values:
    """Without the breakpoints where nothing changes."""
    keep = [k for k in range(len(points)) if not (at[k] == pieces[k] == pieces[k + 1])]
    if len(keep) == len(points):
        return Values(tuple(points), tuple(at), tuple(pieces))
    return Values(tuple(points[k] for k in keep), tuple(at[k] for k in keep),
                  (pieces[0],) + tuple(pieces[k + 1] for k in keep))


_ALL = Values((), (), (True,))
_NONE = Values((), (), (False,))


def exact_number(value: Any, where: str) -> Fraction:
    """A number the engine computed as the exact rational it is; a refusal for anything
    else (a set, an infinite float)."""
    if type(value) is bool or not isinstance(value, (int, float)):
        raise UnsupportedError(f"{where} is not a number here ({type(value).__name__})")
    if isinstance(value, float) and not math.isfinite(value):
        raise UnsupportedError(f"{where} is {value} here: no threshold can be compared "
                               "with it exactly")
    return Fraction(value)


def threshold_guard(machine, node: ast.Node, param: str,
                    is_param: Callable[[ast.Node], bool]) -> ast.Node:
    """``node`` with each sub-formula ``is_param`` picks (a literal, at its place in the
    text) replaced by the name ``param``."""
    def walk(n: ast.Node) -> ast.Node:
        if is_param(n):
            return ast.Name(param, pos=n.pos)
        return ast.map_children(n, walk)
    return walk(node)


def values_of(machine, node: ast.Node, param: str, state: dict, *,
              bound: tuple[str, ...] = (), integer: bool = False) -> Values:
    """The values of ``param`` for which ``node`` holds in ``state`` (see the module)."""
    fn = ThresholdCompiler(machine, param, bound, integer).pred(node)
    return fn(machine.env(state))


class ThresholdCompiler:
    """Compiles a predicate into a function from an environment to the :class:`Values` of
    ``param`` for which it holds: what does not read ``param`` is compiled by the engine's
    own compiler and evaluated as the engine evaluates it; what does is combined here.

    Args:
        machine: the machine (its compiler and source for messages).
        param: the name the tuned number goes by in the formulas.
        bound: names bound around the formulas (an operation's parameters).
        integer: the number is an INTEGER (a division of it truncates: refused).
        shared: the numbering of the formulas whose sets an environment keeps (one dict for
            the compilers of every guard that share environments; None: its own).
    """

    def __init__(self, machine, param: str, bound: tuple[str, ...] = (),
                 integer: bool = False, shared: Optional[dict] = None) -> None:
        self.machine, self.param, self.integer = machine, param, integer
        self.comp = machine.compiler()
        self.bound = tuple(bound)
        self._free: dict = {}
        #: the formulas whose sets a state's environment keeps, numbered (see :meth:`pred`):
        #: give compilers of the same machine and number the same dict to share them
        self.shared: dict = {} if shared is None else shared

    def refuse(self, node: ast.Node, why: str, linear: bool = True) -> UnsupportedError:
        from .scope import render

        where = f" (line {node.pos.line}, column {node.pos.column})" if node.pos else ""
        what = "is not linear in the tuned number" if linear else \
            "reads the tuned number where tracecheck cannot solve for it"
        return UnsupportedError(f"the guard {what}: {why} in "
                                f"`{render(node, self.machine.source)[:80]}`{where}")

    def kind(self, node: ast.Node) -> str:
        """What ``node`` is, in words."""
        return _KINDS.get(type(node).__name__, f"a {type(node).__name__}")

    def free(self, node: ast.Node) -> bool:
        return self.param not in ast.free_names(node, self._free)

    def compiled(self, node: ast.Node) -> Callable[[dict], Any]:
        with self.comp.binding(self.bound):
            return self.comp.compile(node)

    def pred(self, node: ast.Node) -> Callable[[dict], Values]:
        fn = self._pred(node)
        if not isinstance(node, ast.Quant) or ast.free_names(node, self._free) & set(
                self.bound):
            return fn
        # a quantifier of the state alone (no bound name in it): its set is kept in the
        # state's environment, for every guard of the machine that has the same formula (one
        # operation's guard is often made of the others': `not(IDLE_OK or FASTER_OK …)`)
        key = ("$threshold", self.shared.setdefault(node, len(self.shared)))

        def kept(env: dict) -> Values:
            got = env.get(key)
            if got is None:
                got = env[key] = fn(env)
            return got
        return kept

    def _pred(self, node: ast.Node) -> Callable[[dict], Values]:
        if self.free(node):
            fn = self.compiled(node)
            return lambda env: _ALL if fn(env) else _NONE
        if isinstance(node, ast.And):
            parts = [self.pred(c) for c in conjuncts(node)]
            return lambda env: _all_of(parts, env)
        if isinstance(node, ast.Or):
            a, b = self.pred(node.left), self.pred(node.right)
            return lambda env: _either(a, b, env)
        if isinstance(node, ast.Not):
            a = self.pred(node.operand)
            return lambda env: a(env).complement()
        if isinstance(node, ast.Implies):
            a, b = self.pred(node.left), self.pred(node.right)
            return lambda env: _implies(a, b, env)
        if isinstance(node, ast.Equiv):
            a, b = self.pred(node.left), self.pred(node.right)

            def equiv(env: dict) -> Values:
                x, y = a(env), b(env)
                return x.intersect(y).union(x.complement().intersect(y.complement()))
            return equiv
        if isinstance(node, ast.Rel):
            return self.relation(node)
        if isinstance(node, ast.Quant):
            return self.quantifier(node)
        raise self.refuse(node, f"{self.kind(node)} of it", linear=False)

    def relation(self, node: ast.Rel) -> Callable[[dict], Values]:
        op = node.op
        if op == ":" and isinstance(node.left, ast.Name) and self.free(node.right):
            return self.membership(node)
        if op in (":", "/:") and isinstance(node.right, ast.BinOp) and node.right.op == "..":
            return self.between(node)
        if op not in ("<", "<=", ">", ">=", "=", "/="):
            raise self.refuse(node, f"the relation {op}", linear=False)
        left, right = self.expr(node.left), self.expr(node.right)

        def holds(env: dict) -> Values:
            (a1, b1), (a2, b2) = left(env), right(env)
            return _solve(a1 - a2, b1 - b2, op)  # a θ + b  op  0
        return holds

    def between(self, node: ast.Rel) -> Callable[[dict], Values]:
        """``e : lo..hi`` (``/:``: not) with the number in e, lo or hi: lo <= e <= hi (the
        interval holds whole numbers, e is one: B types it so)."""
        value, lo, hi = (self.expr(n) for n in (node.left, node.right.left, node.right.right))
        inside = node.op == ":"

        def holds(env: dict) -> Values:
            (a, b), (la, lb), (ha, hb) = value(env), lo(env), hi(env)
            got = _solve(la - a, lb - b, "<=").intersect(_solve(a - ha, b - hb, "<="))
            return got if inside else got.complement()
        return holds

    def membership(self, node: ast.Rel) -> Callable[[dict], Values]:
        """``θ : REAL`` (its type: every value), ``θ : NATURAL``, ``θ : lo..hi``."""
        right = node.right
        if isinstance(right, ast.Name) and right.id in _TYPES:
            low = _TYPES[right.id]
            made = _ALL if low is None else Values.half(Fraction(low), True, True)
            return lambda env: made
        if isinstance(right, ast.BinOp) and right.op == "..":
            lo, hi = self.compiled(right.left), self.compiled(right.right)

            def between(env: dict) -> Values:
                a, b = _exact(lo(env), right, self), _exact(hi(env), right, self)
                return Values.half(a, True, True).intersect(Values.half(b, False, True))
            return between
        raise self.refuse(node, "a membership of it in a set", linear=False)

    def quantifier(self, node: ast.Quant) -> Callable[[dict], Values]:
        """``#v.(v : S & P & Q …)`` (the union over the elements of S) or ``!v.(v : S & P
        … => R)`` (the intersection) as the engine evaluates it: every element of S (an
        error at any one is a refusal), each conjunct in its order, the ones after a
        conjunct that holds for no value not evaluated."""
        if self.param in node.ids:
            raise self.refuse(node, "a bound variable of the same name")
        if len(node.ids) != 1:
            raise self.refuse(node, "a quantifier over several variables (write one "
                              "quantifier per variable: #x.(#y.(…)))", linear=False)
        body = node.body
        forall = node.op == "!"
        if forall and not isinstance(body, ast.Implies):
            raise self.refuse(node, "a ∀ without `=>`", linear=False)
        given, rest = (body.left, body.right) if forall else (body, None)
        var = node.ids[0]
        conjs = conjuncts(given)
        gen = next((c for c in conjs if isinstance(c, ast.Rel) and c.op == ":"
                    and isinstance(c.left, ast.Name) and c.left.id == var
                    and var not in ast.free_names(c.right) and self.free(c.right)), None)
        if gen is None:
            raise self.refuse(node, f"no conjunct `{var} : S` (S not reading it) gives the "
                              "bound variable's values", linear=False)
        domain = self.compiled(gen.right)
        inner = ThresholdCompiler(self.machine, self.param, self.bound + node.ids,
                                  self.integer, self.shared)
        inner._free = self._free
        parts = [inner.pred(c) for c in conjs if c is not gen]
        then = inner.pred(rest) if forall else None

        def element(env: dict) -> Values:
            reach = _all_of(parts, env)
            if not forall:
                return reach
            if reach is _NONE:
                return _ALL
            got = then(env)
            return got if reach is _ALL else reach.complement().union(got)

        def over(env: dict) -> Values:
            elems = domain(env)
            if isinstance(elems, SymbolicSet) or not isinstance(elems, frozenset):
                raise self.refuse(node, "a bound variable whose values cannot be listed",
                                  linear=False)
            out = _ALL if forall else _NONE
            for e in elems:  # every one, as the engine does (no answer before all are seen)
                local = dict(env)
                local[var] = e
                got = element(local)
                if got is (_ALL if forall else _NONE):
                    continue
                out = got if out is (_ALL if forall else _NONE) else (
                    out.intersect(got) if forall else out.union(got))
            return out
        return over

    def expr(self, node: ast.Node) -> Callable[[dict], Form]:
        if self.free(node):
            fn = self.compiled(node)
            text = node

            def number(env: dict) -> Form:
                return _ZERO, _exact(fn(env), text, self)
            return number
        if isinstance(node, ast.Name):  # the tuned number itself
            return lambda env: (_ONE, _ZERO)
        if isinstance(node, ast.Neg):
            a = self.expr(node.operand)
            return lambda env: tuple(-x for x in a(env))  # type: ignore[return-value]
        if isinstance(node, ast.BinOp) and node.op in ("+", "-"):
            a, b = self.expr(node.left), self.expr(node.right)
            sign = 1 if node.op == "+" else -1
            return lambda env: _add(a(env), b(env), sign)
        if isinstance(node, ast.BinOp) and node.op in ("*", "/"):
            return self.product(node)
        if isinstance(node, ast.IfExpr) and all(self.free(c) for c, _ in node.branches):
            conds = [self.compiled(c) for c, _ in node.branches]
            values = [self.expr(v) for _, v in node.branches] + [self.expr(node.else_)]

            def chosen(env: dict) -> Form:
                for k, c in enumerate(conds):
                    if c(env):
                        return values[k](env)
                return values[-1](env)
            return chosen
        if isinstance(node, ast.IfExpr):
            raise self.refuse(node, "an IF whose condition reads it", linear=False)
        raise self.refuse(node, f"{self.kind(node)} of it", linear=False)

    def product(self, node: ast.BinOp) -> Callable[[dict], Form]:
        if node.op == "*" and not (self.free(node.left) or self.free(node.right)):
            raise self.refuse(node, "a product of two terms with it")
        if node.op == "/" and not self.free(node.right):
            raise self.refuse(node, "a division by a term with it")
        if node.op == "/" and self.integer:
            raise self.refuse(node, "an INTEGER division (it truncates)")
        a, b = self.expr(node.left), self.expr(node.right)
        by_left = node.op == "*" and self.free(node.left)

        def combine(env: dict) -> Form:
            x, y = a(env), b(env)
            if by_left:
                return x[1] * y[0], x[1] * y[1]
            if node.op == "*":
                return x[0] * y[1], x[1] * y[1]
            if y[1] == 0:
                raise self.refuse(node, "a division by zero")
            return x[0] / y[1], x[1] / y[1]
        return combine


def _exact(value: Any, node: ast.Node, comp: ThresholdCompiler) -> Fraction:
    try:
        return exact_number(value, "a term")
    except UnsupportedError as exc:
        raise comp.refuse(node, exc.message) from None


def _and(nodes: list[ast.Node]) -> ast.Node:
    if not nodes:
        return ast.BoolLit(True)
    out = nodes[0]
    for n in nodes[1:]:
        out = ast.And(out, n, pos=n.pos)
    return out


def _all_of(parts: list, env: dict) -> Values:
    out = _ALL
    for p in parts:
        got = p(env)
        if got is _ALL:
            continue
        if got is _NONE:
            return _NONE  # the others not evaluated, as the engine does not
        out = got if out is _ALL else out.intersect(got)
        if out.empty:
            return _NONE
    return out


def _either(a, b, env: dict) -> Values:
    x = a(env)
    if x is _ALL or x.full:
        return _ALL
    y = b(env)
    return y if x is _NONE else x if y is _NONE else x.union(y)


def _implies(a, b, env: dict) -> Values:
    x = a(env)
    if x is _NONE or x.empty:
        return _ALL
    y = b(env)
    return y if x is _ALL else x.complement().union(y)


def _add(x: Form, y: Form, sign: int) -> Form:
    return x[0] + sign * y[0], x[1] + sign * y[1]


def _solve(a: Fraction, b: Fraction, op: str) -> Values:
    """The θ with ``a θ + b  op  0``."""
    if a == 0:
        holds = {"<": b < 0, "<=": b <= 0, ">": b > 0, ">=": b >= 0, "=": b == 0,
                 "/=": b != 0}[op]
        return _ALL if holds else _NONE
    root = -b / a
    if op in ("=", "/="):
        point = Values((root,), (True,), (False, False))
        return point if op == "=" else point.complement()
    # a θ + b < 0: θ < root for a > 0, θ > root for a < 0
    below = op in ("<", "<=")
    if a < 0:
        below = not below
    return Values.half(root, above=not below, closed=op in ("<=", ">="))
