"""The B engine: parse classical B machines and evaluate them on concrete states.

>>> from tracecheck.b import parse_formula, evaluate
>>> evaluate(parse_formula("card({x | x : 1..10 & x mod 3 = 0})"), {})
3

The names below are imported on first use: evaluating one formula does not load numpy (the
batch path) or anything else it does not need.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:  # what editors and type checkers see; at run time, _WHERE
    from .columns import Columns
    from .evaluation import compile_formula, evaluate
    from .machine import Machine, Operation, load_machine, load_machine_text
    from .notation import parse_literal
    from .parser import parse_formula, parse_substitution
    from .printer import to_b
    from .state import read_state_file
    from .values import Elem, FuncValue, format_value
    from .vector import BatchFormula, evaluate_batch

_WHERE = {
    "compile_formula": "evaluation", "evaluate": "evaluation",
    "Machine": "machine", "Operation": "machine", "load_machine": "machine",
    "load_machine_text": "machine",
    "parse_formula": "parser", "parse_substitution": "parser",
    "to_b": "printer", "read_state_file": "state",
    "Elem": "values", "FuncValue": "values", "format_value": "values",
    "parse_literal": "notation",
    "BatchFormula": "vector", "Columns": "columns", "evaluate_batch": "vector",
}

__all__ = [
    "parse_formula", "parse_substitution", "evaluate", "compile_formula", "load_machine",
    "load_machine_text", "Machine", "Operation", "to_b", "parse_literal", "format_value",
    "Elem", "FuncValue", "Columns", "BatchFormula", "evaluate_batch", "read_state_file",
]


__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
