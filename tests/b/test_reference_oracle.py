"""tracecheck against a reference oracle: random B formulas over tiny finite domains, each
evaluated by tracecheck and by tests/b/reference_b.py, a naive evaluator written from the
B-Book's definitions that shares no code with tracecheck.

Why: tracecheck computes B's set theory cleverly (symbolic sets that are never built, batch
columns, a solver), and a clever shortcut can be wrong where no hand-written test looks: a
permutation of permutations was once not a permutation. The oracle builds every set from
its definition, so the two fail in different ways. For every formula tracecheck must give
the oracle's value or refuse (raise a :class:`TracecheckError`), never another value; where
the oracle finds the formula not well-defined, tracecheck must refuse. Checked on
tracecheck's three ways to evaluate: the scalar path (``evaluate``), the batch path
(``BatchFormula`` over :class:`Columns`, row by row) and the solver (``solve`` for a free
integer ``x`` bounded to a small interval).

The formulas are drawn by hypothesis (derandomised: the same ones on every run) from a small
typed grammar: integers in -3..3, booleans, the enumerated elements a, b, c, pairs, sets of
at most three elements, relations, functions, sequences and their spaces (``S --> T`` and
its variants, ``seq``, ``iseq``, ``perm``, nested), the integer sets, quantifiers,
comprehensions, lambdas, IF and LET. Sets of sequences and functions nested in each other
(``perm(perm({1,2}))``, ``{0,1} -->> perm({1,2})``) are drawn often, with elements taken
from the oracle's enumeration so that memberships are TRUE as often as FALSE.
``TRACECHECK_ORACLE_EXAMPLES=N`` draws N predicates (N/2 expressions, N/6 solver problems)
instead of the default 600.

The bugs the oracle found are tests at the end, each with the formulas that show it (an
xfail where it is not fixed yet).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections import Counter
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Optional

import pytest
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st

from tests.b import reference_b as R
from tests.b.reference_b import Node
from tracecheck.b.columns import Columns
from tracecheck.b.evaluation import evaluate
from tracecheck.b.parser import parse_formula
from tracecheck.b.values import Elem, FuncValue, SymbolicSet
from tracecheck.b.vector import BatchFormula
from tracecheck.errors import TracecheckError

#: Formulas per hypothesis test (the predicate test draws this many, the others fewer).
EXAMPLES = int(os.environ.get("TRACECHECK_ORACLE_EXAMPLES", "600"))

#: The same formulas on every run; slow examples and rejected ones (too large for the
#: oracle) are expected.
SETTINGS = dict(deadline=None, derandomize=True, database=None, print_blob=False,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                       HealthCheck.data_too_large])

ELEMS = tuple(Elem(n) for n in R.ELEMENT_NAMES)
CONSTANTS = {str(e): e for e in ELEMS}

# ------------------------------------------------------------------ types
Type = tuple
INT: Type = ("int",)
BOOL: Type = ("bool",)
ELEM: Type = ("elem",)


def SET(t: Type) -> Type:
    return ("set", t)


def PAIR(a: Type, b: Type) -> Type:
    return ("pair", a, b)


def SEQ(t: Type) -> Type:
    return SET(PAIR(INT, t))


def is_seq(t: Type) -> bool:
    return t[0] == "set" and t[1][0] == "pair" and t[1][1] == INT


#: The state variables of the predicate tests (rows of the batch path), with their types.
STATE = {"n": INT, "m": INT, "p": BOOL, "e": ELEM, "S": SET(ELEM), "T": SET(INT),
         "sq": SEQ(INT), "G": SET(PAIR(ELEM, ELEM)), "ss": SEQ(SEQ(INT)),
         "F": SET(PAIR(ELEM, INT))}  # F: an integer function of the elements, a function
#                                     column on the batch path (it was a float column)


def N(op: str, *args: Any) -> Node:
    return Node(op, args)


def var(name: str) -> Node:
    return N("var", name)


# ------------------------------------------------------------------ the grammar


class Gen:
    """Draws well-typed formulas: ``expr(t, depth)`` of type ``t``, ``pred(depth)``; names in
    ``scope`` (state variables and bound variables) with their types."""

    def __init__(self, draw: Callable, scope: dict[str, Type], if_sets: bool = True) -> None:
        self.draw, self.scope, self.if_sets = draw, dict(scope), if_sets

    def bind(self, name: str, t: Type) -> "Gen":
        """The grammar inside a binder of ``name``."""
        return Gen(self.draw, {**self.scope, name: t}, self.if_sets)

    def pick(self, options: list) -> Any:
        return self.draw(st.sampled_from(options))

    def coin(self, p: float = 0.5) -> bool:
        return self.draw(st.integers(0, 99)) < p * 100

    # -- values and leaves
    def value(self, t: Type, size: int = 3) -> Any:
        kind = t[0]
        if kind == "int":
            return self.draw(st.integers(-3, 3))
        if kind == "bool":
            return self.draw(st.booleans())
        if kind == "elem":
            return self.pick(list(R.ELEMENT_NAMES))
        if kind == "pair":
            return (self.value(t[1]), self.value(t[2]))
        count = self.draw(st.integers(0, size))
        if is_seq(t) and self.coin(0.6):
            return frozenset((i + 1, self.value(t[1][2], 2)) for i in range(count))
        return frozenset(R.canon(self.value(t[1], 2)) for _ in range(count))

    def function_value(self, a: Type, b: Type) -> frozenset:
        """A function from some values of ``a`` (total on a tiny carrier, often)."""
        keys = {R.key(k): k for k in (self.value(a, 2) for _ in range(3))}
        return frozenset((k, self.value(b, 2)) for k in keys.values())

    def literal(self, t: Type) -> Node:
        return R.literal(self.value(t), as_sequence=self.coin())

    def leaf(self, t: Type) -> Node:
        names = [n for n, nt in self.scope.items() if nt == t]
        if names and self.coin(0.6):
            return var(self.pick(names))
        return self.literal(t)

    def small_type(self, level: int = 2) -> Type:
        options = ["int", "elem", "bool"] + (["set", "pair", "seq"] if level > 0 else [])
        kind = self.pick(options)
        if kind == "set":
            return SET(self.small_type(level - 1))
        if kind == "pair":
            return PAIR(self.small_type(level - 1), self.small_type(level - 1))
        if kind == "seq":
            return SEQ(self.small_type(level - 1))
        return {"int": INT, "elem": ELEM, "bool": BOOL}[kind]

    # -- expressions
    def expr(self, t: Type, depth: int) -> Node:
        if depth <= 0:
            return self.leaf(t)
        d = depth - 1
        kind = t[0]
        options = ["leaf", "apply", "if"]
        if kind == "int":
            options += ["arith", "arith", "pow", "neg", "card", "size", "minmax", "firstlast",
                        "succ", "sigma"]
        elif kind in ("bool", "elem"):
            options += ["boolof"] * (kind == "bool") + ["firstlast"]
        elif kind == "pair":
            options += ["maplet", "maplet"]
        else:
            return self.set_expr(t[1], depth)
        how = self.pick(options)
        if how == "leaf":
            return self.leaf(t)
        if how == "apply":
            return self.application(t, d)
        if how == "if":
            return N("if", self.pred(d), self.expr(t, d), self.expr(t, d))
        if how == "succ":
            return N(self.pick(["succ", "pred"]), self.expr(INT, d))
        if how == "sigma":
            name = f"q{len(self.scope)}"
            inner = self.bind(name, INT)
            return N(self.pick(["sigma", "pi"]), name, self.expr(SET(INT), d),
                     inner.expr(INT, d))
        if how == "arith":
            return N(self.pick(["add", "sub", "mul", "div", "mod"]), self.expr(INT, d),
                     self.expr(INT, d))
        if how == "pow":
            return N("pow", self.expr(INT, d), N("int", self.draw(st.integers(-1, 3))))
        if how == "neg":
            return N("neg", self.expr(INT, d))
        if how == "card":
            return N("card", self.expr(SET(self.small_type(1)), d))
        if how == "size":
            return N("size", self.expr(SEQ(self.small_type(1)), d))
        if how == "minmax":
            return N(self.pick(["min", "max"]), self.expr(SET(INT), d))
        if how == "firstlast":
            return N(self.pick(["first", "last"]), self.expr(SEQ(t), d))
        if how == "boolof":
            return N("boolof", self.pred(d))
        return N("maplet", self.expr(t[1], d), self.expr(t[2], d))

    def application(self, t: Type, d: int) -> Node:
        functions = [(n, ft[1][1]) for n, ft in self.scope.items()
                     if ft[0] == "set" and ft[1][0] == "pair" and ft[1][2] == t]
        if functions and self.coin(0.6):  # a state variable: a function, or a relation
            name, a = self.pick(functions)
            return N("apply", var(name), self.expr(a, d))
        a = self.small_type(1)
        if self.coin(0.6):  # a function literal and (often) an argument in its domain
            f = self.function_value(a, t)
            keys = sorted((p[0] for p in f), key=R.key)
            x = R.literal(self.pick(keys)) if keys and self.coin(0.8) else self.expr(a, d)
            return N("apply", R.literal(f, as_sequence=self.coin()), x)
        return N("apply", self.expr(SET(PAIR(a, t)), d), self.expr(a, d))

    def set_expr(self, u: Type, depth: int) -> Node:
        """An expression of type SET(u)."""
        t = SET(u)
        if depth <= 0:
            return self.leaf(t)
        d = depth - 1
        options = ["leaf", "setext", "setop", "setop", "compr", "dom", "ran", "image",
                   "generalised"] + ["if"] * self.if_sets
        if u == INT:
            options += ["interval"]
        if u[0] == "set":
            options += ["pow"]
            if u[1][0] == "pair":
                options += ["arrow", "arrow"]
            if is_seq(u):
                options += ["seqspace", "seqspace"]
        if u[0] == "pair":
            a, b = u[1], u[2]
            options += ["prod", "inverse", "restrict", "override", "comp", "lambda"]
            options += ["id", "closure1"] * (a == b)
            options += ["dprod"] * (b[0] == "pair")
            options += ["prj"] * (a[0] == "pair" and b in (a[1], a[2]))
            if a == INT:
                options += ["seqext", "seqop", "concat", "conc"]
        how = self.pick(options)
        if how == "leaf":
            return self.leaf(t)
        if how == "setext":
            return N("setext", *(self.expr(u, d) for _ in range(self.draw(st.integers(0, 3)))))
        if how == "setop":
            return N(self.pick(["union", "inter", "minus"]), self.expr(t, d), self.expr(t, d))
        if how == "compr":
            name = f"q{len(self.scope)}"
            rng = self.expr(t, d)
            inner = self.bind(name, u)
            return N("compr", name, rng, inner.pred(d))
        if how in ("dom", "ran"):
            other = self.small_type(1)
            rel = PAIR(u, other) if how == "dom" else PAIR(other, u)
            return N(how, self.expr(SET(rel), d))
        if how == "image":
            other = self.small_type(1)
            return N("image", self.expr(SET(PAIR(other, u)), d), self.expr(SET(other), d))
        if how == "if":
            return N("if", self.pred(d), self.expr(t, d), self.expr(t, d))
        if how == "generalised":
            return N(self.pick(["union_all", "inter_all"]), self.expr(SET(t), d))
        if how == "interval":
            return N("interval", self.expr(INT, d), self.expr(INT, d))
        if how == "pow":
            return N(self.pick(["POW", "POW1", "FIN"]), self.expr(u, d))
        if how == "arrow":
            a, b = u[1][1], u[1][2]
            return N(self.pick(list(R.ARROWS)), self.expr(SET(a), d), self.expr(SET(b), d))
        if how == "seqspace":
            return N(self.pick(["iseq", "iseq1", "perm"]), self.expr(SET(u[1][2]), d))
        a, b = u[1], u[2]
        if how == "prod":
            return N("prod", self.expr(SET(a), d), self.expr(SET(b), d))
        if how == "inverse":
            return N("inverse", self.expr(SET(PAIR(b, a)), d))
        if how == "restrict":
            op = self.pick(["domres", "ranres", "domsub", "ransub"])
            if op in ("domres", "domsub"):
                return N(op, self.expr(SET(a), d), self.expr(t, d))
            return N(op, self.expr(t, d), self.expr(SET(b), d))
        if how == "override":
            return N("override", self.expr(t, d), self.expr(t, d))
        if how == "comp":
            middle = self.small_type(1)
            return N("comp", self.expr(SET(PAIR(a, middle)), d),
                     self.expr(SET(PAIR(middle, b)), d))
        if how in ("id", "closure1"):
            return N(how, self.expr(SET(a) if how == "id" else t, d))
        if how == "lambda":
            name = f"q{len(self.scope)}"
            inner = self.bind(name, a)
            return N("lambda", name, self.expr(SET(a), d), inner.expr(b, d))
        if how == "dprod":
            return N("dprod", self.expr(SET(PAIR(a, b[1])), d), self.expr(SET(PAIR(a, b[2])), d))
        if how == "prj":
            which = self.pick([k for k in (1, 2) if a[k] == b])
            return N(f"prj{which}", self.expr(SET(a[1]), d), self.expr(SET(a[2]), d))
        if how == "seqext":
            return N("seqext", *(self.expr(b, d) for _ in range(self.draw(st.integers(1, 3)))))
        if how == "seqop":
            return N(self.pick(["front", "tail", "rev"]), self.expr(t, d))
        if how == "concat":
            return N("concat", self.expr(t, d), self.expr(t, d))
        return N("conc", self.expr(SEQ(t), d))

    # -- predicates
    def pred(self, depth: int) -> Node:
        if depth <= 0:
            how = self.pick(["cmp", "member"])
        else:
            how = self.pick(["cmp", "eq", "member", "subset", "logic", "logic", "not",
                             "quant", "let", "space", "space", "space", "symbolic",
                             "symbolic"])
        d = max(depth - 1, 0)
        if how == "cmp":
            return N(self.pick(["=", "/=", "<", "<=", ">", ">="]), self.expr(INT, d),
                     self.expr(INT, d))
        if how == "eq":
            t = self.small_type()
            return N(self.pick(["=", "/="]), self.expr(t, d), self.expr(t, d))
        if how == "member":
            t = self.small_type(1)
            return N(self.pick([":", "/:"]), self.expr(t, d), self.container(t, d))
        if how == "subset":
            t = self.small_type(1)
            return N(self.pick(["<:", "<<:", "/<:", "/<<:"]), self.expr(SET(t), d),
                     self.container(t, d))
        if how == "logic":
            return N(self.pick(["and", "or", "implies", "equiv"]), self.pred(d), self.pred(d))
        if how == "not":
            return N("not", self.pred(d))
        if how == "quant":
            name = f"q{len(self.scope)}"
            t = self.small_type(1)
            rng = self.expr(SET(t), d)
            inner = self.bind(name, t)
            return N(self.pick(["forall", "exists"]), name, rng, inner.pred(d))
        if how == "symbolic":
            return self.symbolic_pred()
        if how == "let":
            name = f"q{len(self.scope)}"
            t = self.small_type(1)
            inner = self.bind(name, t)
            return N("let", name, self.expr(t, d), inner.pred(d))
        return self.space_pred()

    def container(self, t: Type, d: int) -> Node:
        """A set of type SET(t) that may be infinite: only its membership is asked."""
        if t in (INT, BOOL) and self.coin(0.3):
            return self.type_set(t)
        if t == SET(INT) and self.coin(0.3):
            return N(self.pick(["POW", "POW1", "FIN"]), self.type_set(INT))
        if is_seq(t) and t[1][2] in (INT, BOOL) and self.coin(0.3):
            return N(self.pick(list(R.SEQ_KINDS[:4])), self.type_set(t[1][2]))
        return self.expr(SET(t), d)

    def type_set(self, t: Type, bounded: bool = True) -> Node:
        """BOOL, or one of B's integer sets (``bounded``: INT, NAT and NAT1 too, which are
        finite but too large to count: see test_huge_finite_sets_are_not_counted)."""
        if t == BOOL:
            return N("typeset", "BOOL")
        names = [n for n, (lo, hi) in R.INTEGER_SETS.items() if bounded or hi is None]
        return N("typeset", self.pick(names))

    # -- sets tracecheck keeps symbolic, against each other and against their elements
    def symbolic(self, u: Type) -> Node:
        """A set of type SET(u) that tracecheck does not build: POW(S), an arrow, a set of
        sequences, an interval, a product (of tiny literal sets)."""
        if u[0] == "set":
            if is_seq(u) and self.coin():
                return N(self.pick(["iseq", "iseq1", "perm"]), self.tiny_set(u[1][2]))
            if u[1][0] == "pair" and self.coin(0.6):
                return N(self.pick(list(R.ARROWS)), self.tiny_set(u[1][1]),
                         self.tiny_set(u[1][2]))
            return N(self.pick(["POW", "POW1", "FIN"]), self.tiny_set(u[1]))
        if u == INT:
            return N("interval", self.literal(INT), self.literal(INT))
        if u[0] == "pair":
            return N("prod", self.tiny_set(u[1]), self.tiny_set(u[2]))
        return self.tiny_set(u)

    def tiny_set(self, t: Type) -> Node:
        if t == BOOL and self.coin(0.3):
            return N("typeset", "BOOL")
        if t == INT and self.coin(0.3):
            return N("interval", self.literal(INT), self.literal(INT))
        values = {R.key(v): v for v in (R.canon(self.value(t, 1)) for _ in range(
            self.draw(st.integers(0, 2))))}
        return R.literal(frozenset(values.values()))

    def symbolic_pred(self) -> Node:
        u = self.pick([INT, PAIR(INT, BOOL), SET(INT), SET(ELEM), SEQ(INT), SEQ(ELEM),
                       SET(PAIR(ELEM, INT)), SET(PAIR(INT, INT))])
        left = self.symbolic(u)
        how = self.pick(["compare", "compare", "explicit", "card", "quant"])
        if how == "compare":
            return N(self.pick(["=", "/=", "<:", "<<:", "/<:"]), left, self.symbolic(u))
        if how == "card":
            op = self.pick(["union", "inter", "minus"])
            return N("=", N("card", N(op, left, self.symbolic(u))),
                     N("int", self.draw(st.integers(0, 9))))
        if how == "quant":
            name = f"q{len(self.scope)}"
            inner = self.bind(name, u)
            return N(self.pick(["forall", "exists"]), name, left, inner.pred(1))
        try:  # its elements written out: all of them, or one fewer, or one more
            elements = sorted(R.explicit(R.evaluate(left, {})), key=R.key)
        except (R.TooLarge, R.Undefined):
            elements = []
        if len(elements) > 30:
            elements = elements[:30]
        change = self.pick(["same", "fewer", "more"])
        if change == "fewer" and elements:
            elements.pop(self.draw(st.integers(0, len(elements) - 1)))
        elif change == "more":
            elements.append(R.canon(self.value(u)))
        written = R.literal(frozenset(elements))
        op = self.pick(["=", "/=", "<:", "<<:"])
        return N(op, written, left) if self.coin() else N(op, left, written)

    # -- the spaces of sequences and functions, nested (where the old bugs were)
    def base_set(self, most: int, infinite: bool = False) -> tuple[Node, Type]:
        if infinite and self.coin(0.2):
            return self.type_set(INT, bounded=False), INT
        t = self.pick([INT, ELEM])
        values = self.draw(st.lists(st.integers(0, 2) if t == INT else
                                    st.sampled_from(R.ELEMENT_NAMES),
                                    min_size=int(self.coin(0.8)), max_size=most))
        return R.literal(frozenset(values)), t

    def space(self, level: int, infinite: bool = False) -> tuple[Node, Type]:
        """A set of sequences or functions built from literals, nested ``level`` deep (with
        ``infinite``, ``seq``/``seq1`` too): its node and its elements' type."""
        if level <= 0:
            return self.base_set(3, infinite)
        how = self.pick(["seqs", "arrow"])
        if how == "seqs":
            inner, t = self.space(level - 1, infinite) if self.coin(0.7) else \
                self.base_set(2, infinite)
            kinds = ["perm", "perm", "iseq", "iseq1"] + ["seq", "seq1"] * infinite
            return N(self.pick(kinds), inner), SEQ(t)
        if self.coin(0.6):  # the sequences of a set, as in S -->> perm(T), perm(T) --> S
            base, b = self.space(level - 2, infinite) if level >= 2 and self.coin(0.3) else \
                self.base_set(2, infinite)
            inner, t = N(self.pick(["perm", "iseq", "iseq1"]), base), SEQ(b)
        elif self.coin(0.8):
            inner, t = self.space(level - 1, infinite)
        else:
            inner, t = self.base_set(2, infinite)
        other, o = self.base_set(2, infinite)
        arrow = self.pick(list(R.ARROWS))
        if self.coin():
            return N(arrow, other, inner), SET(PAIR(o, t))
        return N(arrow, inner, other), SET(PAIR(t, o))

    def space_pred(self) -> Node:
        how = self.pick(["member", "member", "card", "subset"])
        space, t = self.space(self.draw(st.integers(1, 3)), infinite=how == "member")
        elements = None
        try:
            elements = sorted(R.explicit(R.evaluate(space, {})), key=R.key)
        except (R.TooLarge, R.Undefined):
            pass
        if how == "card":
            n = len(elements) if elements is not None and self.coin(0.7) else \
                self.draw(st.integers(0, 6))
            return N("=", N("card", space), N("int", n))
        if how == "subset":
            some = [self.pick(elements) for _ in range(2)] if elements else []
            return N("<:", R.literal(frozenset(R.canon(x) for x in some),
                                     as_sequence=self.coin(0.8)), space)
        if elements and self.coin(0.7):
            x = R.literal(self.pick(elements), as_sequence=self.coin(0.8))
        else:
            x = self.expr(t, 1)
        return N(self.pick([":", ":", "/:"]), x, space)


