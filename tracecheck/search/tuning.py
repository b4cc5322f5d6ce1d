"""Tune one number of a shield against recorded episodes: for *every* value of it at once, how
many recorded steps the shield would block, in how many episodes, how many crashes came at or
after the first blocked step, and how many states would be deadlocks — exactly, from one pass
over the recordings.

For each recorded state and each operation whose guard reads the number, the guard is turned
into the set of the number's values for which it holds (:mod:`tracecheck.b.threshold`:
exact rationals over the reals). A step is blocked for the values outside its action's set;
an episode for those in the union of its steps' blocked sets (a crash on a blocked way: of
its steps up to the crash); a state is a deadlock for the values no operation allows. Each
figure is then a sum of indicators of finitely many intervals: a piecewise-constant function
of the number, given by its breakpoints (:class:`Piece`), not sampled on a grid.

The pieces are over the reals; the engine evaluates REALs as floats, so right at a breakpoint
(within rounding of the terms the number is added to) a float evaluation can differ from
them. The values reported on their own — the machine's own value, ``--at``, the knee — are
therefore not read off the pieces: each is what ``replay`` of the machine with it written in
says (the machine's own from the same pass, the others by a replay each).
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Iterable, Optional, Sequence

import numpy as np

from ..b import ast
from ..b.columns import Columns
from ..b.threshold import ThresholdCompiler, Values
from ..b.threshold_batch import ThresholdBatch
from ..checking.replaying import enabled_matrix, recorded_feasibility
from ..checking.shield import Shield
from ..episodes.columns import RunColumns, read_blocks
from ..errors import InputError, TracecheckError, UnsupportedError
from .tune_target import Target
from .tune_sweep import Figures, FrontPoint, Piece, front, knee, sweep, whole_numbers

__all__ = ["TuneResult", "tune", "tune_grid", "shield_with", "Figures", "Piece", "FrontPoint"]

#: the most sets kept from earlier blocks (a state seen again is not computed again)
_MEMO = 200_000


@dataclass
class TuneResult:
    """What :func:`tune` found (see the module docstring)."""

    shield: dict
    target: Target
    files: list[str]
    low: float
    high: float
    episodes: int = 0
    steps: int = 0
    crashes: int = 0
    #: the figures on each piece of the range (a breakpoint is a piece of its own)
    pieces: list[Piece] = field(default_factory=list)
    #: the figures at the values reported on their own (the machine's own value first)
    at: dict[float, Figures] = field(default_factory=dict)
    #: why deadlock states are not counted (None: they are)
    deadlock_note: Optional[str] = None
    #: how the figures were found: "exact" (every value) or "grid" (the values given)
    method: str = "exact"
    elapsed_s: float = 0.0
    warnings: list[str] = field(default_factory=list)
    front: list[FrontPoint] = field(default_factory=list)
    knee: Optional[FrontPoint] = None

    @property
    def current(self) -> Figures:
        """The figures with the machine as written."""
        return self.at[float(self.target.value)]

    def figures_at(self, value: float) -> Figures:
        """The figures at ``value``: as reported on its own where it is, else its piece's."""
        if float(value) in self.at:
            return self.at[float(value)]
        x = Fraction(value)
        for p in self.pieces:
            if p.contains(x):
                return p.figures
        raise InputError(f"{value} is outside the range tuned ({self.low}..{self.high})")


