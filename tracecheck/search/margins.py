"""How close an episode came to a guard of its shield flipping (``falsify --guide margin``):
what only a shield-aware search has to go on between violations of a true/false property.

A guard's *margin* in a state is its robustness read as STL reads an atom: a comparison
``a < b`` (``<=``, ``>``, ``>=``) has margin ``b - a`` (``a - b`` for ``>``), in its own
units; ``&`` the smallest of its parts, ``or`` the largest, ``not`` the negation, ``P => Q``
the larger of ``not P`` and ``Q``; any other atom (an equality, a membership, a quantifier)
+infinity where true and -infinity where false (no distance known). An episode's margin is the
smallest margin of the guard of each action taken, in the state it was taken in: a small one
says that a step came close to being blocked, or to being allowed where it was not.

Only discrete actions: an operation with REAL parameters has a set of allowed values, not a
guard to measure (its episodes have no margin: the guide is not used).
"""

from __future__ import annotations

import math
from typing import Optional

from ..b import ast
from ..episodes.model import Episode
from ..errors import TracecheckError

__all__ = ["GuardMargins"]

_SIGN = {"<": 1.0, "<=": 1.0, ">": -1.0, ">=": -1.0}


class GuardMargins:
    """The margins of ``machine``'s guards (each sub-formula compiled once)."""

    def __init__(self, machine) -> None:
        self.machine = machine
        self._compiled: dict = {}

    def _fn(self, node: ast.Node):
        fn = self._compiled.get(id(node))
        if fn is None:
            fn = self._compiled[id(node)] = (node, self.machine.compile(node))
        return fn[1]

    def margin(self, node: Optional[ast.Node], env: dict) -> float:
        """The margin of the predicate ``node`` (None: always true) in ``env``."""
        if node is None:
            return math.inf
        if isinstance(node, ast.And):
            return min(self.margin(node.left, env), self.margin(node.right, env))
        if isinstance(node, ast.Or):
            return max(self.margin(node.left, env), self.margin(node.right, env))
        if isinstance(node, ast.Not):
            return -self.margin(node.operand, env)
        if isinstance(node, ast.Implies):
            return max(-self.margin(node.left, env), self.margin(node.right, env))
        if isinstance(node, ast.Rel) and node.op in _SIGN:
            a, b = self._fn(node.left)(env), self._fn(node.right)(env)
            if type(a) in (int, float) and type(b) in (int, float):
                return _SIGN[node.op] * (float(b) - float(a))
        return math.inf if self._fn(node)(env) is True else -math.inf

    def episode(self, episode: Episode) -> Optional[float]:
        """The smallest margin of the guards of the actions taken (None where the episode
        has no discrete action with a guard to measure, or a guard cannot be evaluated)."""
        ops = self.machine.operations
        found: list[float] = []
        for before, step in zip(episode.steps, episode.steps[1:]):
            op = ops.get(step.action) if step.action is not None else None
            if op is None or op.params:
                return None
            try:
                found.append(self.margin(op.guard, self.machine.env(before.state)))
            except TracecheckError:
                return None
        # a guard false where its action was taken (the fallback): as close as can be, 0
        measured = [max(0.0, m) for m in found if m != math.inf]
        return min(measured) if measured else None