@st.composite
def predicates(draw, scope: dict[str, Type], depth: int = 3, if_sets: bool = True) -> Node:
    """A predicate over the names of ``scope`` (``if_sets``: IF-THEN-ELSE of sets too)."""
    return Gen(draw, scope, if_sets).pred(draw(st.integers(1, depth)))


@st.composite
def expressions(draw) -> Node:
    gen = Gen(draw, {})
    return gen.expr(gen.small_type(), draw(st.integers(1, 3)))


@st.composite
def rows(draw, types: dict[str, Type]) -> list[dict[str, Any]]:
    """1 to 5 states of the state variables (oracle values)."""
    gen = Gen(draw, {})
    count = draw(st.integers(1, 5))
    out = []
    for _ in range(count):
        row = {}
        for name, t in types.items():
            row[name] = R.canon(gen.value(t))
        out.append(row)
    return out


# ------------------------------------------------------------------ the boundary

def to_tracecheck(v: Any) -> Any:
    """An oracle value as tracecheck holds it: elements as :class:`Elem`, a function as a
    :class:`FuncValue` (as a trace's state has it), any other set as a frozenset."""
    if isinstance(v, bool) or isinstance(v, int):
        return v
    if isinstance(v, str):
        return Elem(v)
    if isinstance(v, tuple):
        return (to_tracecheck(v[0]), to_tracecheck(v[1]))
    items = [to_tracecheck(x) for x in v]
    if items and all(isinstance(x, tuple) for x in items) and \
            len({x[0] for x in items}) == len(items):
        return FuncValue(dict(items))
    return frozenset(items)


