"""Sets inside compiled formulas: the explicit form of a finite set and a lazy walk over its
elements, as :mod:`.values` builds them, with errors located at the formula that asked."""

from __future__ import annotations

from typing import Any, Iterator

from ..errors import EvaluationError, TracecheckError
from . import ast
from . import values
from .values import SymbolicSet

__all__ = ["finite", "members"]


def finite(comp, node: ast.Node, v: Any) -> frozenset:
    """``v`` as a frozenset (a located error for an infinite set or a value that is not a set)."""
    if isinstance(v, frozenset):
        return v
    if not isinstance(v, SymbolicSet):
        raise comp.type_error(node, v, "a set")
    if v.finiteness() is not True:
        known = v.refusal()
        if known is not None:
            raise known
        what = "the infinite set" if v.finiteness() is False else \
            "a set tracecheck cannot tell is finite:"
        raise comp.error(EvaluationError, node,
                         f"`{comp.text(node)}` is {what} {v.name}; tracecheck "
                         "only computes with finite sets here")
    try:
        return values.explicit(v)
    except TracecheckError as exc:
        raise comp.at(node, exc) from None


def members(comp, node: ast.Node, v: Any) -> Iterator[Any]:
    """The elements of a finite set, walked lazily (a located error above the size limit)."""
    try:
        return values.members(v)
    except TracecheckError as exc:
        raise comp.at(node, exc) from None
