"""The built-in functions of B (``card``, ``dom``, ``prj1``, ``size``, …) for the compiler:
each takes the compiler (for located errors), the call node and the argument's value."""

from __future__ import annotations

import math
from typing import Any, Callable

from ..errors import TracecheckError, UnsupportedError
from . import ast
from .defined import Chain, applies
from .finite import finite as _finite
from .spaces import SeqSet
from .values import (FuncValue, Interval, PowSet, SymbolicSet, brief, cardinality, make_set,
                     sequence)

__all__ = ["BUILTINS", "UNSUPPORTED_HINTS", "iterate"]

def _card(c, node: ast.Call, v: Any) -> int:
    if isinstance(v, frozenset):
        return len(v)
    if not isinstance(v, SymbolicSet):
        raise c.type_error(node.args[0], v, "a finite set")
    try:
        return cardinality(v)
    except TracecheckError as exc:
        raise c.at(node, exc) from None


def _dom(c, node: ast.Call, v: Any) -> frozenset:
    if isinstance(v, FuncValue):
        return frozenset(v.map)
    return frozenset(p[0] for p in _finite(c, node.args[0], v))


def _ran(c, node: ast.Call, v: Any) -> frozenset:
    if isinstance(v, FuncValue):
        return frozenset(v.map.values())
    return frozenset(p[1] for p in _finite(c, node.args[0], v))


def _extreme(pick):
    def extreme(c, node: ast.Call, v: Any) -> Any:
        if isinstance(v, Interval) and v.card() > 0:
            return v.lo if pick is min else v.hi
        items = _finite(c, node.args[0], v)
        if not items:
            raise c.wd(node, f"{node.name} of the empty set")
        return pick(items)
    return extreme


def _number_fn(fn, wanted=(float,)):
    def number(c, node: ast.Call, v: Any) -> Any:
        if type(v) not in wanted:
            names = " or ".join("a real" if t is float else "an integer" for t in wanted)
            raise c.type_error(node.args[0], v, names)
        return fn(c, node, v)
    return number


def _to_real(c, node: ast.Call, v: Any) -> float:
    try:
        return float(v)
    except OverflowError:
        raise c.wd(node, f"{brief(v)} is too large for a real (at most about 1.8E308)") \
            from None


def _sqrt(c, node: ast.Call, v: float) -> float:
    if v < 0:
        raise c.wd(node, f"square root of the negative number {v}")
    return math.sqrt(v)


