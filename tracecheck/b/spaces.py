"""The symbolic sets of functions and sequences: ``S --> T`` and its variants,
``prj1(S, T)``/``prj2(S, T)``, and ``seq(S)``/``iseq(S)``/``perm(S)``."""

from __future__ import annotations

import math
from typing import Any, Iterator, Optional

from ..errors import EvaluationError, SetLimitError
from ..limits import MAX_INT_BITS
from .clock import tick
from .values import (SET_LIMIT, FuncValue, PowSet, Product, SymbolicSet, as_sequence,
                     cardinality, check_size, contains, finiteness, format_value, is_set,
                     members, set_key, sort_key)

__all__ = ["FunctionSpace", "Projection", "SeqSet", "covers"]


#: the largest card of a function space computed (an integer of this many bits, as ``**``)
CARD_BITS = MAX_INT_BITS

_TOTAL = ("-->", ">->", "-->>", ">->>")
_INJECTIVE = (">->", ">+>", ">->>", ">+>>")
_SURJECTIVE = ("-->>", "+->>", ">->>", ">+>>")


class FunctionSpace(SymbolicSet):
    """``S --> T``, ``S +-> T``, ``S <-> T`` and the injective/surjective variants."""

    def __init__(self, op: str, dom: Any, ran: Any) -> None:
        self.op, self.dom, self.ran = op, dom, ran

    @property
    def name(self) -> str:  # written out only for a message (a map's space is checked often)
        return f"({format_value(self.dom)} {self.op} {format_value(self.ran)})"

    def finiteness(self) -> Optional[bool]:
        fd, fr = finiteness(self.dom), finiteness(self.ran)
        return True if (fd and fr) else None

    def contains(self, value: Any) -> bool:
        if not is_set(value):
            return False
        if isinstance(value, SymbolicSet):
            if value.finiteness() is not True:
                raise EvaluationError(f"cannot decide whether {value.name} is in {self.name}")
            value = value.materialise()
        pairs = list(value)
        if not all(isinstance(p, tuple) and len(p) == 2 for p in pairs):
            return False
        if not all(contains(self.dom, p[0]) and contains(self.ran, p[1]) for p in pairs):
            return False
        if self.op == "<->":
            return True
        firsts = {p[0] for p in pairs}
        if len(firsts) != len(pairs):
            return False
        if self.op in _TOTAL and not covers(firsts, self.dom):
            return False
        seconds = {p[1] for p in pairs}
        if self.op in _INJECTIVE and len(seconds) != len(pairs):
            return False
        if self.op in _SURJECTIVE and not covers(seconds, self.ran):
            return False
        return True

    def card(self) -> int:
        if self.finiteness() is not True:
            return SymbolicSet.card(self)
        d, r = cardinality(self.dom), cardinality(self.ran)
        bits = {"<->": d * r, "+->": d * math.log2(r + 1),
                "-->": d * math.log2(r) if r else 0}.get(self.op, 0)
        if bits > CARD_BITS:
            raise SetLimitError(f"card({self.name}) has more than {CARD_BITS:,} bits: too "
                                "large to compute")
        if self.op == "<->":
            return 2 ** (d * r)
        if self.op == "+->":
            return (r + 1) ** d
        if self.op == "-->":
            return r ** d
        return sum(1 for _ in self._walk())

    def elements(self) -> Iterator[Any]:
        return self._walk()

    def _walk(self) -> Iterator[Any]:
        from itertools import product
        dom = sorted(members(self.dom), key=sort_key)
        ran = sorted(members(self.ran), key=sort_key)
        if self.op == "<->":
            yield from PowSet(Product(frozenset(dom), frozenset(ran))).elements()
            return
        choices = [ran] if self.op in _TOTAL else [[_NONE] + ran]
        if len(dom) * math.log2(max(len(choices[0]), 1)) > 64:  # not computed: far too many
            raise SetLimitError(f"the set {self.name} has about 10^"
                                f"{int(len(dom) * math.log10(len(choices[0])))} elements; "
                                f"tracecheck builds or walks at most {SET_LIMIT:,} elements "
                                "of one set")
        check_size(len(choices[0]) ** len(dom), self.name)
        for pick in product(choices[0], repeat=len(dom)):
            f = FuncValue({x: y for x, y in zip(dom, pick) if y is not _NONE})
            if self.op in ("-->", "+->") or self.contains(f):
                yield f

    def key(self) -> tuple:
        return ("arrow", self.op, set_key(self.dom), set_key(self.ran))


_NONE = object()


