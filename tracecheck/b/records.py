"""Records as ProB has them: ``rec(a: 1, b: TRUE)``, the set ``struct(a: INTEGER, b: BOOL)``
and the field ``r'a``; and the elements ``S1``, ``S2``, … of a deferred set named in formulas.

A record value is a :class:`~tracecheck.b.values.Record` (fields sorted by name, so field order
never matters, and printed ``rec(a:1,b:TRUE)`` as ProB prints it); a ``struct`` is a
:class:`RecordSet`, a symbolic set that is finite when every field's set is, and then counts,
enumerates and compares like its explicit form. :class:`Records` holds the scalar compiler's
rules for the three nodes (a base class of :class:`~tracecheck.b.evaluation.Compiler`); the batch
path has none, so formulas with records run row by row on the scalar path.
"""

from __future__ import annotations

import re
from itertools import product
from typing import Any, Iterator, Optional

from ..errors import BTypeError, EvaluationError
from . import ast
from .names import name_text
from .values import (Elem, Record, SymbolicSet, cardinality, contains, finiteness, format_value,
                     is_set, members, set_key)

__all__ = ["RecordSet", "Records", "set_element", "element_set"]


class RecordSet(SymbolicSet):
    """``struct(a: A, b: B)``: the records with exactly the fields a, b, valued in A and B."""

    def __init__(self, fields: list[tuple[str, Any]]) -> None:
        self.fields = tuple(sorted(fields, key=lambda f: f[0]))
        self.name = "struct(" + ",".join(f"{name_text(n)}:{format_value(s)}"
                                         for n, s in self.fields) + ")"

    def finiteness(self) -> Optional[bool]:
        found = [finiteness(s) for _, s in self.fields]
        if any(f is True and cardinality(s) == 0 for f, (_, s) in zip(found, self.fields)):
            return True
        if all(f is True for f in found):
            return True
        return None if None in found else False

    def contains(self, value: Any) -> bool:
        if not isinstance(value, Record) or value.names() != tuple(n for n, _ in self.fields):
            return False
        return all(contains(s, v) for (_, s), (_, v) in zip(self.fields, value.fields))

    def card(self) -> int:
        if self.finiteness() is not True:
            return SymbolicSet.card(self)
        n = 1
        for _, s in self.fields:
            n *= cardinality(s)
        return n

    def elements(self) -> Iterator[Any]:
        names = [n for n, _ in self.fields]
        sets = [list(members(s)) for _, s in self.fields]
        return (Record(zip(names, values)) for values in product(*sets))

    def key(self) -> tuple:
        return ("struct", tuple((n, set_key(s)) for n, s in self.fields))


_ELEMENT = re.compile(r"(.+?)([0-9]+)")


def element_set(name: str) -> Optional[str]:
    """The set whose element ``name`` could be, as ProB names a deferred set's elements
    (``S3``: ``S``), else None: its meaning depends on that set's value too."""
    m = _ELEMENT.fullmatch(name)
    return m.group(1) if m else None


def set_element(name: str, env: dict) -> Optional[Elem]:
    """``S3`` where S is a set in ``env`` that holds the element S3 (ProB's name for the third
    element of a deferred set S); None otherwise."""
    m = _ELEMENT.fullmatch(name)
    if m is None:
        return None
    elems = env.get(m.group(1))
    if isinstance(elems, frozenset) and Elem(name) in elems:
        return Elem(name)
    return None


def element_hint(name: str, env: dict) -> Optional[str]:
    """Why ``S7`` has no value where S is a set of fewer (or differently named) elements."""
    m = _ELEMENT.fullmatch(name)
    elems = env.get(m.group(1)) if m else None
    if not isinstance(elems, frozenset) or not elems or not all(
            isinstance(e, Elem) for e in elems):
        return None
    return (f"the set {m.group(1)} has {len(elems)} element(s) here: "
            f"{format_value(elems, ascii=True)}")


class Records:
    """The scalar compiler's rules for records (uses ``compile``, ``error`` and ``text``)."""

    def c_Record(self, node: ast.Record):
        names = [n for n, _ in node.fields]
        values = [self.compile(v) for _, v in node.fields]
        return lambda env: Record(zip(names, [v(env) for v in values]))

    def c_Struct(self, node: ast.Struct):
        names = [n for n, _ in node.fields]
        sets = [(self.compile(v), v) for _, v in node.fields]

        def struct(env) -> RecordSet:
            fields = []
            for name, (fn, sub) in zip(names, sets):
                value = fn(env)
                if not is_set(value):
                    raise self.error(BTypeError, sub, f"the field {name} of a struct must be "
                                     f"a set, not `{self.text(sub)}`")
                fields.append((name, value))
            return RecordSet(fields)
        return struct

    def c_Field(self, node: ast.Field):
        record, name = self.compile(node.record), node.name

        def field(env) -> Any:
            value = record(env)
            if not isinstance(value, Record):
                raise self.error(BTypeError, node, f"`{self.text(node.record)}` is not a record")
            try:
                return value.get(name)
            except KeyError:
                raise self.error(EvaluationError, node, f"the record has no field {name} in "
                                 f"`{self.text(node)}`") from None
        return field
