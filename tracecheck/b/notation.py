"""B literals in ProB's output notation read into values, and values to and from JSON.

A literal is what ProB prints and what SimB and ProB2 traces hold; the text of a value is
written by :func:`tracecheck.b.values.format_value`, and reading it back gives the value:

>>> from tracecheck.b.values import format_value
>>> value = parse_literal("{(Vehicles2|->21.9),(EgoVehicle|->150.36)}")
>>> format_value(value)
'{(EgoVehicle↦150.36),(Vehicles2↦21.9)}'
>>> parse_literal(format_value(value)) == value
True
>>> from_json({"EgoVehicle": 1.5}) == parse_literal("{(EgoVehicle↦1.5)}")
True
>>> to_json(value), to_json(2)
('{(EgoVehicle↦150.36),(Vehicles2↦21.9)}', 2)
"""

from __future__ import annotations

import math
import re
from typing import Any, Optional

from ..errors import BSyntaxError, EvaluationError
from ..limits import read_int
from .values import Elem, FuncValue, Record, format_value, make_set, sequence

__all__ = ["parse_literal", "element", "from_json", "to_json", "MAX_LITERAL_DEPTH"]


# ------------------------------------------------------------------ literals

_NUM = r"-?\d+(?:\.\d+(?:[eE][+-]?\d+)?)?"
_IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
_FUNC_LITERAL = re.compile(
    r"\{\((" + _IDENT + r")(?:↦|\|->)(" + _NUM + r")\)((?:,\((?:" + _IDENT
    + r")(?:↦|\|->)(?:" + _NUM + r")\))*)\}\Z"
)
_FUNC_ITEM = re.compile(r"\((" + _IDENT + r")(?:↦|\|->)(" + _NUM + r")\)")
_NUMBER = re.compile(_NUM + r"\Z")
_NUMBER_AT = re.compile(_NUM)  # a number where the reader is
_IDENT_AT = re.compile(_IDENT)
_FIELD_AT = re.compile(r"([^\W\d]\w*|`(?:[^`\\]|\\.)+`)\s*:")
_STRING_AT = re.compile(r'"((?:\\.|[^"\\])*)"')
_ESCAPE = re.compile(r"\\(.)")
#: the escapes of a B string, as ProB reads them; any other backslash is kept ("\a" is
#: backslash and a, ProB's own printing of it)
ESCAPES = {'"': '"', "\\": "\\", "'": "'", "n": "\n", "t": "\t", "r": "\r"}


def unescape(body: str) -> str:
    """The text of a B string literal's body (between its quotes)."""
    return _ESCAPE.sub(lambda m: ESCAPES.get(m.group(1), m.group(0)), body)


def _number(text: str):
    return float(text) if ("." in text or "e" in text or "E" in text) else read_int(text)


#: the elements read so far, one object per name (states of a trace share them: a run holds,
#: pickles and sends each once); at most ELEMENTS names, past that new ones are not kept
_ELEMENTS: dict[str, Elem] = {}
ELEMENTS = 10_000


def element(name: str) -> Elem:
    """The element ``name`` (the one object of that name while there are few)."""
    found = _ELEMENTS.get(name)
    if found is None:
        found = Elem(name)
        if len(_ELEMENTS) < ELEMENTS:
            _ELEMENTS[name] = found
    return found


def parse_literal(text: str, *, file: Optional[str] = None, where: str = "") -> Any:
    """Read a B value written in ProB's output notation.

    Numbers, ``TRUE``/``FALSE``, strings, set elements, pairs ``(a↦b)``, sets and
    functions: ``{(EgoVehicle↦150.36),(Vehicles2↦21.9)}``. The common shapes are read by a
    regular expression; the rest by a small recursive-descent reader.

    Args:
        text: the literal.
        file: where it comes from, for error messages.
        where: what it is (a variable's value, say), for error messages.

    Returns:
        The B value (:mod:`tracecheck.b.values`).

    >>> parse_literal("{(a↦1.5),(b↦2.0)}") == {("a", 1.5), ("b", 2.0)}
    True
    """
    text = text.strip()
    try:
        if _NUMBER.match(text):
            return _number(text)
        m = _FUNC_LITERAL.match(text)
        if m:
            mapping = {element(k): _number(v) for k, v in _FUNC_ITEM.findall(text)}
            if len(mapping) == text.count("("):
                return FuncValue(mapping)
    except ValueError as exc:  # an integer too long to read
        raise _LiteralReader(text, file, where).fail(str(exc)) from None
    return _LiteralReader(text, file, where).read()


