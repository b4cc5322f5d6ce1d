"""B values in Python: their representation, the algebra of sets, and their canonical text.

Representation: integers ``int``, reals ``float``, booleans ``bool``, strings ``str``,
elements of deferred and enumerated sets :class:`Elem`, pairs ``tuple`` of two, sets
``frozenset`` (a function literal is a :class:`FuncValue`, a frozenset of pairs that also
keeps a dict for fast application), and infinite or lazily enumerated sets
:class:`SymbolicSet`. The symbolic sets of functions and sequences are in
:mod:`.spaces`; reading B literals and JSON in :mod:`.notation`. Printing stays here because
a symbolic set is named by the text of its parts (``POW(1..3)``).
"""

from __future__ import annotations

import math
import re
from typing import Any, Callable, Iterable, Iterator, Optional

from ..errors import EvaluationError, SetLimitError
from ..limits import int_text
from .names import name_text

__all__ = [
    "Elem", "Record", "FuncValue", "SymbolicSet", "BuiltinSet", "Interval", "PowSet", "Product",
    "SET_LIMIT", "check_size", "make_set", "hashable", "finiteness", "cardinality", "members",
    "explicit", "contains", "is_subset", "set_equal", "brief", "as_sequence", "sequence",
    "format_value", "format_real", "is_set", "BUILTIN_SET_VALUES", "sort_key", "set_key",
]


class Elem(str):
    """An element of a deferred or enumerated set (``EgoVehicle``, ``Heads``).

    A ``str`` subclass so that hashing and dict lookups stay as fast as for strings; it is
    a different type from B strings, which are plain ``str``.
    """

    __slots__ = ()

    def __repr__(self) -> str:
        return f"Elem({str(self)!r})"

    def __copy__(self) -> "Elem":
        return self

    def __deepcopy__(self, memo: dict) -> "Elem":  # immutable: copies share it (an info
        return self  # holding a B state is deep-copied by SB3's vector environments)


class Record:
    """A B record ``rec(a:1,b:TRUE)``: (name, value) pairs sorted by name, as ProB keeps them
    (so ``rec(b:1,a:2) = rec(a:2,b:1)``). Not a tuple: tuples are pairs."""

    __slots__ = ("fields",)

    def __init__(self, fields) -> None:
        self.fields = tuple(sorted(((n, hashable(v)) for n, v in fields), key=lambda f: f[0]))

    def names(self) -> tuple[str, ...]:
        return tuple(n for n, _ in self.fields)

    def get(self, name: str) -> Any:
        for n, v in self.fields:
            if n == name:
                return v
        raise KeyError(name)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Record) and self.fields == other.fields

    def __hash__(self) -> int:
        return hash(("rec", self.fields))

    def __repr__(self) -> str:
        return f"Record({list(self.fields)!r})"

    def __copy__(self) -> "Record":
        return self

    def __deepcopy__(self, memo: dict) -> "Record":  # immutable, as Elem
        return self


class FuncValue(frozenset):
    """A set of pairs whose first components are distinct: a function, applied in O(1)."""

    __slots__ = ("map",)

    def __new__(cls, mapping: dict):
        obj = super().__new__(cls, mapping.items())
        obj.map = mapping
        return obj

    def __reduce__(self):
        return (FuncValue, (dict(self.map),))

    def __copy__(self) -> "FuncValue":
        return self

    def __deepcopy__(self, memo: dict) -> "FuncValue":  # immutable, as Elem
        return self


#: The most elements tracecheck builds or walks for one set; above it a clear error.
SET_LIMIT = 1_000_000


