"""The words that structure a machine's text: its clauses, the tokens that open and
close a nested part (a clause keyword inside a WHILE's INVARIANT is no clause), and the
renamed names ``r.x`` of included machines read as one."""

from __future__ import annotations

from typing import Callable

from lark import Token

__all__ = ["CLAUSES", "UNSUPPORTED_CLAUSES", "OPENERS", "CLOSERS", "merge_dotted"]

#: The clauses of a machine tracecheck reads by itself.
CLAUSES = (
    "MACHINE", "SETS", "CONSTANTS", "CONCRETE_CONSTANTS", "ABSTRACT_CONSTANTS", "PROPERTIES",
    "VARIABLES", "CONCRETE_VARIABLES", "ABSTRACT_VARIABLES", "INVARIANT", "ASSERTIONS",
    "DEFINITIONS", "INITIALISATION", "OPERATIONS",
)
#: Clauses tracecheck refuses (refinement, Event-B), with a located error.
UNSUPPORTED_CLAUSES = (
    "MODEL", "SYSTEM", "REFINEMENT", "IMPLEMENTATION", "REFINES", "LOCAL_OPERATIONS",
    "VALUES", "EVENTS",
)
#: Token types that open a part an END or a bracket closes.
OPENERS = {"LPAR", "LSQB", "LBRACE", "BEGIN", "IF", "SELECT", "PRE", "ANY", "LET",
            "CHOICE", "ASSERT", "VAR", "CASE", "EITHER", "WHILE"}
CLOSERS = {"RPAR", "RSQB", "RBRACE", "END"}


def merge_dotted(toks: list[Token], joins: Callable[[str, str], bool]) -> list[Token]:
    """``r . x`` as the one name ``r.x`` where ``joins(r, x)`` (a variable or operation of a
    machine included with renaming)."""
    out: list[Token] = []
    k = 0
    while k < len(toks):
        tok = toks[k]
        if tok.type == "NAME" and k + 2 < len(toks) and toks[k + 1].type == "DOT" and \
                toks[k + 2].type == "NAME" and joins(tok.value, toks[k + 2].value):
            last = toks[k + 2]
            out.append(Token("NAME", f"{tok.value}.{last.value}", tok.start_pos, tok.line,
                             tok.column, last.end_line, last.end_column, last.end_pos))
            k += 3
        else:
            out.append(tok)
            k += 1
    return out
