"""A deliberately naive evaluator of classical B's set theory over small finite domains: the
reference that tests/b/test_reference_oracle.py holds tracecheck to.

It shares no code with tracecheck (it imports nothing from it) and follows the definitions
of Abrial's B-Book as ProB reads them, spelled out one by one rather than computed cleverly:
``S --> T`` is the total functions of ``S <-> T``, ``perm(S)`` the injective sequences whose
range is S, ``r ; s`` the pairs through a middle element, and so on. Values are plain
Python: ``int``, ``bool``, ``str`` for an element of an enumerated set, a 2-``tuple`` for a
pair (``a |-> b``), ``frozenset`` for a set; a sequence is the set of its
``(index, item)`` pairs from 1. A set that is not built element by element (``POW(S)``,
``S --> T``, ``seq(S)``) is a :class:`Space`, enumerated only where an operation needs its
elements.

Formulas are :class:`Node` trees, printed as B text by :func:`to_b` for the engine under
test. :func:`evaluate` gives a formula's value or raises :class:`Undefined` where it is not
well-defined, with ProB's left-to-right reading of ``&``, ``or`` and ``=>`` (the B-Book's
well-definedness ``WD(P & Q) = WD(P) & (P => WD(Q))``): ``1 = 2 & 1/0 = 1`` is FALSE,
``1/0 = 1 & 1 = 2`` has no value. A quantifier or comprehension needs its body defined for
every element of its range. Function application ``f(x)`` needs exactly one image of ``x``
(ProB's reading; the B-Book also asks that ``f`` be a function elsewhere). Division
truncates towards zero and needs a divisor other than 0, ``a mod b`` needs a >= 0 and
b > 0, ``a ** b`` needs b >= 0, min, max and inter a non-empty set, first, last, front and
tail a non-empty sequence, and size, rev, ``^`` and conc sequences.
:class:`TooLarge` says the oracle would have to build too large a set: not a verdict.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import partial
from typing import Any, Iterable, Iterator, Optional, Union

__all__ = ["Node", "Space", "Undefined", "TooLarge", "evaluate", "to_b", "literal", "canon",
           "explicit", "finite", "member", "key", "ELEMENT_NAMES", "LIMIT", "ARROWS",
           "SEQ_KINDS", "INTEGER_SETS", "MAXINT", "MININT"]

#: The names of the enumerated set's elements (B identifiers; plain strings as values).
ELEMENT_NAMES = ("a", "b", "c")
#: The most elements the oracle builds for one set (or walks for one space).
LIMIT = 5000

Value = Any  # int | bool | str | tuple | frozenset | Space


class Undefined(Exception):
    """The formula is not well-defined (division by zero, f(x) outside dom(f), …)."""


class TooLarge(Exception):
    """The oracle would build more than :data:`LIMIT` elements: no verdict."""


@dataclass(frozen=True)
class Node:
    """One node of a formula: ``op`` and its arguments (nodes, or an int/bool/str leaf).

    Leaves: ``int`` (n), ``bool`` (b), ``elem`` (name), ``var`` (name), ``typeset``
    (BOOL, INTEGER, NATURAL, NATURAL1, INT, NAT or NAT1). Binders
    (``forall``, ``exists``, ``compr``, ``lambda``, ``sigma``, ``pi``) take (name, range,
    body), ``let`` (name, value, body); ``boolof`` is ``bool(P)``, ``union_all`` and
    ``inter_all`` the generalised ``union(SS)`` and ``inter(SS)``, ``dprod`` ``><``.
    """

    op: str
    args: tuple = ()

    def __str__(self) -> str:
        return to_b(self)


# ------------------------------------------------------------------ printing

_INFIX = {
    "add": "+", "sub": "-", "mul": "*", "div": "/", "mod": "mod", "pow": "**",
    "interval": "..", "union": "\\/", "inter": "/\\", "minus": "\\", "maplet": "|->",
    "prod": "*", "domres": "<|", "ranres": "|>", "domsub": "<<|", "ransub": "|>>",
    "override": "<+", "concat": "^",
    "<->": "<->", "+->": "+->", "-->": "-->", ">+>": ">+>", ">->": ">->", "+->>": "+->>",
    "-->>": "-->>", ">->>": ">->>",
    "and": "&", "or": "or", "implies": "=>", "equiv": "<=>",
    "=": "=", "/=": "/=", "<": "<", "<=": "<=", ">": ">", ">=": ">=", ":": ":", "/:": "/:",
    "<:": "<:", "<<:": "<<:", "/<:": "/<:", "/<<:": "/<<:",
}
_CALLS = ("card", "dom", "ran", "POW", "POW1", "FIN", "id", "size", "first", "last", "front",
          "tail", "rev", "conc", "seq", "seq1", "iseq", "iseq1", "perm", "min", "max")
ARROWS = ("<->", "+->", "-->", ">+>", ">->", "+->>", "-->>", ">->>")
SEQ_KINDS = ("seq", "seq1", "iseq", "iseq1", "perm")


def to_b(node: Node) -> str:
    """The B text of ``node``, every compound parenthesised (no priorities to get wrong)."""
    op, args = node.op, node.args
    if op == "int":
        return str(args[0]) if args[0] >= 0 else f"(-{-args[0]})"
    if op == "bool":
        return "TRUE" if args[0] else "FALSE"
    if op in ("elem", "var", "typeset"):
        return args[0]
    if op in _INFIX:
        return f"({to_b(args[0])} {_INFIX[op]} {to_b(args[1])})"
    if op == "comp":
        return f"({to_b(args[0])} ; {to_b(args[1])})"
    if op in _CALLS:
        return f"{op}({to_b(args[0])})"
    if op == "neg":
        return f"(-{to_b(args[0])})"
    if op == "boolof":
        return f"bool({to_b(args[0])})"
    if op in ("succ", "pred", "closure1"):
        return f"{op}({to_b(args[0])})"
    if op in ("union_all", "inter_all"):
        return f"{op[:-4]}({to_b(args[0])})"
    if op in ("prj1", "prj2"):
        return f"{op}({to_b(args[0])}, {to_b(args[1])})"
    if op == "dprod":
        return f"({to_b(args[0])} >< {to_b(args[1])})"
    if op == "if":
        return f"(IF {to_b(args[0])} THEN {to_b(args[1])} ELSE {to_b(args[2])} END)"
    if op == "let":
        name, value, body = args
        return f"(LET {name} BE {name} = {to_b(value)} IN {to_b(body)} END)"
    if op == "lambda":
        name, rng, body = args
        return f"%{name}.({name} : {to_b(rng)} | {to_b(body)})"
    if op in ("sigma", "pi"):
        name, rng, body = args
        return f"{op.upper()}({name}).({name} : {to_b(rng)} | {to_b(body)})"
    if op == "not":
        return f"not({to_b(args[0])})"
    if op == "inverse":
        return f"{to_b(args[0])}~"
    if op == "image":
        return f"{to_b(args[0])}[{to_b(args[1])}]"
    if op == "apply":
        return f"{to_b(args[0])}({to_b(args[1])})"
    if op == "setext":
        return "{" + ", ".join(to_b(a) for a in args) + "}"
    if op == "seqext":
        return "[" + ", ".join(to_b(a) for a in args) + "]"
    if op == "forall":
        name, rng, body = args
        return f"!{name}.({name} : {to_b(rng)} => {to_b(body)})"
    if op == "exists":
        name, rng, body = args
        return f"#{name}.({name} : {to_b(rng)} & {to_b(body)})"
    if op == "compr":
        name, rng, body = args
        return f"{{{name} | {name} : {to_b(rng)} & {to_b(body)}}}"
    raise ValueError(f"no B text for {op}")


def literal(value: Value, as_sequence: bool = False) -> Node:
    """The literal that denotes ``value`` (with ``as_sequence``, every non-empty sequence in
    it as ``[..]``; a set's elements in :func:`key` order)."""
    if isinstance(value, bool):
        return Node("bool", (value,))
    if isinstance(value, int):
        return Node("int", (value,))
    if isinstance(value, str):
        return Node("elem", (value,))
    if isinstance(value, tuple):
        return Node("maplet", (literal(value[0], as_sequence), literal(value[1], as_sequence)))
    value = explicit(value)
    if as_sequence and value and _items(value) is not None:
        return Node("seqext", tuple(literal(x, as_sequence) for x in _items(value)))
    return Node("setext", tuple(literal(x, as_sequence) for x in sorted(value, key=key)))


def key(value: Value) -> tuple:
    """A total order and an exact identity over values, types included (``True`` and ``1``
    are different here, as they are in B)."""
    if isinstance(value, bool):
        return ("bool", value)
    if isinstance(value, int):
        return ("int", value)
    if isinstance(value, float):
        return ("real", value)  # never the oracle's, but an engine's wrong answer may be one
    if isinstance(value, str):
        return ("elem", value)
    if isinstance(value, tuple):
        return ("pair", key(value[0]), key(value[1]))
    return ("set", tuple(sorted(key(x) for x in explicit(value))))


# ------------------------------------------------------------------ sets


#: ProB's default MAXINT and MININT (the bounds of INT, NAT, NAT1).
MAXINT, MININT = 2 ** 31 - 1, -2 ** 31
#: The integer sets of B: (least, greatest), None where there is no bound.
INTEGER_SETS = {"INTEGER": (None, None), "NATURAL": (0, None), "NATURAL1": (1, None),
                "INT": (MININT, MAXINT), "NAT": (0, MAXINT), "NAT1": (1, MAXINT)}


class Space:
    """A set given by its definition: ``POW(S)``, ``POW1(S)``, ``FIN(S)``, ``S op T`` for
    the arrows, ``seq(S)``/``seq1``/``iseq``/``iseq1``/``perm``, and the integer sets
    ``INTEGER``, ``NATURAL``, ``NAT``, … (no parts)."""

    def __init__(self, kind: str, *parts: Value) -> None:
        self.kind, self.parts = kind, parts
        self._elements: Optional[frozenset] = None

    def __repr__(self) -> str:
        return f"Space({self.kind!r}, {', '.join(map(repr, self.parts))})"

    def finite(self) -> Optional[bool]:
        """True: finite; False: infinite; None: the oracle does not tell (it does not
        reason about ``{0} -->> NATURAL``, which is empty)."""
        kind = self.kind
        if kind in INTEGER_SETS:
            return None not in INTEGER_SETS[kind]
        parts = [finite(p) for p in self.parts]
        if all(parts):
            if kind in ("seq", "seq1"):
                return not explicit(self.parts[0])  # seq({}) = {[]}, seq1({}) = {}
            return True
        if kind in ("POW", "POW1", "FIN", "seq", "seq1", "iseq", "iseq1"):
            return False if parts[0] is False else None  # {x} or [x] for each x of S
        if kind in ARROWS and parts[0] and not explicit(self.parts[0]):
            return True  # the functions of the empty set: {{}}
        return None

    def contains(self, v: Value) -> bool:
        kind = self.kind
        if kind in INTEGER_SETS:
            lo, hi = INTEGER_SETS[kind]
            return type(v) is int and (lo is None or v >= lo) and (hi is None or v <= hi)
        if kind in ("POW", "POW1", "FIN"):
            (base,) = self.parts
            return isinstance(v, frozenset) and all(member(x, base) for x in v) and \
                (kind != "POW1" or bool(v))
        if kind in ARROWS:
            return _in_arrow(kind, v, *self.parts)
        return _in_sequences(kind, v, self.parts[0])

    def elements(self) -> frozenset:
        """Every element, enumerated once (then kept: a space's elements never change)."""
        if self._elements is None:
            self._elements = self._enumerate()
        return self._elements

    def _enumerate(self) -> frozenset:
        kind = self.kind
        if self.finite() is not True:
            raise TooLarge(f"{kind}(..) is infinite, or the oracle cannot tell")
        if kind in INTEGER_SETS:
            lo, hi = INTEGER_SETS[kind]
            _check(hi - lo + 1)
        if kind in ("POW", "POW1", "FIN"):
            base = sorted(explicit(self.parts[0]), key=key)
            _check(2 ** len(base))
            subsets = (frozenset(c) for k in range(len(base) + 1)
                       for c in itertools.combinations(base, k))
            return frozenset(s for s in subsets if kind != "POW1" or s)
        if kind in ARROWS:
            dom, ran = (sorted(explicit(p), key=key) for p in self.parts)
            if kind == "<->":
                pairs = [(x, y) for x in dom for y in ran]
                _check(2 ** len(pairs))
                return frozenset(frozenset(c) for k in range(len(pairs) + 1)
                                 for c in itertools.combinations(pairs, k))
            # a function: each x of the domain mapped to one y, or (partial) to none
            choices = ran + ([] if kind in ("-->", ">->", "-->>", ">->>") else [_NONE])
            _check(len(choices) ** len(dom))
            candidates = (frozenset((x, y) for x, y in zip(dom, pick) if y is not _NONE)
                          for pick in itertools.product(choices, repeat=len(dom)))
            return frozenset(f for f in candidates if self.contains(f))
        base = sorted(explicit(self.parts[0]), key=key)
        if kind in ("seq", "seq1"):
            return frozenset({frozenset()}) if kind == "seq" else frozenset()
        lengths = [len(base)] if kind == "perm" else \
            range(1 if kind == "iseq1" else 0, len(base) + 1)
        _check(sum(_falling(len(base), k) for k in lengths))
        return frozenset(frozenset(enumerate(p, start=1))
                         for k in lengths for p in itertools.permutations(base, k))


_NONE = object()


def _falling(n: int, k: int) -> int:
    out = 1
    for i in range(k):
        out *= n - i
    return out


def _check(size: int) -> None:
    if size > LIMIT:
        raise TooLarge(f"{size} elements")


def _in_arrow(kind: str, f: Value, dom: Value, ran: Value) -> bool:
    """``f : dom kind ran`` from the definitions: a relation (pairs of dom * ran), then
    functional (no x twice), total (its domain is dom), injective (its inverse functional),
    surjective (its range is ran)."""
    if not isinstance(f, frozenset):
        return False
    if not all(isinstance(p, tuple) and member(p[0], dom) and member(p[1], ran) for p in f):
        return False
    if kind == "<->":
        return True
    firsts = [p[0] for p in f]
    seconds = [p[1] for p in f]
    if len(set(firsts)) != len(firsts):
        return False
    if kind in ("-->", ">->", "-->>", ">->>"):
        if finite(dom) is False:
            return False  # finitely many pairs are never total on an infinite set
        if frozenset(firsts) != explicit(dom):
            return False
    if kind in (">+>", ">->", ">->>") and len(set(seconds)) != len(seconds):
        return False
    if kind in ("+->>", "-->>", ">->>"):
        if finite(ran) is False:
            return False  # finitely many values are never all of an infinite set
        if frozenset(seconds) != explicit(ran):
            return False
    return True


def _in_sequences(kind: str, s: Value, base: Value) -> bool:
    """``s : kind(base)``: a function from 1..n into base (seq), non-empty (seq1),
    injective (iseq), both (iseq1), or injective onto all of base (perm)."""
    items = _items(s) if isinstance(s, frozenset) else None
    if items is None or not all(member(x, base) for x in items):
        return False
    if kind in ("seq1", "iseq1") and not items:
        return False
    if kind in ("iseq", "iseq1", "perm") and len(set(items)) != len(items):
        return False
    if kind == "perm" and frozenset(items) != explicit(base):
        return False
    return True


def _items(s: frozenset) -> Union[list, None]:
    """The items of the sequence ``s`` in order, or None if it is not a sequence."""
    if not all(isinstance(p, tuple) and type(p[0]) is int for p in s):
        return None  # (TRUE |-> x) is no sequence, though TRUE == 1 in Python
    indices = sorted(p[0] for p in s)
    if indices != list(range(1, len(s) + 1)):
        return None  # also: an index twice (not a function) or not an integer
    return [p[1] for p in sorted(s, key=lambda p: p[0])]


def finite(value: Value) -> Optional[bool]:
    """Whether a set value is finite (None: the oracle does not tell)."""
    return value.finite() if isinstance(value, Space) else True


def explicit(value: Value) -> frozenset:
    """The elements of a set value (a :class:`Space` enumerated)."""
    if isinstance(value, Space):
        return value.elements()
    if not isinstance(value, frozenset):
        raise TypeError(f"not a set: {value!r}")
    return value


def canon(value: Value) -> Value:
    """``value`` with every :class:`Space` replaced by its elements (so it compares and
    hashes as a plain value)."""
    return explicit(value) if isinstance(value, Space) else value


def member(x: Value, s: Value) -> bool:
    """``x : s``."""
    x = canon(x)
    if isinstance(s, Space):
        return s.contains(x)
    return x in explicit(s)


def make_set(items: Iterable[Value]) -> frozenset:
    out = frozenset(canon(x) for x in items)
    _check(len(out))
    return out


def _sequence(items: list) -> frozenset:
    return frozenset(enumerate(items, start=1))


def _as_sequence(value: Value, what: str) -> list:
    items = _items(explicit(value))
    if items is None:
        raise Undefined(f"{what} of a relation that is not a sequence")
    return items


def _nonempty(value: Value, what: str) -> list:
    items = _as_sequence(value, what)
    if not items:
        raise Undefined(f"{what} of the empty sequence")
    return items


# ------------------------------------------------------------------ evaluation


def evaluate(node: Node, env: dict[str, Value]) -> Value:
    """The value of ``node`` where the free names have the values of ``env``; raises
    :class:`Undefined` where it is not well-defined, :class:`TooLarge` where a set is too
    large to build."""
    op, args = node.op, node.args
    if op in ("int", "bool"):
        return args[0]
    if op == "elem":
        return args[0]
    if op == "var":
        return env[args[0]]
    if op == "typeset":
        return frozenset({False, True}) if args[0] == "BOOL" else Space(args[0])
    fn = _EVAL.get(op)
    if fn is not None:
        return fn(node, env)
    if op in _BINARY:
        return _BINARY[op](evaluate(args[0], env), evaluate(args[1], env))
    if op in _UNARY:
        return _UNARY[op](evaluate(args[0], env))
    raise ValueError(f"the oracle has no meaning for {op}")


def _div(a: int, b: int) -> int:
    if b == 0:
        raise Undefined("division by zero")
    q = abs(a) // abs(b)  # B's division truncates towards zero: -7 / 2 = -3
    return q if (a >= 0) == (b > 0) else -q


def _mod(a: int, b: int) -> int:
    if a < 0 or b <= 0:
        raise Undefined(f"{a} mod {b}: mod needs a >= 0 and b > 0")
    return a - b * (a // b)


def _pow(a: int, b: int) -> int:
    if b < 0:
        raise Undefined("negative exponent")
    out = 1
    for _ in range(b):
        out *= a
    return out


def _pairs(r: Value) -> frozenset:
    return explicit(r)


def _compose(r: Value, s: Value) -> frozenset:
    return make_set((x, z) for (x, y) in _pairs(r) for (y2, z) in _pairs(s) if y == y2)


def _override(r: Value, s: Value) -> frozenset:
    dom_s = {p[0] for p in _pairs(s)}
    return make_set([p for p in _pairs(r) if p[0] not in dom_s] + list(_pairs(s)))


def _extreme(pick):
    def extreme(s: Value) -> int:
        items = explicit(s)
        if not items:
            raise Undefined("min/max of the empty set")
        return pick(items)
    return extreme


def _interval(a: int, b: int) -> frozenset:
    _check(b - a + 1)
    return make_set(range(a, b + 1))


_BINARY = {
    "add": lambda a, b: a + b,
    "sub": lambda a, b: a - b,
    "mul": lambda a, b: a * b,
    "div": _div,
    "mod": _mod,
    "pow": _pow,
    "interval": _interval,
    "maplet": lambda a, b: (canon(a), canon(b)),
    "union": lambda a, b: make_set(explicit(a) | explicit(b)),
    "inter": lambda a, b: make_set(explicit(a) & explicit(b)),
    "minus": lambda a, b: make_set(explicit(a) - explicit(b)),
    "prod": lambda a, b: make_set((x, y) for x in explicit(a) for y in explicit(b)),
    "domres": lambda s, r: make_set(p for p in _pairs(r) if member(p[0], s)),
    "ranres": lambda r, t: make_set(p for p in _pairs(r) if member(p[1], t)),
    "domsub": lambda s, r: make_set(p for p in _pairs(r) if not member(p[0], s)),
    "ransub": lambda r, t: make_set(p for p in _pairs(r) if not member(p[1], t)),
    "override": _override,
    "comp": _compose,
    "dprod": lambda r, s: make_set((x, (y, z)) for (x, y) in _pairs(r) for (x2, z) in _pairs(s)
                                   if x == x2),
    "prj1": lambda s, t: make_set(((x, y), x) for x in explicit(s) for y in explicit(t)),
    "prj2": lambda s, t: make_set(((x, y), y) for x in explicit(s) for y in explicit(t)),
    "image": lambda r, s: make_set(p[1] for p in _pairs(r) if member(p[0], s)),
    "concat": lambda s, t: _sequence(_as_sequence(s, "^") + _as_sequence(t, "^")),
    **{arrow: partial(Space, arrow) for arrow in ARROWS},
    "=": lambda a, b: canon(a) == canon(b),
    "/=": lambda a, b: canon(a) != canon(b),
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
    ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b,
    ":": member,
    "/:": lambda x, s: not member(x, s),
    "<:": lambda a, b: _subset(a, b),
    "/<:": lambda a, b: not _subset(a, b),
    "<<:": lambda a, b: _subset(a, b, strict=True),
    "/<<:": lambda a, b: not _subset(a, b, strict=True),
}


def _subset(a: Value, b: Value, strict: bool = False) -> bool:
    items = explicit(a)
    if not all(member(x, b) for x in items):
        return False
    if not strict:
        return True
    if finite(b) is False:
        return True  # a finite set is never all of an infinite one
    return items != explicit(b)


def _apply(f: Value, x: Value) -> Value:
    x = canon(x)
    images = [p[1] for p in _pairs(f) if p[0] == x and key(p[0]) == key(x)]
    if not images:
        raise Undefined("f(x) with x outside dom(f)")
    if len(images) > 1:
        raise Undefined("f(x) with several images of x")
    return images[0]


def _closure1(r: Value) -> frozenset:
    """The smallest transitive relation that holds r: r \\/ (r ; r) \\/ … until nothing new."""
    out = _pairs(r)
    while True:
        more = out | _compose(out, r)
        if more == out:
            return out
        out = more


def _inter_all(ss: Value) -> frozenset:
    sets = [explicit(s) for s in explicit(ss)]
    if not sets:
        raise Undefined("inter of the empty set")
    out = sets[0]
    for s in sets[1:]:
        out = out & s
    return out


def _conc(ss: Value) -> frozenset:
    items: list = []
    for s in _as_sequence(ss, "conc"):
        items += _as_sequence(s, "conc")
    return _sequence(items)


_UNARY = {
    "neg": lambda a: -a,
    "card": lambda s: len(explicit(s)),
    "dom": lambda r: make_set(p[0] for p in _pairs(r)),
    "ran": lambda r: make_set(p[1] for p in _pairs(r)),
    "inverse": lambda r: make_set((p[1], p[0]) for p in _pairs(r)),
    "id": lambda s: make_set((x, x) for x in explicit(s)),
    **{kind: partial(Space, kind) for kind in ("POW", "POW1", "FIN") + SEQ_KINDS},
    "min": _extreme(min),
    "max": _extreme(max),
    "size": lambda s: len(_as_sequence(s, "size")),
    "first": lambda s: _nonempty(s, "first")[0],
    "last": lambda s: _nonempty(s, "last")[-1],
    "front": lambda s: _sequence(_nonempty(s, "front")[:-1]),
    "tail": lambda s: _sequence(_nonempty(s, "tail")[1:]),
    "rev": lambda s: _sequence(_as_sequence(s, "rev")[::-1]),
    "conc": _conc,
    "succ": lambda a: a + 1,
    "pred": lambda a: a - 1,
    "closure1": _closure1,
    "union_all": lambda ss: make_set(x for s in explicit(ss) for x in explicit(s)),
    "inter_all": _inter_all,
}


def _logic(node: Node, env: dict) -> bool:
    """``&``, ``or``, ``=>`` left to right (the right side only where the left does not
    decide); ``<=>`` needs both."""
    op, (left, right) = node.op, node.args
    p = evaluate(left, env)
    if op == "and":
        return p and evaluate(right, env)
    if op == "or":
        return p or evaluate(right, env)
    if op == "implies":
        return (not p) or evaluate(right, env)
    q = evaluate(right, env)
    return p == q


def _bound(node: Node, env: dict) -> Iterator[tuple[Value, Value]]:
    """Each element of the binder's range with the body's value there (every one of them
    evaluated: the body must be defined on the whole range)."""
    name, rng, body = node.args
    elements = sorted(explicit(evaluate(rng, env)), key=key)
    results = [(x, canon(evaluate(body, {**env, name: x}))) for x in elements]
    return iter(results)


def _if(node: Node, env: dict) -> Value:
    cond, then, other = node.args
    return evaluate(then if evaluate(cond, env) else other, env)


def _let(node: Node, env: dict) -> Value:
    name, value, body = node.args
    return evaluate(body, {**env, name: canon(evaluate(value, env))})


def _product(values: list) -> int:
    out = 1
    for v in values:
        out *= v
    return out


def _apply_node(node: Node, env: dict) -> Value:
    return _apply(evaluate(node.args[0], env), evaluate(node.args[1], env))


_EVAL = {
    "and": _logic, "or": _logic, "implies": _logic, "equiv": _logic,
    "not": lambda node, env: not evaluate(node.args[0], env),
    "boolof": lambda node, env: evaluate(node.args[0], env),
    "forall": lambda node, env: all(v for _, v in _bound(node, env)),
    "exists": lambda node, env: any(v for _, v in _bound(node, env)),
    "compr": lambda node, env: make_set(x for x, v in _bound(node, env) if v),
    "lambda": lambda node, env: make_set((x, v) for x, v in _bound(node, env)),
    "sigma": lambda node, env: sum(v for _, v in _bound(node, env)),
    "pi": lambda node, env: _product([v for _, v in _bound(node, env)]),
    "if": _if,
    "let": _let,
    "apply": _apply_node,
    "setext": lambda node, env: make_set(evaluate(a, env) for a in node.args),
    "seqext": lambda node, env: _sequence([canon(evaluate(a, env)) for a in node.args]),
}