class Unreadable(Exception):
    """tracecheck's value cannot be enumerated (a symbolic set it cannot walk)."""


def from_tracecheck(v: Any) -> Any:
    """A tracecheck value as the oracle writes it (a finite symbolic set enumerated)."""
    if isinstance(v, Elem):
        return str(v)
    if isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, tuple):
        return (from_tracecheck(v[0]), from_tracecheck(v[1]))
    if isinstance(v, SymbolicSet):
        try:
            return frozenset(from_tracecheck(x) for x in v.elements())
        except TracecheckError as exc:
            raise Unreadable(str(exc)) from None
    if isinstance(v, frozenset):
        return frozenset(from_tracecheck(x) for x in v)
    raise AssertionError(f"tracecheck gave a value of an unknown kind: {v!r}")


UNDEFINED = "not well-defined"


def oracle(node: Node, env: dict[str, Any]) -> Any:
    """The oracle's value, or :data:`UNDEFINED`; a formula too large for it is rejected
    (hypothesis draws another)."""
    try:
        return R.canon(R.evaluate(node, env))
    except R.Undefined:
        return UNDEFINED
    except R.TooLarge:
        reject()


def shown(value: Any) -> str:
    return value if value == UNDEFINED else R.to_b(R.literal(value))


@lru_cache(maxsize=64)
def parsed(text: str):
    """tracecheck's AST of ``text`` (frozen: shared by the rows and the paths)."""
    return parse_formula(text)