#: How deeply a B literal may nest (sets in sets, pairs in pairs).
MAX_LITERAL_DEPTH = 1000


class _LiteralReader:
    def __init__(self, text: str, file: Optional[str], where: str) -> None:
        self.text, self.i, self.file, self.where = text, 0, file, where
        self.depth = 0

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
        value = self.maplets()
        self.skip_ws()
        if self.i != len(self.text):
            raise self.fail(f"unexpected {self.text[self.i]!r} after the value")
        return value

    def value(self) -> Any:
        self.depth += 1
        if self.depth > MAX_LITERAL_DEPTH:
            raise self.fail(f"the value nests more than {MAX_LITERAL_DEPTH} levels deep")
        try:
            return self._value()
        finally:
            self.depth -= 1

    def _value(self) -> Any:
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
        if c == "[":
            return self.sequence()
        if c == '"':
            return self.string()
        m = (c.isdigit() or c == "-") and _NUMBER_AT.match(self.text, self.i)
        if m:
            try:
                value = _number(m.group())
            except ValueError as exc:
                raise self.fail(str(exc)) from None
            self.i = m.end()
            return value
        m = _IDENT_AT.match(self.text, self.i)
        if m:
            self.i = m.end()
            word = m.group()
            if word == "TRUE":
                return True
            if word == "FALSE":
                return False
            if word == "rec" and self.peek("("):
                return self.record()
            return element(word)
        raise self.fail(f"unexpected {c!r}")

    def maplets(self) -> Any:
        """``a↦b↦c`` is ``(a↦b)↦c``, as ProB prints nested pairs."""
        value = self.value()
        while True:
            for sep in ("↦", "|->"):
                if self.peek(sep):
                    self.i += len(sep)
                    value = (value, self.value())
                    break
            else:
                return value

    def items(self, open_: str, close: str) -> list:
        """The comma-separated values between ``open_`` and ``close``."""
        self.expect(open_)
        items = []
        if not self.peek(close):
            items.append(self.maplets())
            while self.peek(","):
                self.i += 1
                items.append(self.maplets())
        self.expect(close)
        return items

    def set_(self) -> frozenset:
        return make_set(self.items("{", "}"))

    def sequence(self) -> frozenset:
        """``[a, b]``: ProB's notation for the sequence ``{1↦a, 2↦b}``."""
        return sequence(self.items("[", "]"))

    def record(self) -> Record:
        """``rec(a:1,b:TRUE)``, as ProB prints a record (the fields in any order)."""
        self.expect("(")
        fields: dict[str, Any] = {}
        while True:
            self.skip_ws()
            m = _FIELD_AT.match(self.text, self.i)
            if m is None:
                raise self.fail("expected a field name and ':' in a record")
            name = m.group(1)
            if name.startswith("`"):
                name = re.sub(r"\\(.)", r"\1", name[1:-1])
            if name in fields:
                raise self.fail(f"the field {name} appears twice in a record")
            self.i = m.end()
            fields[name] = self.maplets()
            if not self.peek(","):
                break
            self.i += 1
        self.expect(")")
        return Record(fields.items())

    def pair(self) -> Any:
        self.expect("(")
        value = self.maplets()
        while self.peek(","):
            self.i += 1
            value = (value, self.maplets())
        self.expect(")")
        return value

    def string(self) -> str:
        m = _STRING_AT.match(self.text, self.i)
        if not m:
            raise self.fail("unterminated string")
        self.i = m.end()
        return unescape(m.group(1))


# ------------------------------------------------------------------ JSON


def from_json(value: Any, *, file: Optional[str] = None, where: str = "") -> Any:
    """A state value given in JSON: a B literal as a string, or a JSON number, boolean,
    list (a set) or object (a function from element names)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, float) and not math.isfinite(value):
        raise EvaluationError(f"{value} is not a B real{f' ({where})' if where else ''}",
                              file=file, hint="B reals are finite numbers")
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
