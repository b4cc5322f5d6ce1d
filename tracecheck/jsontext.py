"""Strict JSON for every report tracecheck prints or writes: no ``NaN``, no ``Infinity``.

Python's ``json`` writes them by default, and most JSON readers (``jq``, JavaScript's
``JSON.parse``, Go, Rust's serde) refuse the result. The convention (docs/safety.md, "Output
formats are inert"): a number that is not finite is written as ``null``, and the object
holding it gets a field ``KEY_note`` saying what it was (``+inf``, ``-inf``, ``nan``) — or,
where the code that computed it knows, why (the statistics say which episodes gave an
infinite STL robustness). A note already there is kept.

>>> json_text({"robustness": float("inf")})
'{"robustness": null, "robustness_note": "+inf"}'
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any, Callable, Iterable, Optional

import orjson

from .limits import long_integers

__all__ = ["finite", "json_text", "script_json", "nonfinite_name", "plain", "Rows",
           "write_json"]


def nonfinite_name(x: float) -> str:
    """``+inf``, ``-inf`` or ``nan``."""
    return "nan" if math.isnan(x) else ("+inf" if x > 0 else "-inf")


def plain(value: Any) -> Any:
    """``value`` with every dataclass instance in it as a dict of its fields, as
    ``dataclasses.asdict`` gives it but without copying what needs no copy (lists, dicts and
    tuples are new; other values the same objects) — several times faster on large reports."""
    kind = type(value)
    if kind in (str, int, float, bool) or value is None:
        return value
    if kind is list or kind is tuple:
        return [plain(v) for v in value]
    if kind is dict:
        return {k: plain(v) for k, v in value.items()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    return value


#: values that are JSON as they are
_AS_IS = frozenset({str, int, bool, type(None)})


def _walk(value: Any) -> tuple[Any, Optional[str]]:
    """(the value with every non-finite float as None, a note saying what was replaced)."""
    kind = type(value)
    if kind in _AS_IS:
        return value, None
    if isinstance(value, float):
        return (value, None) if math.isfinite(value) else (None, nonfinite_name(value))
    if isinstance(value, dict):
        return finite(value), None
    if isinstance(value, (list, tuple)):
        if kind is list and all(type(v) in _AS_IS for v in value):
            return value, None  # names, step numbers: nothing to replace (the common case)
        items, notes = [], []
        for i, v in enumerate(value):
            item, note = _walk(v)
            items.append(item)
            if note:
                notes.append(f"[{i}] {note}")
        return items, "; ".join(notes) or None
    return value, None


def finite(data: Any) -> Any:
    """``data`` with every float that is not finite replaced by None and noted beside it
    (see the module docstring); other values as they are."""
    if not isinstance(data, dict):
        return _walk(data)[0]
    out = {}
    as_is = _AS_IS
    for key, value in data.items():
        kind = type(value)
        if kind in as_is or kind is float and value - value == 0.0:  # finite: as it is
            out[key] = value
            continue
        out[key], note = _walk(value)
        if note and f"{key}_note" not in data:
            out[f"{key}_note"] = note
    return out


def json_text(data: Any, *, indent: Optional[int] = None, ensure_ascii: bool = False,
              separators: Optional[tuple[str, str]] = None) -> str:
    """``data`` as strict JSON text, indented by ``indent`` (2, or None for one line; one
    line with ``separators=(",", ":")`` is compact); integers of up to
    :data:`tracecheck.limits.MAX_DIGITS` digits too. Written by orjson (a large report in a
    fraction of the time ``json`` takes); ``json`` only where orjson cannot: an integer
    beyond 64 bits, a key that is not a string, or ``ensure_ascii``."""
    data = finite(data)
    if not ensure_ascii and indent in (None, 2) and (indent or separators == (",", ":")):
        try:
            return orjson.dumps(data, option=orjson.OPT_INDENT_2 if indent else 0).decode()
        except TypeError:  # orjson.JSONEncodeError: a long integer, a key not a string
            pass
    with long_integers():
        return json.dumps(data, allow_nan=False, indent=indent, ensure_ascii=ensure_ascii,
                          separators=separators)


class Rows:
    """A list of objects (dicts) that :func:`write_json` writes a few hundred at a time, each
    made by ``make`` from one of ``items`` only then: a campaign's 10^5 episodes never stand
    in memory as JSON objects, or as one text, all at once."""

    __slots__ = ("items", "make")

    def __init__(self, items: Iterable, make: Callable[[Any], Any] = lambda item: item):
        self.items, self.make = items, make

    def __iter__(self):
        return map(self.make, self.items)


#: items of a :class:`Rows` made and written together
_ROWS_AT_ONCE = 500


def write_json(data: dict, out) -> None:
    """``data`` (a dict) written to the text stream ``out`` exactly as
    ``json_text(data, indent=2)`` writes it, with each value that is a :class:`Rows` as a list
    written a part at a time.

    >>> import io
    >>> out = io.StringIO()
    >>> write_json({"n": 2, "items": Rows([1.5, float("inf")], lambda x: {"x": x})}, out)
    >>> out.getvalue() == json_text({"n": 2, "items": [{"x": 1.5}, {"x": float("inf")}]},
    ...                             indent=2)
    True
    """
    rest = finite({k: v for k, v in data.items() if type(v) is not Rows})
    pairs: list = []
    for key, value in data.items():
        if type(value) is Rows:
            pairs.append((key, value))
            continue
        pairs.append((key, rest[key]))
        note = f"{key}_note"
        if note in rest and note not in data:
            pairs.append((note, rest[note]))
    if not pairs:
        out.write("{}")
        return
    out.write("{")
    for n, (key, value) in enumerate(pairs):
        out.write(",\n" if n else "\n")
        if type(value) is not Rows:
            out.write(json_text({key: value}, indent=2)[2:-2])  # '{\n  "key": …\n}'
            continue
        out.write(json_text({key: []}, indent=2)[2:-4])  # '  "key": '
        _write_rows(value, out)
    out.write("\n}")


def _write_rows(rows: Rows, out) -> None:
    """The items of ``rows`` as a list at the indentation of a value of the top object."""
    items = iter(rows)
    written = False
    while True:
        part = [item for _, item in zip(range(_ROWS_AT_ONCE), items)]
        if not part:
            break
        text = json_text(part, indent=2)  # '[\n  item,\n  item\n]'
        out.write((",\n" if written else "[\n") + "  " + text[2:-2].replace("\n", "\n  "))
        written = True
    out.write("\n  ]" if written else "[]")


#: what could end, or comment out, an HTML ``<script>`` element holding JSON (``</script>``,
#: ``<!--``), or break it as JavaScript (the line separators U+2028 and U+2029): each only
#: ever appears inside a JSON string, where its ``\\u`` escape means the same character
_SCRIPT = str.maketrans({"<": "\\u003c", ">": "\\u003e", "&": "\\u0026",
                         "\u2028": "\\u2028", "\u2029": "\\u2029"})


def script_json(data: Any) -> str:
    """``data`` as strict, compact JSON to put inside an HTML ``<script>``: no string in it
    can end the element or comment it out, whatever it holds (``"</script>"``,
    ``"<!--<script>"``).

    >>> script_json({"s": "</script><!--"})
    '{"s":"\\\\u003c/script\\\\u003e\\\\u003c!--"}'
    """
    return json_text(data, separators=(",", ":")).translate(_SCRIPT)
