"""The words that structure a machine's text: its clauses, and the tokens that open and
close a nested part (a clause keyword inside a WHILE's INVARIANT is no clause)."""

from __future__ import annotations

__all__ = ["CLAUSES", "OPENERS", "CLOSERS"]

#: The clauses of a machine tracecheck reads by itself.
CLAUSES = (
    "MACHINE", "SETS", "CONSTANTS", "CONCRETE_CONSTANTS", "ABSTRACT_CONSTANTS", "PROPERTIES",
    "VARIABLES", "CONCRETE_VARIABLES", "ABSTRACT_VARIABLES", "INVARIANT", "ASSERTIONS",
    "DEFINITIONS", "INITIALISATION", "OPERATIONS",
)
#: Token types that open a part an END or a bracket closes.
OPENERS = {"LPAR", "LSQB", "LBRACE", "BEGIN", "IF", "SELECT", "PRE", "ANY", "LET",
            "CHOICE", "ASSERT", "VAR", "CASE", "EITHER", "WHILE"}
CLOSERS = {"RPAR", "RSQB", "RBRACE", "END"}