class SymbolicSet:
    """A set not held element by element (INTEGER, a..b, POW(S), S*T, S --> T).

    Every finite one behaves like its explicit form: it compares equal to it, hashes like it
    (so it nests in sets and pairs), counts and enumerates; it is built element by element
    only where that is needed, and never above :data:`SET_LIMIT` elements.
    """

    name = "set"

    def finiteness(self) -> Optional[bool]:
        """True: finite; False: infinite; None: tracecheck cannot tell."""
        return False

    @property
    def finite(self) -> bool:
        return self.finiteness() is True

    def contains(self, value: Any) -> bool:
        raise NotImplementedError

    def card(self) -> int:
        """The exact number of elements of a finite set (without building it)."""
        raise self.refusal() or EvaluationError(_not_finite(self, "it has no card"))

    def refusal(self) -> Optional[EvaluationError]:
        """Why its elements cannot be listed, where the set knows better than "not finite"
        (None here)."""
        return None

    def elements(self) -> Iterator[Any]:
        what = "infinite" if self.finiteness() is False else "not known to be finite"
        known = self.refusal()
        if known is not None:
            raise known
        raise EvaluationError(f"cannot enumerate the set {self.name} ({what})",
                              hint="restrict the variable with a finite set, e.g. x : 1..10")

    def key(self) -> tuple:
        """What identifies an infinite set (two sets with the same key are equal)."""
        return (type(self).__name__, self.name)

    def __iter__(self) -> Iterator[Any]:
        if self.finiteness() is not True:
            return SymbolicSet.elements(self)
        check_size(self.card(), self.name)
        return self.elements()

    def __len__(self) -> int:
        return self.card()

    def materialise(self) -> frozenset:
        """The explicit form (refused above :data:`SET_LIMIT` elements)."""
        return make_set(iter(self))

    def __contains__(self, value: Any) -> bool:
        return self.contains(value)

    def __eq__(self, other: object) -> bool:
        if not is_set(other):
            return NotImplemented
        return set_equal(self, other)

    def __ne__(self, other: object) -> bool:
        result = self.__eq__(other)
        return result if result is NotImplemented else not result

    def __hash__(self) -> int:
        if self.finiteness() is True:
            return hash(self.materialise())
        # every other one alike: two such sets meet in a Python set or dict only through
        # __eq__, which decides or refuses — their keys differ where the sets may not
        # ({x | x > 5} and {y | y >= 6}: two elements, card 2, were B's one)
        return _UNLISTED_HASH

    def __repr__(self) -> str:
        return self.name


#: the hash of every set not known to be finite (see :meth:`SymbolicSet.__hash__`)
_UNLISTED_HASH = hash(("tracecheck", "a set not known to be finite"))


def check_size(n: int, what: str) -> None:
    if n > SET_LIMIT:
        raise SetLimitError(
            f"the set {what} has {_count(n)} elements; tracecheck builds or walks at most "
            f"{SET_LIMIT:,} elements of one set",
            hint="use a smaller set, or a predicate that does not need its elements")


def _count(n: int) -> str:
    if n.bit_length() > 100:  # the digits estimated, never converted (it may be huge)
        return f"about 10^{int((n.bit_length() - 1) * math.log10(2))}"
    return f"{n:,}"


def hashable(v: Any) -> Any:
    """``v``, with a finite symbolic set replaced by its explicit form (to hash it by value)."""
    if isinstance(v, SymbolicSet) and v.finiteness() is True:
        return v.materialise()
    return v


def make_set(items: Iterable[Any]) -> frozenset:
    """The set of ``items``: a :class:`FuncValue` when they are pairs with distinct firsts."""
    items = list(items)
    if items and all(type(i) is tuple for i in items):
        mapping = dict(items)
        if len(mapping) == len(items):
            return FuncValue(mapping)
    try:
        return frozenset(items)
    except TypeError:
        return frozenset(hashable(i) for i in items)


class BuiltinSet(SymbolicSet):
    """INTEGER, NATURAL, NATURAL1, REAL, STRING: infinite, identified by name."""

    def __init__(self, name: str, test: Callable[[Any], bool]) -> None:
        self.name = name
        self._test = test

    def contains(self, value: Any) -> bool:
        return self._test(value)

    def key(self) -> tuple:
        return ("builtin", self.name)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


class Interval(SymbolicSet):
    """``a..b``, enumerated lazily."""

    def __init__(self, lo: int, hi: int) -> None:
        self.lo, self.hi = lo, hi
        self.name = f"{lo}..{hi}"

    def finiteness(self) -> Optional[bool]:
        return True

    def contains(self, value: Any) -> bool:
        return _is_int(value) and self.lo <= value <= self.hi

    def elements(self) -> Iterator[int]:
        return iter(range(self.lo, self.hi + 1))

    def card(self) -> int:
        return max(0, self.hi - self.lo + 1)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Interval):
            return self.card() == other.card() == 0 or (self.lo, self.hi) == (other.lo, other.hi)
        return SymbolicSet.__eq__(self, other)

    __hash__ = SymbolicSet.__hash__