class _Sets:
    """Per recorded state and operation, the values its guard allows (computed once, where
    first asked: states are the same where the variables the guards read are). One for all
    the blocks of all the files: a state seen in an earlier block is not computed again —
    its key holds the columns' names, kinds and elements as well as their bytes."""

    def __init__(self, shield: Shield, target: Target):
        machine = shield.machine
        self.machine, self.target = machine, target
        self.memo: dict[tuple, Values] = {}
        shared: dict = {}  # one numbering: a state's environment keeps a formula's set for all
        self.fns = {op: _compiled(machine, target, op, g, shared)
                    for op, g in target.guards.items()}
        self.batch = ThresholdBatch(machine, target.name, {
            op: g for op, g in target.guards.items() if not machine.operations[op].params},
            target.integer)
        self.ids: dict = {}  # values of columns of other values, numbered for the keys
        read = set().union(*(ast.free_names(g) for g in target.guards.values()))
        self.read = sorted(read & set(machine.variables))

    def start(self, cols: RunColumns, needed: np.ndarray) -> None:
        """Take the states of a block (``needed``: the rows whose sets may be asked for)."""
        self.cols = cols
        st = cols.states
        keep = set(self.read) & st.names()
        parts = [{k: v for k, v in part.items() if k in keep}
                 for part in (st.numbers, st.booleans, st.functions, st.masks, st.others)]
        sub = Columns(st.n, st.elements, *parts)
        self.layout = (st.elements, tuple(
            tuple((k, getattr(v, "dtype", None) if not isinstance(v, tuple) else
                   (v[0].dtype, v[1].dtype)) if not isinstance(v, list) else (k, "list")
                  for k, v in part.items()) for part in parts))
        self.firsts, self.which = sub.distinct()
        self.keys = sub.keys(self.firsts, self.ids)
        wanted = np.unique(self.which[needed])
        self.read_row = sub.row_reader(self.firsts[wanted])
        self.envs: dict[int, dict] = {}
        if len(self.memo) > _MEMO:  # states of earlier blocks: kept while memory allows
            self.memo.clear()
        # the batch path first, for the states not seen before; the exact path for the rest
        todo = [int(d) for d in wanted if any((self.layout, self.keys[d], op, None)
                                              not in self.memo for op in self.batch.ops)]
        if todo:
            got = self.batch.sets(sub.take(self.firsts[todo]))
            for op, sets in got.items():
                for d, values in zip(todo, sets):
                    if values is not None:
                        self.memo.setdefault((self.layout, self.keys[d], op, None), values)

    def env(self, d: int) -> dict:
        env = self.envs.get(d)
        if env is None:
            env = self.envs[d] = dict(self.machine.base_env)  # as the batch path's rows
            env.update(self.read_row(int(self.firsts[d])))
        return env

    def of(self, row: int, op: str, params: Optional[dict] = None) -> Values:
        """The values for which ``op``'s guard holds in the state at ``row``."""
        d = int(self.which[row])
        key = (self.layout, self.keys[d], op, None if params is None else tuple(params.items()))
        got = self.memo.get(key)
        if got is None:
            env = self.env(d) if params is None else {**self.env(d), **params}
            try:
                got = self.memo[key] = self.fns[op](env)
            except TracecheckError as exc:
                raise _located(self.cols, row, op, exc) from None
        return got


def _compiled(machine, target: Target, op: str, guard, shared: dict):
    params = tuple(machine.operations[op].params)
    try:
        values = ThresholdCompiler(machine, target.name, params, target.integer,
                                   shared).pred(guard)
    except UnsupportedError as exc:
        raise InputError(f"{target.label}: the guard of {op} {exc.message.removeprefix('the guard ')}",
                         hint="tracecheck finds the figures for every value only where the "
                         "guards are linear in the number; --grid N gives them at N values "
                         "instead (by replay of the machine with each written in)") from None
    return values


def _located(cols: RunColumns, row: int, op: str, exc: TracecheckError) -> TracecheckError:
    return UnsupportedError(f"{cols.path}: episode {int(cols.episode[row])}, step "
                            f"{int(cols.step[row]) + 1} ({op}): tracecheck cannot tell for "
                            f"which values the guard holds: {exc.message}",
                            hint="--grid N gives the figures at N values instead")


@dataclass
class _Tally:
    """The sets every figure sums indicators of, with how often each comes; and the
    machine's own figures, counted as replay counts them."""

    steps: Counter = field(default_factory=Counter)  # blocked sets of steps
    episodes: Counter = field(default_factory=Counter)
    crashes: Counter = field(default_factory=Counter)
    deadlocks: Counter = field(default_factory=Counter)
    own: list = field(default_factory=lambda: [0, 0, 0, 0])