def scalar(node: Node, row: dict[str, Any], want: Any) -> str:
    """tracecheck's scalar path on ``node`` in the state ``row`` (oracle values) against
    the oracle's ``want``: 'refused' or 'answered' (an AssertionError for another value)."""
    text = R.to_b(node)
    env = {**CONSTANTS, **{k: to_tracecheck(v) for k, v in row.items()}}
    try:
        got = from_tracecheck(evaluate(parsed(text), env, source=text))
    except (TracecheckError, Unreadable):
        return "refused"
    assert want != UNDEFINED, \
        f"{text}\n  in {row}: tracecheck gives {got!r}, but it is not well-defined"
    assert R.key(got) == R.key(want), \
        f"{text}\n  in {row}: tracecheck gives {got!r}, the oracle {shown(want)}"
    return "answered"


def batch(node: Node, states: list[dict[str, Any]], wants: list[Any]) -> str:
    """tracecheck's batch path on ``node`` over ``states``, row by row against ``wants``."""
    text = R.to_b(node)
    tc_rows = [{k: to_tracecheck(v) for k, v in s.items()} for s in states]
    cols = Columns.from_states(tc_rows, ELEMS)
    try:
        got = BatchFormula(parsed(text), CONSTANTS, source=text)(cols).tolist()
    except TracecheckError:
        return "refused"
    for i, (g, w) in enumerate(zip(got, wants)):
        assert w != UNDEFINED, \
            f"{text}\n  row {i} {states[i]}: the batch gives {g!r}, but it is not well-defined"
        assert type(g) is bool and g == w, \
            f"{text}\n  row {i} {states[i]}: the batch gives {g!r}, the oracle {w}"
    return "answered"


