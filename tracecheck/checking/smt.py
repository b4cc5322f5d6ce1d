"""Shields over every state, not only recorded ones: the B subset translated to SMT (z3).

A machine's state becomes solver variables (:mod:`.encoding`); constants take the machine's
values. Quantifiers and comprehensions over elements are unrolled, applications record
their well-definedness condition under the path that reaches them. What cannot be
translated is an error naming the construct and its position — never skipped. The
obligations asked of the solver are in :mod:`.prove`.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Optional

from ..b import ast
from ..b.linear import real_parameters
from ..b.values import BUILTIN_SET_VALUES, Elem, FuncValue
from ..errors import UnsupportedError
from .encoding import (ElementFunction, ElementSet, ElementTerm, FiniteFunction,
                       encode_variable, load_z3)

__all__ = ["Translator", "MAX_EXPONENT", "MAX_DEGREE"]


@dataclass
class _Nums:
    """A set of numbers: (condition, value) pairs — value is in the set where condition."""

    items: list


_EMPTY = object()  # the set {} (its carrier comes from the other side)


@dataclass
class _Pair:
    """``a |-> b`` of numbers: only an argument of an application (``field(x |-> y)``)."""

    left: Any
    right: Any

#: The largest literal exponent ``x ** n`` is translated with (larger: ``unknown``).
MAX_EXPONENT = 64
#: The largest degree of a translated product (``(x ** 64) ** 64`` is x to the 4096:
#: nested powers multiply, and z3 spends unbounded time and memory on such a term while it
#: is asserted, before its own timeout starts; larger: ``unknown``).
MAX_DEGREE = 64


class Translator:
    """Translates formulas of one machine over one state: ``variables`` holds each state
    variable's solver encoding, ``definedness`` the well-definedness conditions met on the
    way (each under the condition of the path to it), ``side_conditions`` the definitions
    of the fresh variables translations introduce (min and max of a set of numbers), which
    every question to the solver must include."""

    #: Whether ``x : {a, b}`` of numbers is translated (``eval``'s solver; shields' guards
    #: with such a set keep being decided by the evaluator, their allowed set not computed).
    number_sets = False

    def __init__(self, machine, prefix: str = "") -> None:
        self.z3 = load_z3()
        self.machine = machine
        self.prefix = prefix
        self.variables: dict[str, Any] = {}
        self.definedness: list[tuple[Any, ast.Node]] = []
        self.path: list = []
        self._conj: list = []  # (path condition, conjunction of the path up to it)
        self.side_conditions: list = []
        self._memo: dict = {}  # translated sub-formulas, see translate
        self._raw: list = []  # every condition met, with the path it was met under
        self._free: dict = {}  # free names by node
        self._degrees: dict = {}  # z3 term id -> (term, its degree as a polynomial)
        #: the action space's bounds of REAL parameters, ``{op: ({p: low}, {p: high})}``:
        #: an operation is enabled where its guard allows a value inside them
        self.bounds: dict = {}
        self.file, self.source = machine.file, machine.source  # what positions refer to
        for name in machine.variables:
            self.variables[name] = encode_variable(self.z3, machine, name, prefix)

    def share_state(self, other: "Translator") -> None:
        """Translate over the state of ``other`` (its variables, and the side conditions
        both add to): two machines' formulas about the same states."""
        self.variables, self.side_conditions = other.variables, other.side_conditions

    # -- errors
    def fail(self, node: ast.Node, what: str) -> UnsupportedError:
        pos = node.pos
        return UnsupportedError(f"cannot translate {what} to SMT",
                                file=self.file, source=self.source,
                                line=pos.line if pos else None,
                                column=pos.column if pos else None)

    @contextmanager
    def reading(self, file: str, source: str):
        """Translate a formula the user gave: what cannot be translated points into
        ``source`` (named ``file``: ``--implies``), not into the machine."""
        saved = self.file, self.source
        self.file, self.source = file, source
        try:
            yield
        finally:
            self.file, self.source = saved

    def defined(self, build: Callable[[], Any]) -> tuple[Any, Any]:
        """``build()`` (a translation) and the condition that it is well-defined: the
        conditions met while translating it, each under its path."""
        start = len(self.definedness)
        value = build()
        conds = [c for c, _ in self.definedness[start:]]
        return value, self.z3.And(conds) if conds else self.z3.BoolVal(True)

    # -- formulas
    def pred(self, node: ast.Node, env: Optional[dict] = None) -> Any:
        value = self.translate(node, env or {})
        if not self.z3.is_bool(value):
            raise self.fail(node, "a predicate that is not one")
        return value

    def translate(self, node: ast.Node, env: dict) -> Any:
        method = getattr(self, "t_" + type(node).__name__, None)
        if method is None:
            raise self.fail(node, type(node).__name__)
        if not isinstance(node, _SHARED) or not all(isinstance(v, Elem) for v in env.values()):
            return method(node, env)
        # a shield's definitions are expanded at every use: translate each sub-formula once
        # per binding of its element variables, and replay its well-definedness conditions
        # under the path where it is used again
        key = (node, tuple(sorted((k, v) for k, v in env.items()
                                  if k in ast.free_names(node, self._free))))
        hit = self._memo.get(key)
        if hit is None:
            depth, start = len(self.path), len(self._raw)
            value = method(node, env)
            z3 = self.z3
            inner = [(z3.Implies(z3.And(list(p[depth:])), c) if len(p) > depth else c, n)
                     for c, p, n in self._raw[start:]]  # under the paths inside the formula
            self._memo[key] = (value, inner)
            return value
        value, inner = hit
        for cond, n in inner:
            self._need(cond, n)
        return value

    def t_Name(self, node: ast.Name, env: dict) -> Any:
        if node.id in env:
            return env[node.id]
        if node.id in self.variables:
            return self.variables[node.id]
        if node.id in self.machine.base_env:
            return self._constant(self.machine.base_env[node.id], node)
        if node.id in ("REAL", "INTEGER", "BOOL", "NATURAL", "NATURAL1", "FLOAT"):
            return ("type", node.id)
        raise self.fail(node, f"the name {node.id}")

    def _constant(self, value: Any, node: ast.Node) -> Any:
        z3 = self.z3
        if isinstance(value, bool):
            return z3.BoolVal(value)
        if isinstance(value, int):
            return z3.IntVal(value)
        if isinstance(value, float):
            return z3.RealVal(Fraction(value))
        if isinstance(value, Elem):
            return value
        if isinstance(value, frozenset) and all(isinstance(v, Elem) for v in value):
            sets = self.machine.sets
            carrier = next((s for s, elems in sets.items() if value <= set(elems)), None)
            if carrier is not None:
                return ElementSet(carrier, {e: z3.BoolVal(e in value) for e in sets[carrier]})
        if isinstance(value, FuncValue) and value.map and all(
                isinstance(k, Elem) for k in value.map) and len(
                {type(v) for v in value.map.values()}) == 1 and type(
                next(iter(value.map.values()))) in (bool, int, float):
            sets = self.machine.sets  # a constant function over elements: ElementFunction
            carrier = next((s for s, elems in sets.items() if set(value.map) <= set(elems)),
                           None)
            if carrier is not None:
                filler = next(iter(value.map.values()))
                return ElementFunction(carrier, {
                    e: (z3.BoolVal(e in value.map),
                        self._constant(value.map.get(e, filler), node)) for e in sets[carrier]})
        raise self.fail(node, f"the constant value {value!r}")

    def t_IntLit(self, node, env):
        return self.z3.IntVal(node.value)

    def t_RealLit(self, node, env):
        return self.z3.RealVal(Fraction(node.value))

    def t_BoolLit(self, node, env):
        return self.z3.BoolVal(node.value)

    def t_Neg(self, node, env):
        return -self._num(node.operand, env)

    def _num(self, node, env):
        value = self.translate(node, env)
        if not self.z3.is_arith(value):
            raise self.fail(node, "a number that is not one")
        return value

    def t_BinOp(self, node: ast.BinOp, env: dict) -> Any:
        z3 = self.z3
        if node.op in ("+", "-", "*", "/", "**", "mod"):
            left = self.translate(node.left, env)
            if isinstance(left, ElementSet) and node.op == "-":
                return self._setop(node, left, self.translate(node.right, env))
            a, b = left, self._num(node.right, env)
            if node.op == "+":
                return a + b
            if node.op == "-":
                return a - b
            if node.op == "*":
                self._bound(node, self.degree(a) + self.degree(b))
                return a * b
            if node.op == "/":
                self._bound(node, self.degree(a) + self.degree(b))
                self._need(b != 0, node)
                if z3.is_int(a) and z3.is_int(b):  # B: towards zero
                    q = _abs(z3, a) / _abs(z3, b)
                    return z3.If(a * b >= 0, q, -q)
                return a / b
            if node.op == "**":
                return self._power(node, a)
            self._bound(node, self.degree(a) + self.degree(b))
            self._need(z3.And(a >= 0, b > 0), node)
            return a % b
        if node.op in ("\\", "\\/", "/\\"):
            return self._setop(node, self.translate(node.left, env),
                               self.translate(node.right, env))
        raise self.fail(node, f"the operator {node.op}")

    def _power(self, node: ast.BinOp, a) -> Any:
        """``a ** n`` for a literal natural n up to :data:`MAX_EXPONENT`, by repeated
        squaring (a term of about log n products, not n)."""
        n = node.right.value if isinstance(node.right, ast.IntLit) else None
        if n is None or n < 0:
            raise self.fail(node, "a power whose exponent is not a literal natural")
        if n > MAX_EXPONENT:
            raise self.fail(node, f"a power with exponent {n} (at most {MAX_EXPONENT}: "
                                  "the solver cannot decide such products in useful time)")
        self._bound(node, self.degree(a) * n)
        out = self.z3.RealVal(1) if self.z3.is_real(a) else self.z3.IntVal(1)
        while n:
            if n & 1:
                out = out * a
            n >>= 1
            if n:
                a = a * a
        return out

    def degree(self, term) -> int:
        """The degree of the arithmetic ``term`` as a polynomial in the variables (a
        quotient or remainder counts as a product); a number is 0, a variable 1."""
        z3 = self.z3
        kinds = (z3.Z3_OP_MUL, z3.Z3_OP_DIV, z3.Z3_OP_IDIV, z3.Z3_OP_MOD)
        todo = [term]
        while todo:  # a term can be deeper than Python's recursion allows
            t = todo[-1]
            if t.get_id() in self._degrees:
                todo.pop()
                continue
            args = [c for c in t.children() if z3.is_arith(c)] if z3.is_app(t) else []
            missing = [c for c in args if c.get_id() not in self._degrees]
            if missing:
                todo.extend(missing)
                continue
            todo.pop()
            parts = [self._degrees[c.get_id()][1] for c in args]
            if z3.is_int_value(t) or z3.is_rational_value(t) or z3.is_algebraic_value(t):
                got = 0
            elif not z3.is_app(t) or t.num_args() == 0:
                got = 1
            elif t.decl().kind() in kinds:
                got = sum(parts)
            else:
                got = max(parts, default=0)
            self._degrees[t.get_id()] = (t, got)  # the term kept: z3 reuses freed ids
        return self._degrees[term.get_id()][1]

    def _bound(self, node: ast.Node, degree: int) -> None:
        if degree > MAX_DEGREE:
            raise self.fail(node, f"a term of degree {degree:,} (its powers and products "
                                  f"multiply; at most {MAX_DEGREE}: the solver cannot decide "
                                  "such a polynomial in useful time)")

    def _setop(self, node, a, b) -> Any:
        z3 = self.z3
        if node.op == "\\/" and isinstance(a, _Nums) and isinstance(b, _Nums):
            return _Nums(a.items + b.items)
        if a is _EMPTY and isinstance(b, ElementSet):
            a = ElementSet(b.carrier, {e: z3.BoolVal(False) for e in b.member})
        if b is _EMPTY and isinstance(a, ElementSet):
            b = ElementSet(a.carrier, {e: z3.BoolVal(False) for e in a.member})
        a, b = self._as_set(a, node), self._as_set(b, node)
        if a.carrier != b.carrier:
            raise self.fail(node, "an operation on sets of different carriers")
        op = node.op
        fn = {"-": lambda x, y: z3.And(x, z3.Not(y)), "\\": lambda x, y: z3.And(x, z3.Not(y)),
              "\\/": z3.Or, "/\\": z3.And}[op]
        return ElementSet(a.carrier, {e: fn(a.member[e], b.member[e]) for e in a.member})

    def _as_set(self, value, node) -> ElementSet:
        if isinstance(value, ElementSet):
            return value
        raise self.fail(node, "a set of elements that is not one")

    def t_SetExt(self, node: ast.SetExt, env: dict) -> Any:
        z3 = self.z3
        items = [self.translate(i, env) for i in node.items]
        if not items:
            return _EMPTY
        if all(isinstance(i, Elem) for i in items):
            sets = self.machine.sets
            carrier = next((s for s, elems in sets.items() if set(items) <= set(elems)), None)
            if carrier is not None:
                return ElementSet(carrier, {e: z3.BoolVal(e in items) for e in sets[carrier]})
        if all(z3.is_arith(i) for i in items):
            return _Nums([(z3.BoolVal(True), i) for i in items])
        raise self.fail(node, "this set")

    def t_Comprehension(self, node: ast.Comprehension, env: dict) -> Any:
        """``{v | v : S & P}`` as a set of elements, ``{v . v : S & P | E}`` as numbers."""
        z3 = self.z3
        if len(node.ids) != 1:
            raise self.fail(node, "a comprehension over several variables")
        (var,) = node.ids
        carrier, member = self._generator(node, var, node.pred, env)
        cells = {}
        for e in self.machine.sets[carrier]:
            self.path.append(member(e))
            try:
                held = z3.And(member(e), self.pred(node.pred, {**env, var: e}))
                cells[e] = (held, self._num(node.expr, {**env, var: e})
                            if node.expr is not None else None)
            finally:
                self.path.pop()
        if node.expr is None:
            return ElementSet(carrier, {e: c for e, (c, _) in cells.items()})
        return _Nums(list(cells.values()))

    def _generator(self, node, var: str, pred: ast.Node, env: dict):
        """The carrier of ``var : S`` in ``pred`` and the condition that an element is in S."""
        from ..b.bindings import conjuncts

        gen = next((c for c in conjuncts(pred) if isinstance(c, ast.Rel) and c.op == ":"
                    and isinstance(c.left, ast.Name) and c.left.id == var), None)
        if gen is None:
            raise self.fail(node, f"a binding of {var} without `{var} : S` over a set of "
                                  "elements")
        if isinstance(gen.right, ast.Name) and gen.right.id in self.machine.sets:
            return gen.right.id, lambda e: self.z3.BoolVal(True)
        try:
            s = self.translate(gen.right, env)
        except UnsupportedError:
            s = None
        if not isinstance(s, ElementSet):
            raise self.fail(node, f"a binding of {var} over something that is not a set of "
                                  "elements")
        return s.carrier, lambda e: s.member[e]

    def t_Image(self, node: ast.Image, env: dict) -> Any:
        """``F[S]`` of a function over elements: its values at the members of S."""
        f, s = self.translate(node.rel, env), self.translate(node.arg, env)
        if s is _EMPTY:
            return _Nums([])
        if not (isinstance(f, ElementFunction) and isinstance(s, ElementSet)
                and f.carrier == s.carrier):
            raise self.fail(node, "this image")
        return _Nums([(self.z3.And(s.member[e], d), v) for e, (d, v) in f.cells.items()])

    def t_Apply(self, node: ast.Apply, env: dict) -> Any:
        z3 = self.z3
        f = self.translate(node.fn, env)
        if len(node.args) != 1 or not isinstance(f, (ElementFunction, FiniteFunction)):
            raise self.fail(node, "this application")
        x = self.translate(node.args[0], env)
        if isinstance(f, FiniteFunction):
            return self._apply_finite(node, f, x)
        if isinstance(x, ElementTerm) and x.carrier == f.carrier:  # f(ahead): by cases
            cells = [(x.term == x.consts[e], d, v) for e, (d, v) in f.cells.items()]
            self._need(z3.Or([z3.And(is_e, d) for is_e, d, _ in cells]), node)
            out = cells[-1][2]
            for is_e, _, v in reversed(cells[:-1]):
                out = z3.If(is_e, v, out)
            return out
        if not isinstance(x, Elem) or x not in f.cells:
            raise self.fail(node, "an application to something that is not an element")
        defined, value = f.cells[x]
        self._need(defined, node)
        return value

    def _apply_finite(self, node: ast.Apply, f: FiniteFunction, x) -> Any:
        """``f(i)`` or ``f(i |-> j)`` of a function over integers: the array's value there,
        well-defined where the index is in the domain."""
        z3 = self.z3
        pairs = isinstance(f.keys[0], tuple)
        index = (x.left, x.right) if isinstance(x, _Pair) else (x,)
        if len(index) != (2 if pairs else 1) or not all(z3.is_int(i) for i in index):
            raise self.fail(node, "an application to an index of another kind than the "
                                  "function's domain")
        self._need(_in_keys(z3, f.keys, index), node)
        return f.value(f.array[index] if len(index) == 1 else f.array[index[0], index[1]])

    def t_Pair(self, node: ast.Pair, env: dict) -> Any:
        return _Pair(self._num(node.left, env), self._num(node.right, env))

    def t_Call(self, node: ast.Call, env: dict) -> Any:
        z3 = self.z3
        name = node.name
        if name == "dom":
            f = self.translate(node.args[0], env)
            if isinstance(f, ElementFunction):
                return ElementSet(f.carrier, {e: d for e, (d, _) in f.cells.items()})
        if name == "card":
            s = self.translate(node.args[0], env)
            if isinstance(s, ElementSet):
                return z3.Sum([z3.If(c, 1, 0) for c in s.member.values()]) if s.member \
                    else z3.IntVal(0)
            if isinstance(s, _Nums):  # {x, y, z}: how many different values are in it
                return _count_distinct(z3, s)
        if name == "bool":
            return self.pred(node.args[0], env)
        if name in ("RABS", "abs"):
            return _abs(z3, self._num(node.args[0], env))
        if name == "floor":
            return z3.ToInt(self._num(node.args[0], env))
        if name == "ceiling":
            return -z3.ToInt(-self._num(node.args[0], env))
        if name == "real":
            return z3.ToReal(self._num(node.args[0], env))
        if name in ("min", "max"):
            s = self.translate(node.args[0], env)
            if isinstance(s, _Nums):
                return self._extreme(node, name, s)
        raise self.fail(node, f"{name}(…) here")

    def _extreme(self, node, name: str, s: _Nums) -> Any:
        """``min``/``max`` of a set of numbers: a fresh variable, defined to be it (where
        the set is not empty — that is its well-definedness condition)."""
        z3 = self.z3
        if not s.items:
            self._need(z3.BoolVal(False), node)
            return z3.RealVal(0)
        if all(z3.is_true(c) for c, _ in s.items):  # {a, b, c}: no fresh variable needed
            out = s.items[0][1]
            for _, x in s.items[1:]:
                out = z3.If(x < out, x, out) if name == "min" else z3.If(x > out, x, out)
            return out
        make = z3.Int if z3.is_int(s.items[0][1]) else z3.Real
        m = make(f"{name}#{len(self.side_conditions)}")
        conds = [c for c, _ in s.items]
        bound = (lambda v: m <= v) if name == "min" else (lambda v: m >= v)
        self.side_conditions.append(z3.Implies(z3.Or(conds), z3.Or([z3.And(c, m == v)
                                                          for c, v in s.items])))
        self.side_conditions.append(z3.And([z3.Implies(c, bound(v)) for c, v in s.items]))
        self._need(z3.Or(conds), node)
        return m

    def t_Rel(self, node: ast.Rel, env: dict) -> Any:
        z3 = self.z3
        op = node.op
        if op in ("<", "<=", ">", ">="):
            a, b = self._num(node.left, env), self._num(node.right, env)
            return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b}[op]
        if op in ("=", "/="):
            a, b = self.translate(node.left, env), self.translate(node.right, env)
            if a is _EMPTY and isinstance(b, ElementSet):
                a, b = b, a
            if b is _EMPTY and isinstance(a, ElementSet):
                b = ElementSet(a.carrier, {e: z3.BoolVal(False) for e in a.member})
            if isinstance(a, Elem) and isinstance(b, Elem):
                eq = z3.BoolVal(a == b)
            elif isinstance(a, ElementTerm) or isinstance(b, ElementTerm):
                eq = self._same_element(node, a, b)
            elif isinstance(a, ElementSet) and isinstance(b, ElementSet) and a.carrier == b.carrier:
                eq = z3.And([a.member[e] == b.member[e] for e in a.member])
            elif z3.is_expr(a) and z3.is_expr(b) and not isinstance(a, Elem):
                eq = a == b
            else:
                raise self.fail(node, "this equality")
            return eq if op == "=" else z3.Not(eq)
        if op in (":", "/:"):
            held = self._member(node, self.translate(node.left, env), node.right, env)
            return held if op == ":" else z3.Not(held)
        if op in ("<:", "/<:"):
            a = self.translate(node.left, env)
            b = None if isinstance(a, _Nums) else self.translate(node.right, env)
            if isinstance(a, _Nums):  # {x, y} <: 0..9: each number in it is in the right side
                held = z3.And([z3.Implies(c, self._member(node, v, node.right, env))
                               for c, v in a.items])
            elif isinstance(b, tuple) and b[0] == "type":  # S <: Vehicles-like carrier
                held = z3.BoolVal(True)
            elif isinstance(b, ElementSet) and isinstance(a, ElementSet) and a.carrier == b.carrier:
                held = z3.And([z3.Implies(a.member[e], b.member[e]) for e in a.member])
            else:
                raise self.fail(node, "this inclusion")
            return held if op == "<:" else z3.Not(held)
        raise self.fail(node, f"the relation {op}")

    def _same_element(self, node, a, b) -> Any:
        """``a = b`` where one side is an element the solver chooses."""
        term = a if isinstance(a, ElementTerm) else b
        other = b if term is a else a
        if isinstance(other, ElementTerm):
            if other.carrier != term.carrier:
                raise self.fail(node, "an equality of elements of different sets")
            return term.term == other.term
        if isinstance(other, Elem):
            const = term.consts.get(other)
            return term.term == const if const is not None else self.z3.BoolVal(False)
        raise self.fail(node, "this equality")

    def _member(self, node, x, right: ast.Node, env: dict) -> Any:
        z3 = self.z3
        if isinstance(x, ElementTerm):
            if isinstance(right, ast.Name) and right.id in self.machine.sets:
                return z3.BoolVal(right.id == x.carrier)
            s = self.translate(right, env)
            if isinstance(s, ElementSet) and s.carrier == x.carrier:
                return z3.Or([z3.And(x.term == x.consts[e], c) for e, c in s.member.items()])
            raise self.fail(node, "this membership")
        if (isinstance(x, FiniteFunction) and isinstance(right, ast.BinOp)
                and right.op in ("-->", "+->")):
            return self._function_member(node, x, right, env)
        if isinstance(right, ast.Name) and right.id in self.machine.sets and isinstance(x, Elem):
            return z3.BoolVal(x in self.machine.sets[right.id])
        if isinstance(right, ast.Name) and right.id in ("REAL", "INTEGER", "BOOL", "FLOAT"):
            return z3.BoolVal(True)  # the type checker made sure
        if isinstance(right, ast.Name) and right.id in _NATURALS and z3.is_arith(x):
            lo, hi = _NATURALS[right.id]
            return z3.And(x >= lo, x <= hi) if hi is not None else x >= lo
        if (isinstance(right, ast.BinOp) and right.op in ("-->", "+->")
                and isinstance(x, ElementFunction)):
            dom = self.translate(right.left, env) if not (isinstance(right.left, ast.Name)
                                                  and right.left.id in self.machine.sets) else None
            cells = x.cells
            r = right.right  # each value in the range too (0..3: not every integer)
            ranged = z3.BoolVal(True) if isinstance(r, ast.Name) and r.id in (
                "REAL", "INTEGER", "BOOL", "FLOAT") else z3.And(
                [z3.Implies(d, self._member(node, v, r, env)) for d, v in cells.values()])
            if dom is None:
                return z3.And(ranged, z3.And([d for d, _ in cells.values()])) \
                    if right.op == "-->" else ranged
            dom = self._as_set(dom, right)
            if right.op == "-->":
                return z3.And(ranged, z3.And([d == dom.member[e] for e, (d, _) in cells.items()]))
            return z3.And(ranged, z3.And([z3.Implies(d, dom.member[e])
                                          for e, (d, _) in cells.items()]))
        if isinstance(right, ast.BinOp) and right.op == ".." and self.z3.is_arith(x):
            lo, hi = self._num(right.left, env), self._num(right.right, env)
            return z3.And(lo <= x, x <= hi)
        if isinstance(right, ast.Call) and right.name == "POW":
            inner = right.args[0]
            if (isinstance(inner, ast.Name) and inner.id in self.machine.sets
                    and isinstance(x, ElementSet)):
                return z3.BoolVal(True)
        s = self.translate(right, env)
        if isinstance(s, ElementSet) and isinstance(x, Elem) and x in s.member:
            return s.member[x]
        if isinstance(s, _Nums) and z3.is_arith(x) and self.number_sets:  # x : {1, y, 3}
            return z3.Or([z3.And(c, x == v) for c, v in s.items])
        raise self.fail(node, "this membership")

    def _function_member(self, node, f: FiniteFunction, right: ast.BinOp, env: dict) -> Any:
        """``f : D --> R`` of a function over integers: its domain is its keys by its
        encoding, so D must be a set of the constants; each value in R."""
        from ..b.values import explicit

        z3 = self.z3
        try:
            dom = explicit(self.machine.compile(right.left)(dict(self.machine.base_env)))
        except Exception:  # noqa: BLE001 - not a set of the constants: not translated
            raise self.fail(node, "a function's domain that is not a set of the constants") \
                from None
        if right.op == "-->" and set(dom) != set(f.keys) or not set(f.keys) <= set(dom):
            return z3.BoolVal(False)
        r = right.right
        if isinstance(r, ast.Name) and (r.id in ("REAL", "INTEGER", "BOOL")
                                        or r.id == f.carrier):
            return z3.BoolVal(True)
        return z3.And([self._member(node, f.value(f.at(k)), r, env) for k in f.keys])

    def _short_circuit(self, node, env, reached_when_left: bool, combine):
        """``combine(left, right)``: the right side is reached (for well-definedness) only
        where the left side is ``reached_when_left``."""
        a = self.pred(node.left, env)
        self.path.append(a if reached_when_left else self.z3.Not(a))
        try:
            return combine(a, self.pred(node.right, env))
        finally:
            self.path.pop()

    def t_And(self, node, env):
        return self._short_circuit(node, env, True, self.z3.And)

    def t_Or(self, node, env):
        return self._short_circuit(node, env, False, self.z3.Or)

    def t_Implies(self, node, env):
        return self._short_circuit(node, env, True, self.z3.Implies)

    def t_Equiv(self, node, env):
        return self.pred(node.left, env) == self.pred(node.right, env)

    def t_Not(self, node, env):
        return self.z3.Not(self.pred(node.operand, env))

    def t_IfExpr(self, node: ast.IfExpr, env: dict) -> Any:
        z3 = self.z3
        conds, values = [], []
        for cond, value in node.branches:
            c = self.pred(cond, env)
            self.path.append(c)
            try:
                values.append(self.translate(value, env))
            finally:
                self.path.pop()
            conds.append(c)
            self.path.append(z3.Not(c))
        try:
            out = self.translate(node.else_, env)
        finally:
            del self.path[len(self.path) - len(conds):]
        if not all(z3.is_expr(v) or type(v) in (bool, int) for v in (*values, out)):
            raise self.fail(node, "an IF-THEN-ELSE whose values are sets")  # z3.If takes terms
        for c, v in zip(reversed(conds), reversed(values)):
            out = z3.If(c, v, out)
        return out

    def t_Let(self, node: ast.Let, env: dict) -> Any:
        from ..b.bindings import conjuncts

        inner = dict(env)
        for c in conjuncts(node.pred):
            if (isinstance(c, ast.Rel) and c.op == "=" and isinstance(c.left, ast.Name)
                    and c.left.id in node.ids):
                inner[c.left.id] = self.translate(c.right, inner)
            else:
                raise self.fail(c, "a LET condition that is not an equation")
        return self.translate(node.body, inner)

    def t_Quant(self, node: ast.Quant, env: dict) -> Any:
        z3 = self.z3
        if len(node.ids) != 1:
            raise self.fail(node, "a quantifier over several variables")
        (var,) = node.ids
        body = node.body
        carrier, _ = self._generator(node, var, body.left if isinstance(body, ast.Implies)
                                     else body, env)
        parts = [self.pred(body, {**env, var: e}) for e in self.machine.sets[carrier]]
        if node.op == "#":
            return z3.Or(parts) if parts else z3.BoolVal(False)
        return z3.And(parts) if parts else z3.BoolVal(True)

    def _need(self, cond, node: ast.Node) -> None:
        self.definedness.append((self.z3.Implies(self._path_condition(), cond), node))
        self._raw.append((cond, tuple(self.path), node))

    def _path_condition(self) -> Any:
        """The conjunction of :attr:`path`, built on from the last one (the path grows and
        shrinks like a stack): a condition met deep in a formula costs one conjunction,
        not one over the whole path — the authors' RSS shield has ~30 000 of them."""
        stack, n = self._conj, 0
        while n < len(stack) and n < len(self.path) and stack[n][0] is self.path[n]:
            n += 1
        del stack[n:]
        for c in self.path[n:]:
            stack.append((c, self.z3.And(stack[-1][1], c) if stack else c))
        return stack[-1][1] if stack else self.z3.BoolVal(True)

    def invariant(self) -> Any:
        inv = self.machine.invariant_node
        return self.pred(inv) if inv is not None else self.z3.BoolVal(True)

    def guard(self, op: str) -> Any:
        """When ``op`` is enabled: its guard; with REAL parameters, for some values of them
        (∃ over the reals, which z3 decides for linear arithmetic)."""
        operation = self.machine.operations[op]
        if operation.params and real_parameters(operation):
            bound = self.parameters(op)
            guard = self.pred(operation.guard, bound)
            low, high = self.bounds.get(op, ({}, {}))  # the action space's, where given
            box = [self.z3.RealVal(Fraction(low[p])) <= v for p, v in bound.items() if p in low]
            box += [v <= self.z3.RealVal(Fraction(high[p])) for p, v in bound.items()
                    if p in high]
            return self.z3.Exists(list(bound.values()), self.z3.And(*box, guard) if box
                                  else guard)
        if operation.params:
            raise self.fail(operation.guard, f"the guard of {op}, which has parameters")
        return self.pred(operation.guard) if operation.guard is not None else \
            self.z3.BoolVal(True)


    def parameters(self, op: str) -> dict:
        """``op``'s REAL parameters as solver reals, named ``OP.p`` (the same in every
        translator: two shields' guards then speak of the same action)."""
        return {p: self.z3.Real(f"{op}.{p}") for p in self.machine.operations[op].params}

    def guard_at(self, op: str) -> Any:
        """``op``'s guard with its REAL parameters free (:meth:`parameters`): which actions
        it allows, not only whether some."""
        return self.pred(self.machine.operations[op].guard, self.parameters(op))


