"""How close an episode came to a guard of its shield flipping (``falsify --guide margin``):
what only a shield-aware search has to go on between violations of a true/false property.

A guard's *margin* in a state is its robustness read as STL reads an atom: a comparison
``a < b`` (``<=``, ``>``, ``>=``) has margin ``b - a`` (``a - b`` for ``>``), in its own
units; ``&`` the smallest of its parts, ``or`` the largest, ``not`` the negation, ``P => Q``
the larger of ``not P`` and ``Q``; any other atom (an equality, a membership, a quantifier)
+infinity where true and -infinity where false (no distance known). An episode's margin is the
smallest margin of the guard of each action taken, in the state it was taken in: a small one
says that a step came close to being blocked, or to being allowed where it was not.

For continuous actions (an operation with REAL parameters) the guard allows a set of values,
and what the step measures is how close the guard came to allowing none — the robustness of
"some value is allowed", as STL reads an existential: the largest distance from an allowed
value to the nearest value at which the guard flips. Where the step recorded its set as
intervals of each parameter (``allowed_intervals``, the set their product), that is per
parameter the room of its roomiest interval (half its width, or its whole width where one end
is a bound of the action space, which is no guard's; infinite where both are), the smallest
over the parameters; 0 where nothing was allowed (a deadlock). On a road a small room is
a state where the acceleration the guard allows has shrunk to a sliver: close to the car in
front. A step whose set was not recorded as intervals (a guard not linear in its parameters,
a set that is no product of intervals) leaves the episode without a margin: the guide is not
used for it.
"""

from __future__ import annotations

import math
from typing import Optional

from ..b import ast
from ..episodes.model import Episode
from ..errors import TracecheckError

__all__ = ["GuardMargins", "action_bounds"]

_SIGN = {"<": 1.0, "<=": 1.0, ">": -1.0, ">=": -1.0}


class GuardMargins:
    """The margins of ``machine``'s guards (each sub-formula compiled once)."""

    def __init__(self, machine, bounds: Optional[dict] = None) -> None:
        self.machine = machine
        #: continuous actions: the action space's bounds, {operation: ({param: low},
        #: {param: high})} (:func:`action_bounds`)
        self.bounds = bounds or {}
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
        has no action with a guard to measure, a guard cannot be evaluated, or a continuous
        step did not record its allowed set as intervals)."""
        ops = self.machine.operations
        found: list[float] = []
        for before, step in zip(episode.steps, episode.steps[1:]):
            op = ops.get(step.action) if step.action is not None else None
            if op is None:
                return None
            if op.params:
                within = _within(step, *self.bounds.get(step.action, ({}, {})))
                if within is None:
                    return None
                found.append(within)
                continue
            try:
                found.append(self.margin(op.guard, self.machine.env(before.state)))
            except TracecheckError:
                return None
        # a guard false where its action was taken (the fallback): as close as can be, 0
        measured = [max(0.0, m) for m in found if m != math.inf]
        return min(measured) if measured else None


def action_bounds(continuous) -> dict:
    """The bounds of a shield wrapper's action space per operation with parameters,
    ``{op: ({param: low}, {param: high})}`` (``continuous``: the wrapper's continuous shield,
    None for discrete actions: no bounds)."""
    if continuous is None:
        return {}
    return {name: (dict(op.low), dict(op.high)) for name, op in continuous.ops.items()}


def _within(step, low: dict, high: dict) -> Optional[float]:
    """A continuous step's margin: how close its guard came to allowing nothing (see the
    module docstring); None where the step did not record its allowed values as
    intervals."""
    if step.deadlock:  # nothing was allowed, whatever the set's shape
        return 0.0
    bands = step.allowed_intervals
    if bands is None or not step.parameters:
        return None
    best = math.inf
    for name in step.parameters:
        if name not in bands:
            return None
        room = 0.0  # nothing allowed: a deadlock
        for lo, hi in bands[name]:
            guard_lo = lo is not None and not _bound(lo, low.get(name))
            guard_hi = hi is not None and not _bound(hi, high.get(name))
            if guard_lo and guard_hi:
                room = max(room, (hi - lo) / 2.0)
            elif guard_lo or guard_hi:  # the farthest value is at the space's bound
                far = hi if guard_lo else lo
                near = lo if guard_lo else hi
                room = max(room, abs(far - near) if far is not None else math.inf)
            else:
                room = math.inf
        best = min(best, room)
    return best


def _bound(end: float, bound: Optional[float]) -> bool:
    """Whether an interval's end is the action space's bound (as float32 stores it)."""
    return bound is not None and math.isfinite(bound) and \
        abs(end - bound) <= 1e-6 * max(1.0, abs(bound))