def check_predicate(node: Node, states: list[dict[str, Any]]) -> Counter:
    wants = [oracle(node, s) for s in states]
    seen = Counter(f"oracle {w}" for w in wants)
    for s, w in zip(states, wants):
        seen[outcome("scalar", scalar(node, s, w), w)] += 1
    seen[outcome("batch", batch(node, states, wants), *wants)] += 1
    return seen


def outcome(path: str, answer: str, *wants: Any) -> str:
    """What a path did: answered, refused, or refused where the oracle has a value."""
    if answer == "refused" and UNDEFINED not in wants:
        return f"{path} refused a value"
    return f"{path} {answer}"


# ------------------------------------------------------------------ hand-written cases

def seq_lit(*items: Node) -> Node:
    return N("seqext", *items)


def ints(*values: int) -> list[Node]:
    return [N("int", v) for v in values]


PERM12 = N("perm", N("setext", *ints(1, 2)))
EXPLICIT = [
    # the permutations of {1,2} are [1,2] and [2,1], and those two are a permutation of them
    pytest.param(N(":", seq_lit(seq_lit(*ints(1, 2)), seq_lit(*ints(2, 1))), N("perm", PERM12)),
                 True, id="perm-of-perm"),
    pytest.param(N(":", N("setext", N("maplet", N("int", 0), seq_lit(*ints(1, 2))),
                          N("maplet", N("int", 1), seq_lit(*ints(2, 1)))),
                   N("-->>", N("setext", *ints(0, 1)), PERM12)), True, id="onto-perm"),
    pytest.param(N(":", N("setext", N("maplet", seq_lit(*ints(1, 2)), N("int", 0)),
                          N("maplet", seq_lit(*ints(2, 1)), N("int", 0))),
                   N("-->", PERM12, N("setext", N("int", 0)))), True, id="total-on-perm"),
    pytest.param(N("card", PERM12), 2, id="card-perm"),
    pytest.param(N("=", N("card", N("perm", PERM12)), N("int", 2)), True, id="card-perm-perm"),
    pytest.param(N(":", seq_lit(*ints(2, 1)), N("iseq", N("setext", *ints(1, 2, 3)))), True,
                 id="iseq"),
    pytest.param(N("div", N("int", -7), N("int", 2)), -3, id="division-truncates"),
    pytest.param(N("card", N("-->", N("setext", *ints(1, 2)), N("setext", *ints(1, 2, 3)))), 9,
                 id="card-total"),
    pytest.param(N("card", N("+->", N("setext", *ints(1, 2)), N("setext", *ints(1, 2)))), 9,
                 id="card-partial"),
    pytest.param(N("card", N(">->", N("setext", *ints(1, 2)), N("setext", *ints(1, 2, 3)))), 6,
                 id="card-injective"),
    pytest.param(N("card", N("-->>", N("setext", *ints(1, 2, 3)), N("setext", *ints(1, 2)))),
                 6, id="card-surjective"),
    pytest.param(N("card", N("iseq", N("setext", *ints(1, 2, 3)))), 16, id="card-iseq"),
    pytest.param(N("card", N("POW1", N("setext", *ints(1, 2)))), 3, id="card-POW1"),
    pytest.param(N("closure1", N("setext", N("maplet", *ints(1, 2)), N("maplet", *ints(2, 3)))),
                 frozenset({(1, 2), (2, 3), (1, 3)}), id="closure1"),
    pytest.param(N("conc", seq_lit(seq_lit(*ints(1)), seq_lit(*ints(2, 3)))),
                 frozenset({(1, 1), (2, 2), (3, 3)}), id="conc"),
    pytest.param(N("and", N("=", N("int", 1), N("int", 2)),
                   N("=", N("div", N("int", 1), N("int", 0)), N("int", 1))),
                 False, id="and-left-to-right"),
]