# sub-formulas translated once per binding (see Translator.translate)
_SHARED = (ast.Comprehension, ast.Image, ast.Call, ast.Quant, ast.IfExpr)


def _in_keys(z3, keys: tuple, index: tuple) -> Any:
    """That ``index`` (z3 integers) is one of ``keys``: bounds where the keys are a range
    (or a product of two), else one equation per key."""
    axes = list(zip(*keys)) if isinstance(keys[0], tuple) else [keys]
    spans = [(min(a), max(a)) for a in axes]
    full = 1
    for lo, hi in spans:
        full *= hi - lo + 1
    if full == len(set(keys)):
        return z3.And([z3.And(lo <= i, i <= hi) for (lo, hi), i in zip(spans, index)])
    return z3.Or([z3.And([i == v for i, v in zip(index, k if isinstance(k, tuple) else (k,))])
                  for k in keys])


def _abs(z3, x):
    return z3.If(x >= 0, x, -x)


#: The built-in sets of integers with bounds: (least, greatest or None), as the evaluator has
#: them (NAT is 0..MAXINT).
_NATURALS = {"NATURAL": (0, None), "NATURAL1": (1, None),
             **{n: (BUILTIN_SET_VALUES[n].lo, BUILTIN_SET_VALUES[n].hi)
                for n in ("NAT", "NAT1", "INT")}}


def _count_distinct(z3, s: _Nums):
    """``card`` of a set of numbers: each item counts where it is in the set and equals
    none of the items in it before it."""
    terms = []
    for i, (c, v) in enumerate(s.items):
        before = [z3.And(d, w == v) for d, w in s.items[:i]]
        terms.append(z3.If(z3.And(c, z3.Not(z3.Or(before))) if before else c, 1, 0))
    return z3.Sum(terms) if terms else z3.IntVal(0)
