"""B values in Python, and B literals in ProB's output notation.

Representation: integers ``int``, reals ``float``, booleans ``bool``, strings ``str``,
elements of deferred and enumerated sets :class:`Elem`, pairs ``tuple`` of two, sets
``frozenset`` (a function literal is a :class:`FuncValue`, a frozenset of pairs that also
keeps a dict for fast application), and infinite or lazily enumerated sets
:class:`SymbolicSet`.
"""

from __future__ import annotations

import math
import re
from typing import Any, Callable, Iterator, Optional

from ..errors import BSyntaxError, EvaluationError

__all__ = [
    "Elem", "FuncValue", "SymbolicSet", "BuiltinSet", "Interval", "PowSet", "FunctionSpace",
    "parse_literal", "format_value", "from_json", "to_json", "is_set", "BUILTIN_SET_VALUES",
    "sort_key",
]


class Elem(str):
    """An element of a deferred or enumerated set (``EgoVehicle``, ``Heads``).

    A ``str`` subclass so that hashing and dict lookups stay as fast as for strings; it is
    a different type from B strings, which are plain ``str``.
    """

    __slots__ = ()

    def __repr__(self) -> str:
        return f"Elem({str(self)!r})"


class FuncValue(frozenset):
    """A set of pairs whose first components are distinct: a function, applied in O(1)."""

    __slots__ = ("map",)

    def __new__(cls, mapping: dict):
        obj = super().__new__(cls, mapping.items())
        obj.map = mapping
        return obj

    def __reduce__(self):
        return (FuncValue, (dict(self.map),))


class SymbolicSet:
    """A set that is not held element by element (INTEGER, REAL, POW(S), S --> T, a..b)."""

    name = "set"
    finite = False

    def contains(self, value: Any) -> bool:
        raise NotImplementedError

    def __iter__(self) -> Iterator[Any]:
        raise EvaluationError(f"cannot enumerate the infinite set {self.name}",
                              hint="restrict the variable with a finite set, e.g. x : 1..10")

    def __contains__(self, value: Any) -> bool:
        return self.contains(value)

    def __repr__(self) -> str:
        return self.name


class BuiltinSet(SymbolicSet):
    def __init__(self, name: str, test: Callable[[Any], bool]) -> None:
        self.name = name
        self._test = test

    def contains(self, value: Any) -> bool:
        return self._test(value)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, BuiltinSet) and other.name == self.name

    def __hash__(self) -> int:
        return hash(self.name)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)




class Interval(SymbolicSet):
    """``a..b``, enumerated lazily."""

    finite = True

    def __init__(self, lo: int, hi: int) -> None:
        self.lo, self.hi = lo, hi
        self.name = f"{lo}..{hi}"

    def contains(self, value: Any) -> bool:
        return _is_int(value) and self.lo <= value <= self.hi

    def __iter__(self) -> Iterator[int]:
        return iter(range(self.lo, self.hi + 1))

    def __len__(self) -> int:
        return max(0, self.hi - self.lo + 1)

    def materialise(self) -> frozenset:
        if len(self) > 1_000_000:
            raise EvaluationError(f"the interval {self.name} is too large to build as a set")
        return frozenset(range(self.lo, self.hi + 1))


BUILTIN_SET_VALUES: dict[str, Any] = {
    "INTEGER": BuiltinSet("INTEGER", _is_int),
    "NATURAL": BuiltinSet("NATURAL", lambda v: _is_int(v) and v >= 0),
    "NATURAL1": BuiltinSet("NATURAL1", lambda v: _is_int(v) and v >= 1),
    "REAL": BuiltinSet("REAL", lambda v: isinstance(v, float)),
    "FLOAT": BuiltinSet("FLOAT", lambda v: isinstance(v, float)),
    "STRING": BuiltinSet("STRING", lambda v: type(v) is str),
    "BOOL": frozenset({True, False}),
    "NAT": Interval(0, 2147483647),
    "NAT1": Interval(1, 2147483647),
    "INT": Interval(-2147483648, 2147483647),
    "MAXINT": 2147483647,
    "MININT": -2147483648,
}


