"""A discrete shield's decisions: which of an environment's actions it allows in a state, for
one state or for many at once.

:class:`Decisions` is what :class:`~tracecheck.live.wrapper.ShieldWrapper` asks after each
reset and step, and what a shielded vector environment (:mod:`tracecheck.live.vector`) asks
once for all its sub-environments:

* each distinct state is decided once: the decisions are memoised by the state's values (a
  grid world visits a few dozen states millions of times). States holding a float zero or a
  NaN, or values other than numbers, booleans, strings, elements, pairs, sets and functions
  of them, are decided afresh each time (``0.0 == -0.0`` and ``NaN != NaN`` would make a
  memo confuse or miss them);
* many states at once (from :data:`BATCH_MIN` distinct ones not remembered) may go through
  the batch evaluator (:class:`~tracecheck.b.vector.BatchFormula`, real powers by Python's
  own ``**``, so that every row's answer is the scalar path's) when every guard takes its
  batch path for them. Both ways give the same answers; which is faster depends on the
  states (building columns from states of five vehicles' functions costs more than deciding them
  one by one, 16 or 1024 at a time; a few numbers per state are 1.6× faster in a batch of
  256), so
  the faster one, as measured on these states, is taken, the other tried again now and then.
  A machine whose operations have REAL parameters is decided one state at a time;
* a guard that cannot be evaluated — a refusal, not FALSE — does not allow its action (the
  shield fails closed), and :attr:`Decision.problem` says why. In a batch, any such state
  sends the whole batch one state at a time, so the answers and messages are those of one
  by one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Mapping, Optional, Sequence

import numpy as np

from ..b.linear import real_parameters
from ..b.memo import MEMO_KEY
from ..b.values import Elem, FuncValue
from ..errors import TracecheckError

__all__ = ["Decision", "Decisions"]

#: the most states (and sets or functions) remembered; past it the memo starts afresh
MEMO_SIZE = 4096
#: after this many lookups with fewer than 1 in 20 found, the memo is given up (states that
#: rarely repeat, as those of real-valued dynamics: the keys would cost more than they save,
#: up to twice a decision where each state holds new functions of reals)
TRIAL = 128
#: the fewest distinct states worth a batch (below it, columns cost more than they save)
BATCH_MIN = 32
#: every this many choices, the slower way is timed again
RETRY = 64
_ATOMS = frozenset({int, bool, str, Elem})
#: atoms that Python finds equal across types (1 == 1.0 == True, Elem("a") == "a"): a set
#: or function mixing two of a group is not memoised
_NUMBERS = frozenset({int, bool, float})
_TEXTS = frozenset({str, Elem})


@dataclass(frozen=True, eq=False)
class Decision:
    """What the shield allows in one state.

    Attributes:
        mask: one bool per action, in the adapter's order (read-only).
        allowed: the allowed actions' names, in that order.
        problem: why guards could not be evaluated (their actions not allowed), or None.
    """

    mask: np.ndarray
    allowed: tuple[str, ...]
    problem: Optional[str] = None


class Decisions:
    """The decisions of ``machine`` over ``actions`` (see the module docstring).

    Args:
        machine: the shield's machine.
        actions: the environment's actions, each an operation of the machine.
    """

    def __init__(self, machine, actions: Sequence[str]) -> None:
        self.machine = machine
        self.actions = tuple(actions)
        self._env = dict(machine.base_env)  # kept: each decision only updates it
        self._memo: dict[tuple, Decision] = {}
        self._memoise = True
        self._lookups = self._found = 0
        self._exact: dict[int, tuple[Any, Any]] = {}  # by id: (the object, its canonical)
        self._canon: dict[Any, Any] = {}
        self._formulas: Optional[dict] = None  # the batch guards, made at the first batch
        self._batch = not any(real_parameters(op) for op in machine.operations.values())
        self._cost: dict[bool, Optional[float]] = {True: None, False: None}  # µs per state
        self._choices = 0
        self._made: dict[tuple[str, ...], Decision] = {}  # the decisions without a problem
        self._names: set = set()  # the names of the state decided last

    def one(self, state: Mapping[str, Any]) -> Decision:
        """The decision in ``state`` (a dict of B values of the machine's variables)."""
        key = self._key(state)
        if key is not None:
            found = self._look(key)
            if found is not None:
                return found
        decision = self._scalar(state)
        if key is not None:
            self._remember(key, decision)
        return decision

    def many(self, states: Sequence[Mapping[str, Any]]) -> list[Decision]:
        """The decision in each of ``states``: those not remembered decided in one batch."""
        keys = [self._key(s) for s in states]
        out: list[Optional[Decision]] = [self._look(k) if k is not None else None
                                         for k in keys]
        todo: dict[Any, list[int]] = {}  # the states to decide, equal ones once (a state
        for i, (key, found) in enumerate(zip(keys, out)):  # without a key: by its row)
            if found is None:
                todo.setdefault(key if key is not None else i, []).append(i)
        firsts = [rows[0] for rows in todo.values()]
        batch = self._batch and len(firsts) >= BATCH_MIN and self._prefer_batch()
        start = time.perf_counter()
        decided = self._batched([states[i] for i in firsts]) if batch else None
        if decided is None:
            batch = False
            start = time.perf_counter()
            decided = [self._scalar(states[i]) for i in firsts]
        if firsts:
            spent = (time.perf_counter() - start) * 1e6 / len(firsts)
            old = self._cost[batch]
            self._cost[batch] = spent if old is None else 0.8 * old + 0.2 * spent
        for (key, rows), decision in zip(todo.items(), decided):
            if type(key) is tuple:
                self._remember(key, decision)
            for i in rows:
                out[i] = decision
        return out  # type: ignore[return-value]

    def _prefer_batch(self) -> bool:
        """Whether to take the batch path now: the faster as measured so far, each tried
        first once, the slower again every :data:`RETRY` choices."""
        batch, one = self._cost[True], self._cost[False]
        if batch is None or one is None:
            return batch is None
        self._choices += 1
        return (batch < one) != (self._choices % RETRY == 0)

    def _scalar(self, state: Mapping[str, Any]) -> Decision:
        env = self._env
        env.pop(MEMO_KEY, None)
        names = state.keys()
        if names != self._names:  # a name the state before had and this one lacks: gone
            for name in self._names - names:  # (a decision is of its own state alone)
                env.pop(name, None)
            env.update(self.machine.base_env)
            self._names = set(names)
        env.update(state)
        machine = self.machine
        try:
            return self._decision(machine.enabled_in(env))
        except TracecheckError:  # which guard, and why: one by one
            enabled, problems = set(), []
            for name in self.actions:
                try:
                    if machine.is_enabled_in(name, env):
                        enabled.add(name)
                except TracecheckError as exc:
                    problems.append(f"{name}: {exc.message}")
            return self._decision(enabled, "; ".join(problems) or None)

    def _batched(self, states: list) -> Optional[list[Decision]]:
        """The decisions of ``states`` by the batch evaluator; None where it does not take
        them all (states of different variables, a guard row by row, an error)."""
        from ..b.columns import Columns

        names = list(states[0])
        if not self._batch or any(list(s) != names for s in states):
            return None
        formulas = self._batch_formulas()
        memo: dict = {}
        try:
            cols = Columns.from_states(states)
            if not all(f.vectorised(cols) for f in formulas.values()):
                self._batch = False  # the guards row by row: never faster than one by one
                return None
            holds = {op: np.asarray(f(cols, memo), dtype=bool) for op, f in formulas.items()}
        except (TracecheckError, OverflowError, ValueError, TypeError):  # one by one, then:
            return None  # the states' answers and messages are those of the scalar path
        operations = self.machine.operations
        n = len(states)
        # an operation without a guard is always enabled; an action the machine has no
        # operation for never is (as machine.enabled_in has it)
        columns = np.stack([holds[a] if a in holds else np.full(n, a in operations, dtype=bool)
                            for a in self.actions], axis=1)
        return [self._decision({a for a, ok in zip(self.actions, row) if ok}) for row in
                columns.tolist()]

    def _batch_formulas(self) -> dict:
        if self._formulas is None:
            from ..b.vector import BatchFormula

            machine = self.machine
            self._formulas = {
                op.name: BatchFormula(op.enabling_guard, machine.base_env, source=machine.source,
                                      file=machine.file, python_power=True)
                for op in machine.operations.values()
                if op.guard is not None and op.name in self.actions}
        return self._formulas

    def _decision(self, enabled, problem: Optional[str] = None) -> Decision:
        allowed = tuple(a for a in self.actions if a in enabled)
        if problem is None:  # one object per allowed set: no array built per state
            found = self._made.get(allowed)
            if found is not None:
                return found
        mask = np.array([a in enabled for a in self.actions], dtype=bool)
        mask.flags.writeable = False
        decision = Decision(mask, allowed, problem)
        if problem is None:
            self._made[allowed] = decision
        return decision

    def _look(self, key: tuple) -> Optional[Decision]:
        found = self._memo.get(key)
        self._lookups += 1
        if found is not None:
            self._found += 1
        elif self._lookups >= TRIAL and self._found * 20 < self._lookups:
            self._memoise = False  # given up: see TRIAL
            self._memo.clear()
            self._exact.clear()
            self._canon.clear()
        return found

    def _remember(self, key: tuple, decision: Decision) -> None:
        if not self._memoise:
            return
        if len(self._memo) >= MEMO_SIZE:
            self._memo.clear()
        self._memo[key] = decision

    def _key(self, state: Mapping[str, Any]) -> Optional[tuple]:
        """The memo's key of ``state``: its names, values and their types; None where a
        value is not one a dict tells apart exactly. Equal sets and functions are made one
        object (sub-environments each build their own map: comparing two is slow)."""
        if not self._memoise:
            return None
        values = list(state.values())
        types = tuple(map(type, values))
        for i, value in enumerate(values):
            kind = type(value)
            if kind in _ATOMS:
                continue
            if kind is float:
                if value != value or value == 0.0:
                    return None
                continue
            same = self._canonical(value)
            if same is None:
                return None
            values[i] = same
        return tuple(state), tuple(values), types

    def _canonical(self, value: Any) -> Optional[tuple]:
        """(the types of its atoms, the one object equal to ``value`` of those types); None
        for a value not memoised. Each object is looked at once."""
        seen = self._exact.get(id(value))
        if seen is not None and seen[0] is value:
            return seen[1]
        leaves = _leaf_types(value)
        same = None
        if leaves is not None and len(leaves & _NUMBERS) <= 1 and len(leaves & _TEXTS) <= 1:
            same = self._canon.setdefault((leaves, value), (leaves, value))  # the types
            #     kept in the key: {a |-> 1}, {a |-> TRUE} and {a |-> 1.0} are equal in Python
        if len(self._exact) >= MEMO_SIZE:
            self._exact.clear()
            self._canon.clear()
        self._exact[id(value)] = (value, same)  # the object kept: its id stays its own
        return same


def _leaf_types(value: Any) -> Optional[frozenset]:
    """The types of the atoms in ``value``; None where one is not memoised."""
    kind = type(value)
    if kind in _ATOMS:
        return frozenset((kind,))
    if kind is float:
        return frozenset((float,)) if value == value and value != 0.0 else None
    if kind is FuncValue:
        parts = [p for pair in value.map.items() for p in pair]
    elif kind in (tuple, frozenset):
        parts = list(value)
    else:
        return None
    found: set = set()
    for part in parts:
        leaves = _leaf_types(part)
        if leaves is None:
            return None
        found |= leaves
    return frozenset(found)