@pytest.mark.parametrize("node,value", EXPLICIT)
def test_hand_written_formulas(node: Node, value: Any):
    """The oracle and tracecheck's scalar path both give ``value`` (no refusal here)."""
    assert R.key(R.canon(R.evaluate(node, {}))) == R.key(value)
    text = R.to_b(node)
    got = from_tracecheck(evaluate(parse_formula(text), dict(CONSTANTS), source=text))
    assert R.key(got) == R.key(value), f"{text}: tracecheck gives {got!r}, not {value!r}"


ONE, TWO, ZERO = ints(1, 2, 0)


@pytest.mark.parametrize("node", [
    pytest.param(N("=", N("div", ONE, ZERO), ONE), id="division-by-zero"),
    pytest.param(N("and", N("=", N("div", ONE, ZERO), ONE), N("=", ONE, TWO)),
                 id="and-undefined-on-the-left"),
    pytest.param(N("=", N("first", N("seqext")), ONE), id="first-of-empty"),
    pytest.param(N("=", N("mod", N("int", -1), TWO), ONE), id="mod-of-negative"),
    pytest.param(N("=", N("apply", N("setext", N("maplet", ONE, TWO)), N("int", 3)), TWO),
                 id="outside-the-domain"),
    pytest.param(N("=", N("apply", N("setext", N("maplet", ONE, TWO), N("maplet", ONE, ONE)),
                          ONE), TWO), id="two-images"),
    pytest.param(N("forall", "q0", N("setext", ONE, TWO),
                   N("=", N("div", ONE, N("sub", var("q0"), ONE)), ONE)),
                 id="undefined-for-one-element"),
    pytest.param(N("=", N("inter_all", N("setext")), N("setext")), id="inter-of-empty"),
])
def test_not_well_defined_is_refused(node: Node):
    """The oracle finds no value, and tracecheck refuses."""
    assert oracle(node, {}) == UNDEFINED
    text = R.to_b(node)
    with pytest.raises(TracecheckError):
        evaluate(parse_formula(text), dict(CONSTANTS), source=text)


