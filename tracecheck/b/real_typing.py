"""Which parameters of an operation its guard types REAL (``p : REAL``, or ``p : FLOAT``):
the parameters whose allowed values :mod:`.linear` computes."""

from __future__ import annotations

from . import ast
from .bindings import conjuncts

__all__ = ["real_parameters", "real_typed", "typing_conjunct"]


def real_parameters(op) -> bool:
    """Whether every parameter of ``op`` is typed REAL (:func:`real_typed`)."""
    return bool(op.params) and set(op.params) <= real_typed(op)


def real_typed(op) -> frozenset[str]:
    """The parameters of ``op`` a conjunct ``p : REAL`` of its guard types."""
    found = conjuncts(op.guard) if op.guard is not None else []
    return frozenset(c.left.id for c in found if typing_conjunct(c) and c.left.id in op.params)


def typing_conjunct(node: ast.Node) -> bool:
    """Whether ``node`` is ``name : REAL`` (or ``name : FLOAT``)."""
    return isinstance(node, ast.Rel) and node.op == ":" and isinstance(node.left, ast.Name) \
        and isinstance(node.right, ast.Name) and node.right.id in ("REAL", "FLOAT")
