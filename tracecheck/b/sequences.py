"""The sequence operators of B for the scalar compiler (``^ -> <- /|\\ \\|/``): a sequence is
a set of pairs ``1..n``, built and taken apart as a Python list."""

from __future__ import annotations

from typing import Any, Callable

from . import ast
from .finite import finite as _finite
from .values import SymbolicSet, as_sequence, brief, sequence

__all__ = ["Sequences"]

Fn = Callable[[dict], Any]


class Sequences:
    """Mixin of :class:`~tracecheck.b.evaluation.Compiler`: ``op_<name>`` for each sequence
    operator (it gives ``wd``, ``int_of``)."""

    def op_concat(self, node, l, r) -> Fn:
        def concat(env: dict) -> Any:
            return sequence(self.seq_items(node.left, l(env))
                              + self.seq_items(node.right, r(env)))
        return concat

    def op_prepend(self, node, l, r) -> Fn:
        return lambda env: sequence([l(env)] + self.seq_items(node.right, r(env)))

    def op_append(self, node, l, r) -> Fn:
        return lambda env: sequence(self.seq_items(node.left, l(env)) + [r(env)])

    def op_take(self, node, l, r) -> Fn:
        return lambda env: sequence(self._cut(node, l(env), r(env))[0])

    def op_drop(self, node, l, r) -> Fn:
        return lambda env: sequence(self._cut(node, l(env), r(env))[1])

    def _cut(self, node, s: Any, n: Any) -> tuple[list, list]:
        """``s /|\\ n`` and ``s \\|/ n``: well-defined for n in 0..size(s) (the B book)."""
        items, n = self.seq_items(node.left, s), self.int_of(node.right, n)
        if not 0 <= n <= len(items):
            raise self.wd(node, f"{n} is not in 0..size(s) = 0..{len(items)} for `{node.op}`")
        return items[:n], items[n:]

    def seq_items(self, node: ast.Node, v: Any) -> list:
        items = as_sequence(_finite(self, node, v) if isinstance(v, SymbolicSet) else v)
        if items is None:
            raise self.wd(node, f"{brief(v)} is not a sequence")
        return items