_REAL = BuiltinSet("REAL", lambda v: isinstance(v, float))
BUILTIN_SET_VALUES: dict[str, Any] = {
    "INTEGER": BuiltinSet("INTEGER", _is_int),
    "NATURAL": BuiltinSet("NATURAL", lambda v: _is_int(v) and v >= 0),
    "NATURAL1": BuiltinSet("NATURAL1", lambda v: _is_int(v) and v >= 1),
    "REAL": _REAL,
    "FLOAT": _REAL,
    "STRING": BuiltinSet("STRING", lambda v: type(v) is str),
    "BOOL": frozenset({True, False}),
    "NAT": Interval(0, 2147483647),
    "NAT1": Interval(1, 2147483647),
    "INT": Interval(-2147483648, 2147483647),
    "MAXINT": 2147483647,
    "MININT": -2147483648,
}

#: Which infinite built-in sets lie inside which (for ``<:`` between infinite sets).
_BUILTIN_SUBSETS = {("NATURAL1", "NATURAL"), ("NATURAL1", "INTEGER"), ("NATURAL", "INTEGER")}


class Product(SymbolicSet):
    """``A * B`` where A or B is not held element by element."""

    def __init__(self, a: Any, b: Any) -> None:
        self.a, self.b = a, b
        # each side's membership test found once (REAL's is isinstance(v, float)): a
        # projection's domain is asked at every application
        self._in_a, self._in_b = _membership(a), _membership(b)

    @property
    def name(self) -> str:  # printed when asked: most products are only asked to contain
        text = self.__dict__.get("_name")
        if text is None:
            text = self.__dict__["_name"] = f"({format_value(self.a)} * {format_value(self.b)})"
        return text

    def finiteness(self) -> Optional[bool]:
        fa, fb = finiteness(self.a), finiteness(self.b)
        if (fa and cardinality(self.a) == 0) or (fb and cardinality(self.b) == 0):
            return True
        if fa and fb:
            return True
        if fa is None or fb is None:
            return None
        return False

    def contains(self, v: Any) -> bool:
        return (isinstance(v, tuple) and len(v) == 2 and self._in_a(v[0])
                and self._in_b(v[1]))

    def card(self) -> int:
        if self.finiteness() is not True:
            return SymbolicSet.card(self)
        for side in (self.a, self.b):
            if finiteness(side) and cardinality(side) == 0:
                return 0
        return cardinality(self.a) * cardinality(self.b)

    def elements(self) -> Iterator[Any]:
        right = list(members(self.b))
        return ((x, y) for x in members(self.a) for y in right)

    def key(self) -> tuple:
        return ("product", set_key(self.a), set_key(self.b))


class PowSet(SymbolicSet):
    """``POW(S)``, ``POW1(S)``, ``FIN(S)``, ``FIN1(S)`` (FIN: the finite subsets)."""

    def __init__(self, base: Any, nonempty: bool = False, fin: bool = False) -> None:
        self.base, self.nonempty, self.fin = base, nonempty, fin
        kind = ("FIN" if fin else "POW") + ("1" if nonempty else "")
        self.name = f"{kind}({format_value(base)})"

    def finiteness(self) -> Optional[bool]:
        return finiteness(self.base)

    def contains(self, value: Any) -> bool:
        if not is_set(value):
            return False
        fv = finiteness(value)
        if self.nonempty and fv is True and cardinality(value) == 0:
            return False
        if self.fin and fv is not True:
            if fv is None:
                raise EvaluationError(f"cannot decide whether {value.name} is finite")
            return False
        return is_subset(value, self.base)

    def card(self) -> int:
        if self.finiteness() is not True:
            return SymbolicSet.card(self)
        n = cardinality(self.base)
        if n > 100_000:
            raise SetLimitError(f"card({self.name}) = 2^{n} is too large to compute")
        return 2 ** n - (1 if self.nonempty else 0)

    def elements(self) -> Iterator[Any]:
        from itertools import combinations
        items = sorted(members(self.base), key=sort_key)
        start = 1 if self.nonempty else 0
        return (make_set(c) for k in range(start, len(items) + 1)
                for c in combinations(items, k))

    def key(self) -> tuple:
        if self.fin and self.finiteness() is True:
            return ("pow", self.nonempty, False, set_key(self.base))
        return ("pow", self.nonempty, self.fin, set_key(self.base))


def as_sequence(value: Any) -> Optional[list]:
    """The items of a B sequence (a function from 1..n), or None if ``value`` is not one."""
    if not isinstance(value, frozenset):
        return None
    if not value:
        return []
    mapping = value.map if isinstance(value, FuncValue) else None
    if mapping is None:
        if not all(isinstance(p, tuple) and len(p) == 2 for p in value):
            return None
        mapping = dict(value)
        if len(mapping) != len(value):
            return None
    n = len(mapping)
    if not all(type(k) is int and 1 <= k <= n for k in mapping):
        return None
    return [mapping[i] for i in range(1, n + 1)]