def tune(paths: Iterable[str | Path], shield: Shield, target: Target, low: float,
         high: float, *, at: Sequence[float] = (), knee_too: bool = False) -> TuneResult:
    """The figures of ``shield`` over ``paths`` for every value of ``target`` in
    [``low``, ``high``] (see the module docstring), and at the machine's own value, each of
    ``at`` and (``knee_too``) the front's knee on their own, as replay gives them."""
    paths = [str(p) for p in paths]
    start = time.perf_counter()
    result = TuneResult(shield.identity, target, paths, low, high)
    tally = _Tally()
    sets = _Sets(shield, target)
    for path in paths:
        for cols in read_blocks(path):
            result.warnings += cols.warnings
            _block(shield, target, cols, sets, tally, result)
    pieces = sweep(tally, Fraction(low), Fraction(high), deadlocks=result.deadlock_note is None)
    result.pieces = whole_numbers(pieces) if target.integer else pieces
    result.at = {float(target.value): Figures(*tally.own)}
    result.front = front(result.pieces, result.crashes)
    result.knee = knee(result.front)
    wanted = list(at) + ([result.knee.value] if knee_too and result.knee else [])
    for v in wanted:
        if float(v) not in result.at:
            result.at[float(v)] = replayed(paths, shield, target, v)
    result.elapsed_s = round(time.perf_counter() - start, 6)
    return result


def replayed(paths: Sequence[str], shield: Shield, target: Target, value: float) -> Figures:
    """What replay says of the machine with ``value`` written in."""
    from ..checking.replaying import replay

    return _figures(replay(paths, shield_with(shield, target, value)))


def _figures(r) -> Figures:
    """A replay report's figures."""
    return Figures(r.infeasible_steps, r.infeasible_episodes, r.crashes_after_infeasible,
                   r.deadlock_states)


def _block(shield: Shield, target: Target, cols: RunColumns, sets: _Sets, tally: _Tally,
           result: TuneResult) -> None:
    machine = shield.machine
    if not cols.n:
        return
    matrix, ops = enabled_matrix(shield, cols)
    rows, actions, feasible, _ = recorded_feasibility(shield, cols, matrix, ops, margins=False)
    deadlock = ~matrix.any(axis=1) if ops else np.ones(cols.n, dtype=bool)
    _own(tally, cols, feasible, deadlock)
    tuned = [o for o in ops if o in target.guards]
    continuous = [o for o in tuned if machine.operations[o].params]
    if continuous:
        result.deadlock_note = (f"not counted: {', '.join(continuous)} has parameters, and "
                                "whether some value of them is allowed is not found for every "
                                "value of the tuned number")
    fixed = [i for i, o in enumerate(ops) if o not in target.guards]
    some_fixed = matrix[:, fixed].any(axis=1) if fixed else np.zeros(cols.n, dtype=bool)
    steps_of = rows[np.isin(actions, [k for k, a in enumerate(cols.action_names)
                                      if a in target.guards])]
    needed = np.union1d(steps_of - 1, np.flatnonzero(~some_fixed) if not continuous
                        else np.zeros(0, dtype=np.int64))
    sets.start(cols, needed.astype(np.int64))
    names = cols.action_names
    done: dict[bytes, list] = {}  # an episode the same as one before: the same sets, counted
    for i in range(len(cols.episode_ids)):
        lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
        key = b"|".join(a[lo:hi].tobytes() for a in (sets.which, cols.action, cols.crashed,
                                                      feasible, some_fixed))
        if continuous:
            key += b"".join(cols.parameters[p][lo:hi].tobytes() for p in sorted(cols.parameters))
        found = done.get(key)
        if found is None:
            done[key] = [_episode(sets, cols, lo, hi, feasible, some_fixed, tuned, continuous,
                                  names), 1]
        else:
            found[1] += 1
        result.episodes += 1
        result.steps += hi - lo - 1
        result.crashes += bool(cols.crashed[lo:hi].any())
    for found, times in done.values():
        _add(tally, found, times)