class PowSet(SymbolicSet):
    """``POW(S)`` or ``POW1(S)``: membership only."""

    def __init__(self, base: Any, nonempty: bool = False) -> None:
        self.base, self.nonempty = base, nonempty
        self.name = f"{'POW1' if nonempty else 'POW'}({format_value(base)})"

    def contains(self, value: Any) -> bool:
        if not is_set(value) or isinstance(value, SymbolicSet):
            return False
        if self.nonempty and not value:
            return False
        return all(item in self.base for item in value)


class FunctionSpace(SymbolicSet):
    """``S --> T``, ``S +-> T``, ``S <-> T`` and the injective/surjective variants."""

    def __init__(self, op: str, dom: Any, ran: Any) -> None:
        self.op, self.dom, self.ran = op, dom, ran
        self.name = f"({format_value(dom)} {op} {format_value(ran)})"

    def contains(self, value: Any) -> bool:
        if not is_set(value) or isinstance(value, SymbolicSet):
            return False
        pairs = list(value)
        if not all(isinstance(p, tuple) and len(p) == 2 for p in pairs):
            return False
        if not all(p[0] in self.dom and p[1] in self.ran for p in pairs):
            return False
        if self.op == "<->":
            return True
        firsts = [p[0] for p in pairs]
        if len(set(firsts)) != len(firsts):
            return False
        total = self.op in ("-->", ">->", "-->>", ">->>")
        if total and not _covers(set(firsts), self.dom):
            return False
        seconds = [p[1] for p in pairs]
        if self.op in (">->", ">+>", ">->>") and len(set(seconds)) != len(seconds):
            return False
        if self.op in ("-->>", "+->>", ">->>") and not _covers(set(seconds), self.ran):
            return False
        return True


def _covers(values: set, space: Any) -> bool:
    if isinstance(space, SymbolicSet) and not space.finite:
        return False
    return all(item in values for item in space)


def is_set(value: Any) -> bool:
    return isinstance(value, (frozenset, SymbolicSet))


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
    if isinstance(value, frozenset):
        return (5, len(value), tuple(sorted(sort_key(v) for v in value)))
    return (6, repr(value))


def _natural(name: str):
    m = re.match(r"(.*?)(\d+)$", name)
    return (m.group(1), int(m.group(2)), name) if m else (name, -1, name)


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


def format_value(value: Any, *, ascii: bool = False) -> str:
    """Write ``value`` in ProB's notation: ``{(EgoVehicle↦150.36),(Vehicles2↦21.9)}``."""
    maplet = "|->" if ascii else "↦"
    if value is True:
        return "TRUE"
    if value is False:
        return "FALSE"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return format_real(value)
    if isinstance(value, Elem):
        return str(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, tuple):
        return f"({format_value(value[0], ascii=ascii)}{maplet}{format_value(value[1], ascii=ascii)})"
    if isinstance(value, SymbolicSet):
        return value.name
    if isinstance(value, frozenset):
        if not value:
            return "{}" if ascii else "∅"
        items = sorted(value, key=sort_key)
        return "{" + ",".join(format_value(v, ascii=ascii) for v in items) + "}"
    raise EvaluationError(f"no B notation for the value {value!r}")


# ------------------------------------------------------------------ literals

_NUM = r"-?\d+(?:\.\d+(?:[eE][+-]?\d+)?)?"
_FUNC_LITERAL = re.compile(
    r"\{\((\w+)(?:↦|\|->)(" + _NUM + r")\)((?:,\((?:\w+)(?:↦|\|->)(?:" + _NUM + r")\))*)\}\Z"
)
_FUNC_ITEM = re.compile(r"\((\w+)(?:↦|\|->)(" + _NUM + r")\)")
_NUMBER = re.compile(_NUM + r"\Z")


def _number(text: str):
    return float(text) if ("." in text or "e" in text or "E" in text) else int(text)


def parse_literal(text: str, *, file: Optional[str] = None, where: str = "") -> Any:
    """Read a B value written in ProB's output notation.

    Numbers, ``TRUE``/``FALSE``, strings, set elements, pairs ``(a↦b)``, sets and
    functions: ``{(EgoVehicle↦150.36),(Vehicles2↦21.9)}``. The common shapes are read by a
    regular expression; the rest by a small recursive-descent reader.

    >>> parse_literal("{(a↦1.5),(b↦2.0)}") == {("a", 1.5), ("b", 2.0)}
    True
    """
    text = text.strip()
    if _NUMBER.match(text):
        return _number(text)
    m = _FUNC_LITERAL.match(text)
    if m:
        mapping = {Elem(k): _number(v) for k, v in _FUNC_ITEM.findall(text)}
        if len(mapping) == text.count("(") :
            return FuncValue(mapping)
    return _LiteralReader(text, file, where).read()