def sequence(items: list) -> frozenset:
    """The B sequence of ``items``: ``{1|->a, 2|->b, …}``."""
    return FuncValue({i: x for i, x in enumerate(items, start=1)})


def set_key(v: Any) -> Any:
    """What identifies ``v`` inside a symbolic set's :meth:`SymbolicSet.key`."""
    if isinstance(v, SymbolicSet):
        return v if v.finiteness() is True else v.key()
    return v


def is_set(value: Any) -> bool:
    return isinstance(value, (frozenset, SymbolicSet))


# ------------------------------------------------------------------ set algebra on any set


def finiteness(s: Any) -> Optional[bool]:
    """True for a finite set, False for an infinite one, None where tracecheck cannot tell."""
    if isinstance(s, frozenset):
        return True
    if isinstance(s, SymbolicSet):
        return s.finiteness()
    raise EvaluationError(f"{brief(s)} is not a set")


def cardinality(s: Any) -> int:
    if isinstance(s, frozenset):
        return len(s)
    if isinstance(s, SymbolicSet):
        if s.finiteness() is not True:
            raise s.refusal() or EvaluationError(_not_finite(s, "it has no card"))
        return s.card()
    raise EvaluationError(f"{brief(s)} is not a set")


def members(s: Any) -> Iterator[Any]:
    """The elements of a finite set (an error above the size limit or for infinite sets)."""
    if isinstance(s, frozenset):
        return iter(s)
    if isinstance(s, SymbolicSet):
        return iter(s)
    raise EvaluationError(f"{brief(s)} is not a set")


def explicit(s: Any) -> frozenset:
    """A finite set as a frozenset."""
    if isinstance(s, frozenset):
        return s
    if isinstance(s, SymbolicSet):
        if s.finiteness() is not True:
            raise s.refusal() or EvaluationError(
                _not_finite(s, "tracecheck computes with finite sets here"))
        return s.materialise()
    raise EvaluationError(f"{brief(s)} is not a set")


def _not_finite(s: "SymbolicSet", what: str) -> str:
    """Why a set without a known finite size is refused: infinite, or not known to be
    finite (never called infinite where tracecheck cannot tell)."""
    if s.finiteness() is False:
        return f"the set {s.name} is infinite: {what}"
    return f"tracecheck cannot tell whether the set {s.name} is finite: {what}"


def contains(s: Any, v: Any) -> bool:
    if isinstance(s, frozenset):
        return v in s
    if isinstance(s, SymbolicSet):
        return s.contains(v)
    raise EvaluationError(f"{brief(s)} is not a set")


def _membership(s: Any) -> Callable[[Any], bool]:
    """``v -> contains(s, v)``, its dispatch done once."""
    if isinstance(s, BuiltinSet):
        return s._test
    if isinstance(s, frozenset):
        return s.__contains__
    if isinstance(s, SymbolicSet):
        return s.contains
    return lambda v: contains(s, v)


def is_subset(a: Any, b: Any) -> bool:
    """``a <: b`` for any two sets; an error where it cannot be decided exactly."""
    if isinstance(a, frozenset) and isinstance(b, frozenset):
        return a <= b
    fa = finiteness(a)
    if fa is True:
        return all(contains(b, x) for x in members(a))
    if isinstance(a, BuiltinSet) and isinstance(b, BuiltinSet):
        return a.name == b.name or (a.name, b.name) in _BUILTIN_SUBSETS
    if isinstance(b, SymbolicSet) and fa is False and finiteness(b) is True:
        return False
    if isinstance(a, SymbolicSet) and isinstance(b, SymbolicSet) and a.key() == b.key():
        return True
    raise EvaluationError(f"cannot decide whether {format_value(a)} is a subset of "
                          f"{format_value(b)}")


def set_equal(a: Any, b: Any) -> bool:
    """Equality of two sets, symbolic or explicit, exactly (or an error)."""
    if isinstance(a, frozenset) and isinstance(b, frozenset):
        return frozenset.__eq__(a, b)
    fa, fb = finiteness(a), finiteness(b)
    if fa is True and fb is True:
        if cardinality(a) != cardinality(b):
            return False
        walk, other = (a, b) if isinstance(a, frozenset) or not isinstance(b, frozenset) \
            else (b, a)
        return all(contains(other, x) for x in members(walk))
    if {fa, fb} == {True, False}:
        return False
    if fa is False and fb is False:
        if isinstance(a, BuiltinSet) and isinstance(b, BuiltinSet):
            return a.key() == b.key()
    if isinstance(a, SymbolicSet) and isinstance(b, SymbolicSet) and a.key() == b.key():
        return True  # the same set, however it is held
    raise EvaluationError(f"cannot decide whether {format_value(a)} = {format_value(b)}",
                          hint="tracecheck compares finite sets, and infinite sets it can name")