# ------------------------------------------------------------------ generated formulas

def run_examples(strategy, check: Callable[..., Counter], examples: int) -> Counter:
    """Run ``check`` on ``examples`` cases drawn from ``strategy``; the outcomes counted.
    A failing case is shrunk by hypothesis and raised."""
    seen: Counter = Counter()

    @settings(max_examples=examples, **SETTINGS)
    @given(strategy)
    def run(case):
        seen.update(check(*case))
    run()
    return seen


def test_predicates_agree_with_the_oracle():
    """Predicates over the state variables (and closed ones): the scalar path in each row
    and the batch path over the rows give the oracle's value or refuse. Most are answered,
    and the oracle's verdicts are mixed (not a test of one constant)."""
    seen = run_examples(st.tuples(predicates(STATE), rows(STATE)), check_predicate, EXAMPLES)
    assert seen["scalar answered"] >= 10 * seen["scalar refused a value"], seen
    assert min(seen["oracle True"], seen["oracle False"], seen[f"oracle {UNDEFINED}"]) > 0, seen


def check_expression(node: Node) -> Counter:
    want = oracle(node, {})
    return Counter([outcome("scalar", scalar(node, {}, want), want)])


def test_expressions_agree_with_the_oracle():
    """Closed expressions of every type (numbers, sets, relations, sequences, spaces): the
    scalar path's value is the oracle's."""
    seen = run_examples(st.tuples(expressions()), check_expression, max(EXAMPLES // 2, 1))
    assert seen["scalar answered"] >= 10 * seen["scalar refused a value"], seen


# ------------------------------------------------------------------ the solver

SOLVED = (-3, 3)  # x : -3..3


@pytest.fixture(scope="module")
def elements_machine():
    from tracecheck.b import load_machine_text

    return load_machine_text("MACHINE Oracle\nSETS E = {a, b, c}\nEND")


def solve_text(text: str, machine, timeout_s: float = 5.0):
    """``solve`` on the predicate ``text`` for its free identifiers, all solutions (as
    tests/checking/test_solving.py's ``answer``), the elements a, b, c those of the
    machine's set E."""
    from tracecheck.b.btypes import Var, resolve_all
    from tracecheck.b.typecheck import check_formula
    from tracecheck.checking.solving import free_identifiers, solve

    names = dict(machine.type_objects)
    free = free_identifiers(parse_formula(text, file="<t>"), names)
    typed = {**names, **{n: Var() for n in free}}
    node, _ = check_formula(text, typed, file="<t>", kind="predicate")
    types = {n: resolve_all(typed[n]) for n in free}
    return solve(node, types, machine.env({}), sets=machine.sets, source=text, file="<t>",
                 timeout_s=timeout_s, all_solutions=True, limit=20)


def check_solver(pred: Node, machine, small_space: Optional[int]) -> Counter:
    """``x : -3..3 & P`` solved for x: TRUE only with solutions the oracle accepts, FALSE
    only where the oracle finds P FALSE at every x of the range (where it has no value at
    some x and holds at none, tracecheck raises, as ProB does); or unknown, or a refusal
    (never a :class:`Disagreement`, tracecheck's own alarm). ``small_space``: solving's
    SMALL_SPACE for the run (0: the SMT solver, not the walk)."""
    from tracecheck.checking import solving
    from tracecheck.errors import Disagreement

    lo, hi = SOLVED
    node = N("and", N(":", var("x"), N("interval", N("int", lo), N("int", hi))), pred)
    verdicts = {v: oracle(pred, {"x": v}) for v in range(lo, hi + 1)}
    text = R.to_b(node)
    saved = solving.SMALL_SPACE
    if small_space is not None:
        solving.SMALL_SPACE = small_space
    try:
        got = solve_text(text, machine)
    except Disagreement:
        raise
    except TracecheckError:
        return Counter(["solver refused"])
    finally:
        solving.SMALL_SPACE = saved
    assert set(got.names) == {"x"}, (text, got)
    if got.status == "TRUE":
        for solution in got.solutions:
            x = solution["x"]
            assert verdicts.get(x) is True, \
                f"{text}: the solver says x = {x}; the oracle: {verdicts.get(x, 'out of range')}"
        if got.complete:
            assert {s["x"] for s in got.solutions} == \
                {x for x, v in verdicts.items() if v is True}, (text, got.solutions, verdicts)
    elif got.status == "FALSE":
        assert all(v is False for v in verdicts.values()), \
            f"{text}: the solver says FALSE; the oracle: {verdicts}"
    return Counter([f"solver {got.status} {got.method}"])


@pytest.mark.parametrize("small_space", [None, 0], ids=["walk", "smt"])
def test_the_solver_agrees_with_the_oracle(elements_machine, small_space: Optional[int]):
    """Solutions of ``x : -3..3 & P(x)`` (a generated P) are the oracle's, walked by the
    evaluator (the default for so small a range) or asked of z3 (SMALL_SPACE = 0)."""
    if small_space == 0:
        pytest.importorskip("z3")
    # no IF-THEN-ELSE of sets for z3: see test_the_solver_takes_an_if_of_sets
    seen = run_examples(st.tuples(predicates({"x": INT}, depth=2, if_sets=small_space != 0)),
                        lambda p: check_solver(p, elements_machine, small_space),
                        max(EXAMPLES // 6, 1))
    assert seen["solver TRUE enumeration"] + seen["solver TRUE solver"] > 0, seen
    assert seen["solver FALSE enumeration"] + seen["solver FALSE solver"] > 0, seen


# ------------------------------------------------------------------ known bugs

@pytest.mark.parametrize("text,one", [
    ("x > 0 & IF x = 1 THEN {2} ELSE {1} END = {1}", False),
    ("x : -3..3 & IF x = 1 THEN {} ELSE {1} END <: INTEGER", True),
    ("x > 0 & card(IF x = 1 THEN {1} ELSE {} END) = 0", False),
])
def test_the_solver_takes_an_if_of_sets(elements_machine, text: str, one: bool):
    """TRUE with solutions that hold (x = 1 only where ``one``), or unknown; never an
    exception from z3 (it raised Z3Exception: a traceback from `tracecheck eval`)."""
    try:
        got = solve_text(text, elements_machine)
    except Exception as exc:  # whatever else escapes is the failure
        if isinstance(exc, TracecheckError):
            raise
        raise AssertionError(f"{text}: {type(exc).__name__}: {exc}") from None
    assert got.status in ("TRUE", "unknown"), got
    assert one or all(s["x"] != 1 for s in got.solutions), got


FUNCTION_ROWS = [{"F": frozenset({("a", 3), ("b", -3)})}, {"F": frozenset({("a", 1)})}]


@pytest.mark.parametrize("node", [
    N("=", N("div", N("apply", var("F"), N("elem", "a")), N("int", 2)), N("int", 1)),
    N(":", N("apply", var("F"), N("elem", "a")), N("interval", N("int", 1), N("int", 5))),
    N("=", N("pow", N("apply", var("F"), N("elem", "a")), N("int", -1)), N("int", 0)),
    N("=", N("div", N("max", N("ran", var("F"))), N("int", 2)), N("int", 1)),
], ids=["vectorised-division", "interval", "negative-power", "scalar-fallback-division"])
def test_batch_function_columns_keep_integers(node: Node):
    """An integer function of the elements on the batch path (each row as the scalar path
    and the oracle have it)."""
    wants = [oracle(node, row) for row in FUNCTION_ROWS]
    for row, want in zip(FUNCTION_ROWS, wants):
        assert scalar(node, row, want) == ("answered" if want != UNDEFINED else "refused")
    assert batch(node, FUNCTION_ROWS, wants) in ("answered", "refused")


#: A formula, evaluated in a subprocess, that answers within this many seconds.
PROMPT_S = 3.0
_EVALUATE = """
import sys
from tracecheck.b.evaluation import evaluate
from tracecheck.b.parser import parse_formula
from tracecheck.errors import TracecheckError
try:
    print(evaluate(parse_formula(sys.argv[1]), {}, source=sys.argv[1]))
except TracecheckError:
    print("refused")
"""


def _at_most_2_gib() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2 ** 31, 2 ** 31))


@pytest.mark.parametrize("node", [
    N(":", N("setext"), N("+->", N("setext", N("int", 0)),
                          N("+->", N("typeset", "NAT"), N("typeset", "BOOL")))),
    N(":", N("setext"), N("POW", N("iseq", N("typeset", "NAT1")))),
], ids=["arrow-of-NAT-arrow", "POW-iseq-NAT1"])
def test_huge_finite_sets_are_not_counted(node: Node):
    """A membership in a set built on NAT (finite, 2^31 elements) answers at once: the
    oracle's value (TRUE: {} is a partial function, a subset), or a refusal. In a
    subprocess, which is stopped after PROMPT_S seconds."""
    text = R.to_b(node)
    want = oracle(node, {})
    root = Path(__import__("tracecheck").__file__).resolve().parent.parent
    try:
        proc = subprocess.run([sys.executable, "-c", _EVALUATE, text], capture_output=True,
                              text=True, timeout=PROMPT_S, preexec_fn=_at_most_2_gib,
                              env={**os.environ, "PYTHONPATH": str(root)})
    except subprocess.TimeoutExpired:
        pytest.fail(f"{text}: no answer within {PROMPT_S:g} s", pytrace=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() in ("refused", str(want)), (text, proc.stdout)
