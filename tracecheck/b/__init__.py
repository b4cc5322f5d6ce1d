"""The B engine: parse classical B machines and evaluate them on concrete states.

>>> from tracecheck.b import parse_formula, evaluate
>>> evaluate(parse_formula("card({x | x : 1..10 & x mod 3 = 0})"), {})
3

The names below are imported on first use: evaluating one formula does not load numpy (the
batch path) or anything else it does not need.
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "compile_formula": "evaluate", "evaluate": "evaluate",
    "Machine": "machine", "Operation": "machine", "load_machine": "machine",
    "load_machine_text": "machine",
    "parse_formula": "parser", "parse_substitution": "parser",
    "to_b": "printer", "read_state_file": "state",
    "Elem": "values", "FuncValue": "values", "format_value": "values",
    "parse_literal": "values",
    "BatchFormula": "vector", "Columns": "vector", "evaluate_batch": "vector",
}

__all__ = [
    "parse_formula", "parse_substitution", "evaluate", "compile_formula", "load_machine",
    "load_machine_text", "Machine", "Operation", "to_b", "parse_literal", "format_value",
    "Elem", "FuncValue", "Columns", "BatchFormula", "evaluate_batch", "read_state_file",
]


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