class _LiteralReader:
    def __init__(self, text: str, file: Optional[str], where: str) -> None:
        self.text, self.i, self.file, self.where = text, 0, file, where

    def fail(self, message: str) -> BSyntaxError:
        where = f" ({self.where})" if self.where else ""
        return BSyntaxError(f"{message} in the B literal{where}", file=self.file, line=1,
                            column=self.i + 1, source=self.text)

    def skip_ws(self) -> None:
        while self.i < len(self.text) and self.text[self.i].isspace():
            self.i += 1

    def peek(self, s: str) -> bool:
        self.skip_ws()
        return self.text.startswith(s, self.i)

    def expect(self, s: str) -> None:
        if not self.peek(s):
            found = self.text[self.i] if self.i < len(self.text) else "end of text"
            raise self.fail(f"expected {s!r} but found {found!r}")
        self.i += len(s)

    def read(self) -> Any:
        value = self.value()
        self.skip_ws()
        if self.i != len(self.text):
            raise self.fail(f"unexpected {self.text[self.i]!r} after the value")
        return value

    def value(self) -> Any:
        self.skip_ws()
        if self.i >= len(self.text):
            raise self.fail("expected a value but the text ended")
        c = self.text[self.i]
        if c == "{":
            return self.set_()
        if c == "∅":
            self.i += 1
            return frozenset()
        if c == "(":
            return self.pair()
        if c == '"':
            return self.string()
        m = re.compile(_NUM).match(self.text, self.i)
        if m and (c.isdigit() or c == "-"):
            self.i = m.end()
            return _number(m.group())
        m = re.compile(r"[A-Za-z_][A-Za-z0-9_]*").match(self.text, self.i)
        if m:
            self.i = m.end()
            word = m.group()
            if word == "TRUE":
                return True
            if word == "FALSE":
                return False
            return Elem(word)
        raise self.fail(f"unexpected {c!r}")

    def set_(self) -> frozenset:
        self.expect("{")
        items = []
        if not self.peek("}"):
            items.append(self.value())
            while self.peek(","):
                self.i += 1
                items.append(self.value())
        self.expect("}")
        if items and all(isinstance(x, tuple) for x in items):
            mapping = dict(items)
            if len(mapping) == len(items):
                return FuncValue(mapping)
        return frozenset(items)

    def pair(self) -> Any:
        self.expect("(")
        left = self.value()
        for sep in ("↦", "|->", ","):
            if self.peek(sep):
                self.i += len(sep)
                right = self.value()
                self.expect(")")
                return (left, right)
        self.expect(")")
        return left

    def string(self) -> str:
        m = re.compile(r'"((?:\\.|[^"\\])*)"').match(self.text, self.i)
        if not m:
            raise self.fail("unterminated string")
        self.i = m.end()
        return re.sub(r"\\(.)", r"\1", m.group(1))


# ------------------------------------------------------------------ JSON


def from_json(value: Any, *, file: Optional[str] = None, where: str = "") -> Any:
    """A state value given in JSON: a B literal as a string, or a JSON number, boolean,
    list (a set) or object (a function from element names)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, str):
        return parse_literal(value, file=file, where=where)
    if isinstance(value, list):
        return frozenset(from_json(v, file=file, where=where) for v in value)
    if isinstance(value, dict):
        return FuncValue({Elem(k): from_json(v, file=file, where=where) for k, v in value.items()})
    raise EvaluationError(f"cannot read {value!r} as a B value{f' ({where})' if where else ''}",
                          file=file)


def to_json(value: Any) -> Any:
    """The JSON form of a value: numbers and booleans as such, everything else as a literal."""
    if isinstance(value, (bool, int, float)) and not (
        isinstance(value, float) and (math.isnan(value) or math.isinf(value))
    ):
        return value
    return format_value(value)