BUILTINS: dict[str, Callable[[Any, ast.Call, Any], Any]] = {
    "card": _card,
    "dom": _dom,
    "ran": _ran,
    "min": _extreme(min),
    "max": _extreme(max),
    "POW": lambda c, n, v: PowSet(v),
    "FIN": lambda c, n, v: PowSet(v, fin=True),
    "POW1": lambda c, n, v: PowSet(v, nonempty=True),
    "FIN1": lambda c, n, v: PowSet(v, nonempty=True, fin=True),
    "bool": lambda c, n, v: bool(v),
    "floor": _number_fn(lambda c, n, v: math.floor(v), (float, int)),
    "ceiling": _number_fn(lambda c, n, v: math.ceil(v), (float, int)),
    "real": _number_fn(lambda c, n, v: _to_real(c, n, v), (int, float)),
    "RSQRT": _number_fn(_sqrt, (float, int)),
    "RABS": _number_fn(lambda c, n, v: abs(v), (float, int)),
    "abs": _number_fn(lambda c, n, v: abs(v), (int, float)),
    "succ": _number_fn(lambda c, n, v: v + 1, (int,)),
    "pred": _number_fn(lambda c, n, v: v - 1, (int,)),
    "union": lambda c, n, v: frozenset().union(*_finite(c, n.args[0], v)),
    "inter": lambda c, n, v: frozenset.intersection(*_finite(c, n.args[0], v))
    if v else (_ for _ in ()).throw(c.wd(n, "inter of the empty set")),
    "id": lambda c, n, v: FuncValue({x: x for x in _finite(c, n.args[0], v)}),
    "prj1": lambda c, n, v: _component(c, n, v, 0),
    "prj2": lambda c, n, v: _component(c, n, v, 1),
    "closure1": lambda c, n, v: _closure1(_finite(c, n.args[0], v)),
    "fnc": lambda c, n, v: _fnc(_finite(c, n.args[0], v)),
    "rel": lambda c, n, v: make_set([(x, y) for x, ys in _finite(c, n.args[0], v)
                                     for y in _finite(c, n.args[0], ys)]),
    "size": lambda c, n, v: len(c.seq_items(n.args[0], v)),
    "first": lambda c, n, v: _nonempty_seq(c, n, v)[0],
    "last": lambda c, n, v: _nonempty_seq(c, n, v)[-1],
    "front": lambda c, n, v: sequence(_nonempty_seq(c, n, v)[:-1]),
    "tail": lambda c, n, v: sequence(_nonempty_seq(c, n, v)[1:]),
    "rev": lambda c, n, v: sequence(c.seq_items(n.args[0], v)[::-1]),
    "conc": lambda c, n, v: sequence([x for s in c.seq_items(n.args[0], v)
                                        for x in c.seq_items(n.args[0], s)]),
    "seq": lambda c, n, v: SeqSet("seq", v),
    "seq1": lambda c, n, v: SeqSet("seq1", v),
    "iseq": lambda c, n, v: SeqSet("iseq", v),
    "iseq1": lambda c, n, v: SeqSet("iseq1", v),
    "perm": lambda c, n, v: SeqSet("perm", v),
}

UNSUPPORTED_HINTS = {
    "closure": "closure(r) includes the identity on the whole type; write "
               "closure1(r) \\/ id(S) for the set S you mean",
}


def _component(c, node: ast.Call, v: Any, i: int) -> Any:
    if not isinstance(v, tuple):
        raise c.type_error(node.args[0], v, "a pair")
    return v[i]


def _nonempty_seq(c, node: ast.Call, v: Any) -> list:
    items = c.seq_items(node.args[0], v)
    if not items:
        raise c.wd(node, f"{node.name} of the empty sequence")
    return items


def _fnc(rel) -> frozenset:
    """``fnc(r)``: each x of dom(r) to the set of its images."""
    images: dict = {}
    for x, y in rel:
        images.setdefault(x, set()).add(y)
    return make_set([(x, frozenset(ys)) for x, ys in images.items()])


def iterate(c, node: ast.Call, r: Any, n: Any) -> Any:
    """``iterate(r, n)``: r composed with itself n times (n >= 1; n = 0 is the identity over
    the whole type, refused)."""
    n = c.int_of(node.args[1], n)
    if n < 0:
        raise c.wd(node, f"iterate of a negative number of times ({n})")
    if n == 0:
        raise c.error(UnsupportedError, node, "not supported: iterate(r, 0), the identity "
                      "over the whole type", hint="write id(S) for the set S you mean")
    if applies(r):  # a lambda over an infinite set: applied n times
        return Chain([r] * n, f"iterate({r.name}, {n})")
    pairs = _finite(c, node.args[0], r)
    step: dict = {}
    for x, y in pairs:
        step.setdefault(x, []).append(y)
    out = pairs
    for _ in range(n - 1):
        out = make_set([(x, z) for x, y in out for z in step.get(y, ())])
    return out


def _closure1(rel: frozenset) -> frozenset:
    """The transitive closure of a finite relation."""
    succ: dict = {}
    for x, y in rel:
        succ.setdefault(x, set()).add(y)
    out = []
    for start in succ:
        seen, todo = set(), list(succ[start])
        while todo:
            y = todo.pop()
            if y not in seen:
                seen.add(y)
                todo.extend(succ.get(y, ()))
        out.extend((start, y) for y in seen)
    return make_set(out)