def brief(v: Any) -> str:
    """A value in B notation, cut to 60 characters (for messages)."""
    try:
        text = format_value(v)
    except EvaluationError:
        text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


# ------------------------------------------------------------------ printing

def sort_key(value: Any):
    """A total order for printing sets deterministically."""
    if isinstance(value, bool):
        return (0, value)
    if isinstance(value, (int, float)):
        return (1, value)
    if isinstance(value, Elem):
        return (2, _natural(value))
    if isinstance(value, str):
        return (3, value)
    if isinstance(value, tuple):
        return (4, tuple(sort_key(v) for v in value))
    if isinstance(value, SymbolicSet) and value.finiteness() is True:
        value = value.materialise()
    if isinstance(value, frozenset):
        return (5, len(value), tuple(sorted(sort_key(v) for v in value)))
    if isinstance(value, Record):
        return (6, tuple((n, sort_key(v)) for n, v in value.fields))
    return (7, repr(value))


def _natural(name: str):
    m = re.match(r"(.*?)(\d+)$", name)
    return (m.group(1), int(m.group(2)), name) if m else (name, -1, name)


_PRINT_LIMIT = 10_000  # a finite symbolic set up to this size prints element by element


def format_real(x: float) -> str:
    if math.isnan(x) or math.isinf(x):
        raise EvaluationError(f"the real {x} has no B literal")
    text = repr(float(x))
    if "e" in text:
        mant, exp = text.split("e")
        if "." not in mant:
            mant += ".0"
        text = f"{mant}E{int(exp)}"
    return text


#: a string printed as a B literal that reads back as itself (B's escapes: \\ \" \n \t \r)
_STRING_ESCAPES = str.maketrans({"\\": "\\\\", '"': '\\"', "\n": "\\n", "\t": "\\t",
                                 "\r": "\\r"})


def _countable(value: SymbolicSet) -> float:
    """A finite set's card, infinite where it is too large to count (it is then named)."""
    try:
        return value.card()
    except SetLimitError:
        return math.inf


def format_value(value: Any, *, ascii: bool = False) -> str:
    """Write ``value`` in ProB's notation: ``{(EgoVehicle↦150.36),(Vehicles2↦21.9)}``.

    Args:
        value: a B value.
        ascii: ``|->`` instead of ``↦``.

    Returns:
        Its text, as ProB prints it (and :func:`~tracecheck.b.notation.parse_literal` reads).

    >>> format_value(frozenset({1, 2}))
    '{1,2}'
    """
    maplet = "|->" if ascii else "↦"
    if value is True:
        return "TRUE"
    if value is False:
        return "FALSE"
    if isinstance(value, int):
        return int_text(value)
    if isinstance(value, float):
        return format_real(value)
    if isinstance(value, Elem):
        return str(value)
    if isinstance(value, str):
        return '"' + value.translate(_STRING_ESCAPES) + '"'
    if isinstance(value, tuple):
        # ProB's way: maplets associate to the left, so (a↦b)↦c prints as (a↦b↦c)
        parts, left = [format_value(value[1], ascii=ascii)], value[0]
        while isinstance(left, tuple):
            parts.append(format_value(left[1], ascii=ascii))
            left = left[0]
        parts.append(format_value(left, ascii=ascii))
        return "(" + maplet.join(reversed(parts)) + ")"
    if isinstance(value, Record):  # as ProB prints it: rec(a:1,b:TRUE)
        return "rec(" + ",".join(f"{name_text(n)}:{format_value(v, ascii=ascii)}"
                                 for n, v in value.fields) + ")"
    if isinstance(value, SymbolicSet):
        if value.finiteness() is True and _countable(value) <= _PRINT_LIMIT:
            return format_value(value.materialise(), ascii=ascii)
        return value.name
    if isinstance(value, frozenset):
        if not value:
            return "{}" if ascii else "∅"
        items = sorted(value, key=sort_key)
        return "{" + ",".join(format_value(v, ascii=ascii) for v in items) + "}"
    raise EvaluationError(f"no B notation for the value {value!r}")
