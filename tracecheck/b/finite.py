"""Sets inside compiled formulas: the explicit form of a finite set (located errors above the
size limit or for infinite sets), lazy walks, and building sets from values."""

from __future__ import annotations

from typing import Any

from ..errors import EvaluationError, TracecheckError
from . import ast as A
from . import values as V
from .values import FuncValue, SymbolicSet

__all__ = ["finite", "members", "make_set", "hashable", "short"]


def hashable(v: Any) -> Any:
    if isinstance(v, SymbolicSet) and v.finiteness() is True:
        return v.materialise()
    return v


def finite(comp, node: A.Node, v: Any) -> frozenset:
    if isinstance(v, frozenset):
        return v
    if isinstance(v, SymbolicSet):
        if v.finiteness() is not True:
            raise comp.error(EvaluationError, node,
                             f"`{comp.text(node)}` is the infinite set {v.name}; tracecheck "
                             "only computes with finite sets here")
        try:
            return v.materialise()
        except TracecheckError as exc:
            raise comp.at(node, exc) from None
    raise comp.type_error(node, v, "a set")


def members(comp, node: A.Node, v: Any):
    """The elements of a finite set, walked lazily (a located error above the size limit)."""
    if isinstance(v, frozenset):
        return v
    try:
        V.check_size(v.card(), v.name)
    except TracecheckError as exc:
        raise comp.at(node, exc) from None
    return v.elements()


def make_set(items: list) -> frozenset:
    if items and all(type(i) is tuple for i in items):
        mapping = dict(items)
        if len(mapping) == len(items):
            return FuncValue(mapping)
    try:
        return frozenset(items)
    except TypeError:
        return frozenset(hashable(i) for i in items)


short = V.brief
