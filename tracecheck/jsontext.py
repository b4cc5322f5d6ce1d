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

import json
import math
from typing import Any, Optional

from .limits import long_integers

__all__ = ["finite", "json_text", "script_json", "nonfinite_name"]


def nonfinite_name(x: float) -> str:
    """``+inf``, ``-inf`` or ``nan``."""
    return "nan" if math.isnan(x) else ("+inf" if x > 0 else "-inf")


def _walk(value: Any) -> tuple[Any, Optional[str]]:
    """(the value with every non-finite float as None, a note saying what was replaced)."""
    if isinstance(value, float):
        return (value, None) if math.isfinite(value) else (None, nonfinite_name(value))
    if isinstance(value, dict):
        return finite(value), None
    if isinstance(value, (list, tuple)):
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
    for key, value in data.items():
        out[key], note = _walk(value)
        if note and f"{key}_note" not in data:
            out[f"{key}_note"] = note
    return out


def json_text(data: Any, **options) -> str:
    """``data`` as strict JSON text (``options`` as for ``json.dumps``, e.g. ``indent``);
    integers of up to :data:`tracecheck.limits.MAX_DIGITS` digits too."""
    with long_integers():
        return json.dumps(finite(data), allow_nan=False, **options)


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