def _own(tally: _Tally, cols: RunColumns, feasible: np.ndarray, deadlock: np.ndarray) -> None:
    """The machine's own figures over a block, as replay counts them."""
    for i in range(len(cols.episode_ids)):
        lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
        bad = np.flatnonzero(~feasible[lo + 1:hi]) + 1
        crashes = np.flatnonzero(cols.crashed[lo:hi])
        tally.own[0] += len(bad)
        tally.own[1] += bool(len(bad))
        tally.own[2] += bool(len(bad) and len(crashes) and crashes[0] >= bad[0])
        tally.own[3] += int(deadlock[lo:hi].sum())


def _episode(sets: _Sets, cols: RunColumns, lo: int, hi: int, feasible: np.ndarray,
             some_fixed: np.ndarray, tuned: list[str], continuous: list[str], names) -> tuple:
    """One episode's sets: its steps' blocked sets, the union of them, the union up to its
    crash, its states' deadlock sets."""
    crashes = np.flatnonzero(cols.crashed[lo:hi])
    crash = int(crashes[0]) if len(crashes) else None
    blocked: list[Values] = []
    fixed_blocked = 0
    union = crash_union = Values.nothing()
    for k in range(1, hi - lo):
        r = lo + k
        op = names[cols.action[r]]
        if op in sets.target.guards:
            params = ({p: float(cols.parameters[p][r]) for p in sets.machine.operations[op].params}
                      if op in continuous else None)
            bad = sets.of(r - 1, op, params).complement()
            blocked.append(bad)
            union = union.union(bad)
            if crash is not None and k <= crash:
                crash_union = crash_union.union(bad)
        elif not feasible[r]:
            fixed_blocked += 1
            union = Values.everything()
            if crash is not None and k <= crash:
                crash_union = Values.everything()
    deadlocks = []
    if not continuous:
        for r in range(lo, hi):
            if some_fixed[r]:
                continue
            allowed = Values.nothing()
            for op in tuned:
                allowed = allowed.union(sets.of(r, op))
            deadlocks.append(allowed.complement())
    return blocked, fixed_blocked, union, crash_union if crash is not None else None, deadlocks


def _add(tally: _Tally, found: tuple, times: int) -> None:
    """An episode's sets, counted ``times`` (the episodes of a block that are the same)."""
    blocked, fixed_blocked, union, crash_union, deadlocks = found
    for counter, sets in ((tally.steps, blocked), (tally.deadlocks, deadlocks)):
        for v, k in Counter(sets).items():
            counter[v] += k * times
    tally.steps[Values.everything()] += fixed_blocked * times
    tally.episodes[union] += times
    if crash_union is not None:
        tally.crashes[crash_union] += times


def shield_with(shield: Shield, target: Target, value: float) -> Shield:
    """``shield`` with ``value`` written in the target's place (its text rewritten)."""
    from ..b import load_machine_text
    from ..checking.shield import ShieldMachine
    from .tune_target import number_text, written

    machine = load_machine_text(written(shield.machine.source, target, value),
                                file=shield.machine.file, kind=ShieldMachine)
    name = f"{shield.name} with {target.label} = {number_text(value, target.integer)}"
    return Shield(name=name, sha256=machine.sha256, path=shield.path, machine=machine)


def tune_grid(paths: Iterable[str | Path], shield: Shield, target: Target,
              values: Sequence[float]) -> TuneResult:
    """The figures at each of ``values`` only (with the machine's own value): each by
    :func:`~tracecheck.checking.replaying.replay` of the machine with it written in — for a
    number the guards do not read linearly."""
    from ..checking.replaying import replay

    paths = [str(p) for p in paths]
    start = time.perf_counter()
    values = sorted(set([float(target.value), *map(float, values)]))
    result = TuneResult(shield.identity, target, paths, min(values), max(values),
                        method="grid")
    for v in values:
        r = replay(paths, shield_with(shield, target, v))
        result.at[v] = _figures(r)
        result.episodes, result.steps, result.crashes = r.episodes, r.steps, r.crashes
        result.warnings = r.warnings
    result.pieces = [Piece(Fraction(v), Fraction(v), True, True, f, target.integer)
                     for v, f in result.at.items()]
    result.front = front(result.pieces, result.crashes)
    result.knee = knee(result.front)
    result.elapsed_s = round(time.perf_counter() - start, 6)
    return result
