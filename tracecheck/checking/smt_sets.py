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
from ..errors import TracecheckError, UnsupportedError
from .encoding import ElementFunction, ElementSet, ElementTerm, FiniteFunction, NumberSet

__all__ = ["SetTranslation", "Nums", "EMPTY", "UNBOUND", "NATURALS", "MAX_LISTED"]

#: The most values a quantifier or SIGMA is unrolled over, and a set of the constants a
#: function's domain or range is listed from.
MAX_LISTED = 100_000
_TOTAL = ("-->", ">->", "-->>", ">->>")
_PARTIAL = ("+->", ">+>", "+->>", ">+>>")
_INJECTIVE = (">->", ">+>", ">->>", ">+>>")
_SURJECTIVE = ("-->>", "+->>", ">->>", ">+>>")


@dataclass
class Nums:
    """A set of numbers: (condition, value) pairs — value is in the set where condition."""

    items: list


EMPTY = object()  # the set {} (its carrier comes from the other side)
UNBOUND = object()  # a quantifier's variable before its value is chosen (in the env)


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
            return Nums(a.items + b.items)  # numbers of either kind, listed
        numbers = (Nums, NumberSet)
        if isinstance(a, NumberSet) or isinstance(b, NumberSet) or (
                isinstance(a, numbers) or isinstance(b, numbers)) and \
                all(isinstance(x, numbers) or x is EMPTY for x in (a, b)):
            x, y = self.int_set(a, node), self.int_set(b, node)
            fn = {"-": z3.SetDifference, "\\": z3.SetDifference, "\\/": z3.SetUnion,
                  "/\\": z3.SetIntersect}[node.op]
            return NumberSet(fn(x, y))
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

    def int_set(self, value, node) -> Any:
        """A set of integers as a z3 set: one the solver chooses, {} or listed numbers."""
        z3 = self.z3
        if isinstance(value, NumberSet):
            return value.term
        out = z3.EmptySet(z3.IntSort())
        if value is EMPTY:
            return out
        if isinstance(value, Nums) and all(z3.is_int(v) for _, v in value.items):
            for c, v in value.items:
                out = z3.If(c, z3.SetAdd(out, v), out) if not z3.is_true(c) else \
                    z3.SetAdd(out, v)
            return out
        raise self.fail(node, "a set of integers that is not one")

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

    def function_equals(self, node, f: FiniteFunction, other: ast.Node, env: dict) -> Any:
        """``f = {…}`` of a function over integers and a value of the constants (a whole map
        assumed): the array's value at each key is the value's there."""
        from ..b.values import FuncValue

        z3 = self.z3
        if ast.free_names(other) - set(self.machine.base_env) or \
                ast.free_names(other) & set(env):
            raise self.fail(node, "an equality of a map with a value that is not of the "
                                  "constants (compare it cell by cell: grid(x |-> y) = …)")
        value = self._listed(other, self.closed_value(other, env))
        if not all(type(p) is tuple and len(p) == 2 for p in value):
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
        if isinstance(x, FiniteFunction) and isinstance(right, ast.Call) and \
                right.name == "perm" and len(right.args) == 1:
            return self._function_member(node, x, "perm", None, right.args[0], env)
        if isinstance(x, ElementTerm):
            if isinstance(right, ast.Name) and right.id in self.machine.sets:
                return z3.BoolVal(right.id == x.carrier)
            s = self.translate(right, env)
            if isinstance(s, ElementSet) and s.carrier == x.carrier:
                return z3.Or([z3.And(x.term == x.consts[e], c) for e, c in s.member.items()])
            raise self.fail(node, "this membership")
        if isinstance(x, FiniteFunction) and isinstance(right, ast.BinOp) and \
                right.op in _TOTAL + _PARTIAL:
            return self._function_member(node, x, right.op, right.left, right.right, env)
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
        if isinstance(s, NumberSet) and z3.is_expr(x) and z3.is_int(x):
            return z3.IsMember(x, s.term)
        if isinstance(s, ElementSet) and isinstance(x, Elem) and x in s.member:
            return s.member[x]
        if isinstance(s, Nums) and z3.is_arith(x) and self.number_sets:  # x : {1, y, 3}
            return z3.Or([z3.And(c, x == v) for c, v in s.items])
        raise self.fail(node, "this membership")

    def closed_value(self, node: ast.Node, env: dict) -> Any:
        """The value of ``node``, which reads no solver variable and no bound name of
        ``env`` (a set of the constants); else an error saying it is not translated."""
        if ast.free_names(node) & set(env):
            raise self.fail(node, "a value that reads a variable the solver chooses")
        try:
            return self.machine.compile(node)(dict(self.machine.base_env))
        except Exception:  # noqa: BLE001 - not evaluated here: not translated
            raise self.fail(node, "a value that is not of the constants") from None

    def _listed(self, node: ast.Node, value: Any) -> frozenset:
        """``value`` (of ``node``) as a finite set of at most :data:`MAX_LISTED` members."""
        from ..b.values import cardinality, explicit

        try:
            if cardinality(value) <= MAX_LISTED:
                return explicit(value)
        except TracecheckError:
            pass
        raise self.fail(node, f"a set that is not a finite one of at most {MAX_LISTED:,} "
                              "members")

    def _closed_set(self, node: ast.Node, env: dict) -> frozenset:
        return self._listed(node, self.closed_value(node, env))

    def _function_member(self, node, f: FiniteFunction, arrow: str, dom_node, rng_node,
                         env: dict) -> Any:
        """``f : D arrow R`` (or ``f : perm(R)``) of a function over integers: its domain
        is its keys by its encoding, so D must be a set of the constants; each value in R,
        different ones where it is injective, every member of R taken where surjective."""
        z3 = self.z3
        if arrow == "perm":  # perm(R): the bijections from 1..card(R) to R
            rng = self._closed_set(rng_node, env)
            dom, arrow = frozenset(range(1, len(rng) + 1)), ">->>"
        else:
            dom, rng = self._closed_set(dom_node, env), None
        if arrow in _TOTAL and set(dom) != set(f.keys) or not set(f.keys) <= set(dom):
            return z3.BoolVal(False)
        terms = [f.at(k) for k in f.keys]
        parts = []
        r = rng_node
        if not (isinstance(r, ast.Name) and (r.id in ("REAL", "INTEGER", "BOOL")
                                             or r.id == f.carrier)):
            parts += [self._member(node, f.value(t), r, env) for t in terms]
        if arrow in _INJECTIVE and len(terms) > 1:
            parts.append(z3.Distinct(terms))
        if arrow in _SURJECTIVE:
            rng = self._closed_set(rng_node, env) if rng is None else rng
            if len(rng) * len(terms) > MAX_LISTED:
                raise self.fail(node, "a surjection with this many values")
            parts += [z3.Or([t == self._cell(node, f, v) for t in terms]) for v in rng]
        return z3.And(parts) if parts else z3.BoolVal(True)

    def _bindings(self, node: ast.Node, ids: tuple, pred: ast.Node, env: dict) -> list:
        """Every binding of ``ids`` the generators in ``pred`` allow (``v : S`` of a set of
        elements, ``v : lo..hi`` or ``v : {…}`` of numbers the bindings before it fix),
        each variable once those its generator reads have values: the environments, each
        to translate the body in. Over :data:`MAX_LISTED`: not translated."""
        from ..b.bindings import conjuncts

        gens = {c.left.id: c.right for c in reversed(conjuncts(pred)) if isinstance(c, ast.Rel)
                and c.op == ":" and isinstance(c.left, ast.Name) and c.left.id in ids}
        order: list = []
        while len(order) < len(ids):  # a variable whose range reads one still to bind: later
            ready = [v for v in ids if v not in order and not (
                ast.free_names(gens[v]) & (set(ids) - set(order)) if v in gens else False)]
            if not ready:
                raise self.fail(node, "a quantifier whose variables' ranges read each other")
            order.append(ready[0])
        out = [{**env, **{v: UNBOUND for v in ids}}]
        for var in order:
            grown = []
            for e in out:
                for value in self._values_of(node, var, pred, e):
                    grown.append({**e, var: value})
                    if len(grown) > MAX_LISTED:
                        raise self.fail(node, f"a quantifier over more than {MAX_LISTED:,} "
                                              "values")
            out = grown
        return out

    def _values_of(self, node, var: str, pred: ast.Node, env: dict) -> list:
        """The values ``var`` takes by its generator ``var : S`` in ``pred``: elements (of
        S's carrier, the membership left to the body), or numbers the solver computes."""
        from ..b.bindings import conjuncts

        z3 = self.z3
        gen = next((c for c in conjuncts(pred) if isinstance(c, ast.Rel) and c.op == ":"
                    and isinstance(c.left, ast.Name) and c.left.id == var), None)
        right = gen.right if gen is not None else None
        if isinstance(right, ast.BinOp) and right.op == "..":
            lo, hi = (z3.simplify(self._num(x, env)) for x in (right.left, right.right))
            if z3.is_int_value(lo) and z3.is_int_value(hi):
                if hi.as_long() - lo.as_long() >= MAX_LISTED:
                    raise self.fail(node, f"a quantifier over more than {MAX_LISTED:,} values")
                return [z3.IntVal(k) for k in range(lo.as_long(), hi.as_long() + 1)]
            raise self.fail(node, f"a binding of {var} over a range the solver chooses")
        if right is not None and not (isinstance(right, ast.Name)
                                      and right.id in self.machine.sets):
            try:
                s = self.translate(right, env)
            except UnsupportedError:
                s = None
            if isinstance(s, Nums) and all(z3.is_true(z3.simplify(c)) and
                                           z3.is_int_value(z3.simplify(v)) for c, v in s.items):
                return [z3.IntVal(k) for k in sorted({z3.simplify(v).as_long() for _, v in s.items})]
        carrier, _ = self._generator(node, var, pred, env)
        return list(self.machine.sets[carrier])

    def t_Quant(self, node: ast.Quant, env: dict) -> Any:
        z3 = self.z3
        body = node.body
        gens = body.left if isinstance(body, ast.Implies) and node.op == "!" else body
        if len(node.ids) == 1 and self._chosen_set(node.ids[0], gens, env) is not None:
            return self._native(node, env)
        parts = [self.pred(body, e) for e in self._bindings(node, node.ids, gens, env)]
        if node.op == "#":
            return z3.Or(parts) if parts else z3.BoolVal(False)
        return z3.And(parts) if parts else z3.BoolVal(True)

    def _chosen_set(self, var: str, gens: ast.Node, env: dict) -> Any:
        """The set of integers the solver chooses that ``var``'s generator ``var : s``
        ranges over, or None (another generator, or none)."""
        from ..b.bindings import conjuncts

        gen = next((c for c in conjuncts(gens) if isinstance(c, ast.Rel) and c.op == ":"
                    and isinstance(c.left, ast.Name) and c.left.id == var), None)
        if gen is None:
            return None
        try:
            found = self.translate(gen.right, env)
        except UnsupportedError:  # not one: the other ways of binding it say why
            found = None
        return found if isinstance(found, NumberSet) else None

    def _native(self, node: ast.Quant, env: dict) -> Any:
        """``!x.(x : s => P)`` / ``#x.(x : s & P)`` over a set the solver chooses: a z3
        quantifier over the integers — only where P is defined everywhere and introduces
        no fresh variable (their conditions would be outside the quantifier)."""
        z3 = self.z3
        (var,) = node.ids
        k = z3.FreshInt(var)
        start, side = len(self.definedness), len(self.side_conditions)
        body = self.pred(node.body, {**env, var: k})
        if len(self.definedness) > start or len(self.side_conditions) > side:
            del self.definedness[start:], self.side_conditions[side:]
            raise self.fail(node, "a quantifier over a set the solver chooses, with a term "
                                  "not defined everywhere")
        return z3.ForAll([k], body) if node.op == "!" else z3.Exists([k], body)

    def t_QuantExpr(self, node: ast.QuantExpr, env: dict) -> Any:
        """``SIGMA(x).(x : S | E)`` over the bindings of its generators: each term counted
        where the predicate holds."""
        z3 = self.z3
        if node.op not in ("SIGMA", "∑"):
            raise self.fail(node, node.op)
        terms = []
        for e in self._bindings(node, node.ids, node.pred, env):
            held = self.pred(node.pred, e)
            self.path.append(held)
            try:
                terms.append(z3.If(held, self._num(node.expr, e), 0))
            finally:
                self.path.pop()
        return z3.Sum(terms) if terms else z3.IntVal(0)


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
