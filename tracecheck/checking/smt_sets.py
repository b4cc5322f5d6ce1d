"""The set part of the SMT translation (:class:`~tracecheck.checking.smt.Translator` takes it
in): sets of elements and of numbers, comprehensions and quantifiers unrolled over a set's
elements, membership (in a type, a range, a set, a function space), an element the solver
chooses compared with one, and applications of functions over elements or over finite sets
of integers (a grid map).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..b import ast
from ..b.values import BUILTIN_SET_VALUES, Elem
from ..errors import UnsupportedError
from .encoding import ElementFunction, ElementSet, ElementTerm, FiniteFunction

__all__ = ["SetTranslation", "Nums", "EMPTY", "NATURALS"]


@dataclass
class Nums:
    """A set of numbers: (condition, value) pairs — value is in the set where condition."""

    items: list


EMPTY = object()  # the set {} (its carrier comes from the other side)


@dataclass
class _Pair:
    """``a |-> b`` of numbers: only an argument of an application (``field(x |-> y)``)."""

    left: Any
    right: Any


#: The built-in sets of integers with bounds: (least, greatest or None), as the evaluator has
#: them (NAT is 0..MAXINT).
NATURALS = {"NATURAL": (0, None), "NATURAL1": (1, None),
             **{n: (BUILTIN_SET_VALUES[n].lo, BUILTIN_SET_VALUES[n].hi)
                for n in ("NAT", "NAT1", "INT")}}


class SetTranslation:
    """The translator's methods for sets, membership and application (a mixin of
    :class:`~tracecheck.checking.smt.Translator`: ``self`` has its ``z3``, ``machine``,
    ``translate``, ``pred``, ``fail`` and well-definedness bookkeeping)."""

    def _setop(self, node, a, b) -> Any:
        z3 = self.z3
        if node.op == "\\/" and isinstance(a, Nums) and isinstance(b, Nums):
            return Nums(a.items + b.items)
        if a is EMPTY and isinstance(b, ElementSet):
            a = ElementSet(b.carrier, {e: z3.BoolVal(False) for e in b.member})
        if b is EMPTY and isinstance(a, ElementSet):
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
            return EMPTY
        if all(isinstance(i, Elem) for i in items):
            sets = self.machine.sets
            carrier = next((s for s, elems in sets.items() if set(items) <= set(elems)), None)
            if carrier is not None:
                return ElementSet(carrier, {e: z3.BoolVal(e in items) for e in sets[carrier]})
        if all(z3.is_arith(i) for i in items):
            return Nums([(z3.BoolVal(True), i) for i in items])
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
        return Nums(list(cells.values()))

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
        if s is EMPTY:
            return Nums([])
        if not (isinstance(f, ElementFunction) and isinstance(s, ElementSet)
                and f.carrier == s.carrier):
            raise self.fail(node, "this image")
        return Nums([(self.z3.And(s.member[e], d), v) for e, (d, v) in f.cells.items()])

    def t_Apply(self, node: ast.Apply, env: dict) -> Any:
        z3 = self.z3
        f = self.translate(node.fn, env)
        if isinstance(f, FiniteFunction) and len(node.args) == 2:  # grid(x, y): grid(x |-> y)
            return self._apply_finite(node, f, _Pair(self._num(node.args[0], env),
                                                      self._num(node.args[1], env)))
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
        return f.value(f.at(index if pairs else index[0]))

    def t_Pair(self, node: ast.Pair, env: dict) -> Any:
        return _Pair(self._num(node.left, env), self._num(node.right, env))

    def function_equals(self, node, f: FiniteFunction, other: ast.Node) -> Any:
        """``f = {…}`` of a function over integers and a value of the constants (a whole map
        assumed): the array's value at each key is the value's there."""
        from ..b.values import FuncValue

        z3 = self.z3
        if ast.free_names(other) - set(self.machine.base_env):
            raise self.fail(node, "an equality of a map with a value that is not of the "
                                  "constants (compare it cell by cell: grid(x |-> y) = …)")
        try:
            value = self.machine.compile(other)(dict(self.machine.base_env))
        except Exception:  # noqa: BLE001 - not evaluated here: not translated
            raise self.fail(other, "this value") from None
        if not isinstance(value, frozenset) or not all(type(p) is tuple for p in value):
            return z3.BoolVal(False)  # not a function (the type checker let a set through)
        mapping = value.map if isinstance(value, FuncValue) else dict(value)
        if set(mapping) != set(f.keys) or len(mapping) != len(value):
            return z3.BoolVal(False)  # another domain, or not a function
        return z3.And([f.at(k) == self._cell(node, f, mapping[k]) for k in f.keys])

    def _cell(self, node, f: FiniteFunction, v) -> Any:
        """A value of the constants as a term of ``f``'s values."""
        if f.carrier is not None:
            if not isinstance(v, Elem) or v not in f.consts:
                raise self.fail(node, f"the value {v!r} in a map of {f.carrier}")
            return f.consts[v]
        return self._constant(v, node)

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
        if isinstance(right, ast.Name) and right.id in NATURALS and z3.is_arith(x):
            lo, hi = NATURALS[right.id]
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
        if isinstance(s, Nums) and z3.is_arith(x) and self.number_sets:  # x : {1, y, 3}
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
