"""Shields over every state, not only recorded ones: the B subset translated to SMT (z3).

A machine's state becomes solver variables (:mod:`.encoding`); constants take the machine's
values. Quantifiers and comprehensions over elements are unrolled, applications record
their well-definedness condition under the path that reaches them. What cannot be
translated is an error naming the construct and its position — never skipped. The
obligations asked of the solver are in :mod:`.prove`.
"""

from __future__ import annotations

from contextlib import contextmanager
from fractions import Fraction
from typing import Any, Callable, Optional

from ..b import ast
from ..b.linear import real_parameters
from ..b.values import Elem, FuncValue
from ..errors import UnsupportedError
from .encoding import (ElementFunction, ElementSet, ElementTerm, FiniteFunction, NumberSet,
                       encode_variable, load_z3)
from .smt_sets import EMPTY, UNBOUND, Nums, SetTranslation

__all__ = ["Translator", "MAX_EXPONENT", "MAX_DEGREE"]


#: The largest literal exponent ``x ** n`` is translated with (larger: ``unknown``).
MAX_EXPONENT = 64
#: The largest degree of a translated product (``(x ** 64) ** 64`` is x to the 4096:
#: nested powers multiply, and z3 spends unbounded time and memory on such a term while it
#: is asserted, before its own timeout starts; larger: ``unknown``).
MAX_DEGREE = 64


class Translator(SetTranslation):
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
            if env[node.id] is UNBOUND:  # a quantified name whose value is not chosen yet
                raise self.fail(node, f"{node.id} before the quantifier binds it")
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
            if isinstance(left, (ElementSet, NumberSet)) and node.op == "-":
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
            if isinstance(s, Nums):  # {x, y, z}: how many different values are in it
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
            if isinstance(s, Nums):
                return self._extreme(node, name, s)
        raise self.fail(node, f"{name}(…) here")

    def _extreme(self, node, name: str, s: Nums) -> Any:
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
            a = self.translate(node.left, env)
            if isinstance(a, FiniteFunction):  # a whole map: cell by cell
                eq = self.function_equals(node, a, node.right, env)
                return eq if op == "=" else z3.Not(eq)
            b = self.translate(node.right, env)
            if isinstance(b, FiniteFunction):
                eq = self.function_equals(node, b, node.left, env)
                return eq if op == "=" else z3.Not(eq)
            if isinstance(a, NumberSet) or isinstance(b, NumberSet):
                eq = self.int_set(a, node) == self.int_set(b, node)
                return eq if op == "=" else z3.Not(eq)
            if a is EMPTY and isinstance(b, ElementSet):
                a, b = b, a
            if b is EMPTY and isinstance(a, ElementSet):
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
            b = None if isinstance(a, Nums) else self.translate(node.right, env)
            if isinstance(a, Nums):  # {x, y} <: 0..9: each number in it is in the right side
                held = z3.And([z3.Implies(c, self._member(node, v, node.right, env))
                               for c, v in a.items])
            elif isinstance(b, tuple) and b[0] == "type":  # S <: Vehicles-like carrier
                held = z3.BoolVal(True)
            elif isinstance(b, ElementSet) and isinstance(a, ElementSet) and a.carrier == b.carrier:
                held = z3.And([z3.Implies(a.member[e], b.member[e]) for e in a.member])
            elif isinstance(a, NumberSet) or isinstance(b, NumberSet):
                held = z3.IsSubset(self.int_set(a, node), self.int_set(b, node))
            else:
                raise self.fail(node, "this inclusion")
            return held if op == "<:" else z3.Not(held)
        raise self.fail(node, f"the relation {op}")

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
            box = self.action_box(op, bound)
            return self.z3.Exists(list(bound.values()), self.z3.And(*box, guard) if box
                                  else guard)
        if operation.params:
            raise self.fail(operation.guard, f"the guard of {op}, which has parameters")
        return self.pred(operation.guard) if operation.guard is not None else \
            self.z3.BoolVal(True)


    def action_box(self, op: str, values: dict) -> list:
        """The action space's bounds (:attr:`bounds`, where given) of ``op``'s parameters,
        ``values`` their solver terms: one constraint per finite end."""
        low, high = self.bounds.get(op, ({}, {}))
        return [self.z3.RealVal(Fraction(low[p])) <= v for p, v in values.items() if p in low] \
            + [v <= self.z3.RealVal(Fraction(high[p])) for p, v in values.items() if p in high]

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


def _abs(z3, x):
    return z3.If(x >= 0, x, -x)


def _count_distinct(z3, s: Nums):
    """``card`` of a set of numbers: each item counts where it is in the set and equals
    none of the items in it before it."""
    terms = []
    for i, (c, v) in enumerate(s.items):
        before = [z3.And(d, w == v) for d, w in s.items[:i]]
        terms.append(z3.If(z3.And(c, z3.Not(z3.Or(before))) if before else c, 1, 0))
    return z3.Sum(terms) if terms else z3.IntVal(0)
