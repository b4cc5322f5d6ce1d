"""The B engine: parse classical B machines and evaluate them on concrete states.

>>> from tracecheck.b import parse_formula, evaluate
>>> evaluate(parse_formula("card({x | x : 1..10 & x mod 3 = 0})"), {})
3
"""

from .evaluate import compile_formula, evaluate
from .machine import Machine, Operation, load_machine, load_machine_text
from .parser import parse_formula, parse_substitution
from .printer import to_b
from .state import read_state_file
from .values import Elem, FuncValue, format_value, parse_literal
from .vector import BatchFormula, Columns, evaluate_batch

__all__ = [
    "parse_formula", "parse_substitution", "evaluate", "compile_formula", "load_machine",
    "load_machine_text", "Machine", "Operation", "to_b", "parse_literal", "format_value",
    "Elem", "FuncValue", "Columns", "BatchFormula", "evaluate_batch", "read_state_file",
]