class Projection(SymbolicSet):
    """``prj1(S, T)`` / ``prj2(S, T)``: the function ``(x|->y) |-> x`` (or ``y``) on S*T."""

    def __init__(self, which: int, s: Any, t: Any) -> None:
        self.which, self.s, self.t = which, s, t
        self._domain = Product(s, t)

    @property
    def name(self) -> str:  # printed when asked (a message): not at every application
        text = self.__dict__.get("_name")
        if text is None:
            text = self.__dict__["_name"] = \
                f"prj{self.which}({format_value(self.s)},{format_value(self.t)})"
        return text

    def finiteness(self) -> Optional[bool]:
        return self._domain.finiteness()

    def apply(self, x: Any) -> Any:
        if not self._domain.contains(x):
            raise KeyError(x)
        return x[self.which - 1]

    def in_domain(self, x: Any) -> bool:
        """Whether ``x`` is a pair of S * T (where :meth:`apply` gives its component)."""
        return self._domain.contains(x)

    def contains(self, v: Any) -> bool:
        if not (isinstance(v, tuple) and len(v) == 2):
            return False
        try:
            return self.apply(v[0]) == v[1]
        except KeyError:
            return False

    def card(self) -> int:
        return self._domain.card()

    def elements(self) -> Iterator[Any]:
        return ((p, p[self.which - 1]) for p in self._domain.elements())

    def key(self) -> tuple:
        return ("prj", self.which, set_key(self.s), set_key(self.t))


class SeqSet(SymbolicSet):
    """``seq(S)``, ``seq1(S)``, ``iseq(S)``, ``iseq1(S)``, ``perm(S)``: membership; the
    elements of the finite ones (an injective sequence over a finite set, a permutation)."""

    def __init__(self, kind: str, base: Any) -> None:
        self.kind, self.base = kind, base
        self.name = f"{kind}({format_value(base)})"

    def finiteness(self) -> Optional[bool]:
        fb = finiteness(self.base)
        if fb is True and cardinality(self.base) == 0:
            return True  # seq({}) = iseq({}) = perm({}) = {[]}; seq1({}) = iseq1({}) = {}
        if self.kind in ("seq", "seq1"):
            return None if fb is None else False  # a non-empty base: every length
        if fb is True:
            return True  # no item twice: at most card(S) items
        return False if (fb is False and self.kind != "perm") else None

    def contains(self, value: Any) -> bool:
        items = as_sequence(value)
        if items is None or not all(contains(self.base, x) for x in items):
            return False
        if self.kind in ("seq1", "iseq1") and not items:
            return False
        if self.kind in ("iseq", "iseq1", "perm") and len(set(items)) != len(items):
            return False
        if self.kind == "perm":
            return covers(set(items), self.base)
        return True

    def card(self) -> int:
        if self.finiteness() is not True:
            return SymbolicSet.card(self)
        n = cardinality(self.base)
        if math.lgamma(n + 1) / math.log(2) > CARD_BITS:  # n! (and e·n! for iseq) bits
            raise SetLimitError(f"card({self.name}) has more than {CARD_BITS:,} bits: too "
                                "large to compute")
        if self.kind == "perm":
            return math.factorial(n)
        total = 1  # Σ_k n!/(n-k)! injective sequences of length k, by Horner: 1 + n(1 + …)
        for j in range(1, n + 1):
            tick()
            total = 1 + j * total
        return total - 1 if self.kind in ("seq1", "iseq1") else total

    def elements(self) -> Iterator[Any]:
        if self.finiteness() is not True:
            return SymbolicSet.elements(self)
        check_size(self.card(), self.name)
        from itertools import permutations
        base = sorted(members(self.base), key=sort_key)
        if self.kind == "perm":
            lengths: Any = [len(base)]
        else:
            lengths = range(1 if self.kind in ("seq1", "iseq1") else 0, len(base) + 1)
        return (FuncValue({i + 1: x for i, x in enumerate(p)})
                for k in lengths for p in permutations(base, k))

    def key(self) -> tuple:
        return ("seq", self.kind, set_key(self.base))


def covers(values: set, space: Any) -> bool:
    """Whether ``values`` are exactly the elements of the finite set ``space`` (an error
    where tracecheck cannot tell whether ``space`` is finite: an infinite one is never
    covered)."""
    fs = finiteness(space)
    if fs is False:
        return False
    if fs is None:
        raise EvaluationError(f"cannot tell whether {format_value(space)} is finite, so "
                              f"whether these {len(values)} values are all of it")
    if cardinality(space) != len(values):
        return False
    return all(contains(space, v) for v in values)
