"""Replay recorded episodes against a shield: where would it have blocked the recorded action?

For each step k >= 1 of each episode: the recorded action must be enabled in the state before
it (else the step is *infeasible*: the shield would have blocked it), the pair of states must
satisfy the operation's effect (else a *postcondition violation*: model and environment
disagree, paper §3.3), the invariant must hold, and a state where the shield enables nothing
is a *deadlock*. Everything is evaluated over the numpy columns of the whole file at once.

A continuous action (an operation whose parameters are typed REAL) is feasible when its guard
holds in the state before with the parameters bound to the recorded values — one batch
evaluation over all its steps; where it does not, the *margin* says how far the recorded
values lay from the nearest the shield allowed (Euclidean, in the parameters' units).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Optional, Sequence

import numpy as np

from ..b.cache import Cache
from ..b.columns import Columns, shifted_pairs, step_pairs
from ..b.linear import real_parameters
from ..episodes.columns import RunColumns, read_blocks
from ..errors import InputError, TracecheckError, UnsupportedError
from .executors import map_file_blocks
from .shared import EnabledNames, shared
from .fit import check_actions, check_variables, refuse_recorded_values
from .shield import Shield
from .episode_results import EpisodeReplay, EpisodeRows
from ..jsontext import Rows, plain

__all__ = ["replay", "replay_columns", "ReplayReport", "EpisodeReplay", "EpisodeRows",
           "enabled_matrix", "recorded_feasibility",
           "check_parameters", "add_up", "OUTCOMES", "NEVER_BLOCKED"]

#: per machine, an operation's guard over the columns with its recorded parameters bound
_BATCH_BOUND_GUARDS: Cache = Cache("batch guards with parameters")

#: what re-simulating one episode can find, in the words every output uses (the lines under
#: the summary, the episode table in every format, the JSON): the recorded crash prevented or
#: not, a new crash, no crash either way, a run that did not reproduce the recording up to
#: the first blocked step (its outcome is unknown), an imported episode without a seed
PREVENTED, NOT_PREVENTED, NEW_CRASH, NO_CRASH, MISMATCH, NO_SEED = OUTCOMES = (
    "prevented", "not prevented", "new crash", "no crash", "did not reproduce", "no seed")
#: what re-simulation says of a crash in an episode the shield would not have blocked
#: anything in: nothing to re-run, the recorded crash stands
NEVER_BLOCKED = "never blocked"


@dataclass
class ReplayReport:
    shield: dict
    files: list[str]
    episodes: int = 0
    steps: int = 0
    feasible_episodes: int = 0
    infeasible_episodes: int = 0
    infeasible_steps: int = 0
    crashes: int = 0
    crashes_after_infeasible: int = 0
    deadlock_states: int = 0
    postcondition_violations: int = 0
    invariant_violations: int = 0
    elapsed_s: float = 0.0
    per_episode: EpisodeRows = field(default_factory=EpisodeRows)
    warnings: list[str] = field(default_factory=list)
    resimulation: Optional[dict] = None
    ltl: list[dict] = field(default_factory=list)  # per formula, see add_ltl

    def resimulated(self) -> Optional[dict[tuple[str, int], str]]:
        """With a re-simulation (``resimulation`` set): per (file, episode) what it found, one
        of :data:`OUTCOMES`, or ``NEVER_BLOCKED`` for a crash
        the shield would not have intervened in, or "" (neither); None without one. Every
        output's episode table shows this, so the table and the re-simulation lines agree."""
        if self.resimulation is None:
            return None
        found = {(r["file"], r["episode"]): r["outcome"]
                 for r in self.resimulation["per_episode"]}
        return {(e.file, e.episode): found.get((e.file, e.episode))
                or (NEVER_BLOCKED if e.crashed else "") for e in self.per_episode}

    def to_json(self) -> dict:
        data = self.json_parts()
        data["per_episode"] = list(data["per_episode"])
        return data

    def json_parts(self) -> dict:
        """:meth:`to_json` with the episodes as a :class:`~tracecheck.jsontext.Rows`, each
        made only as it is written (:func:`~tracecheck.jsontext.write_json`)."""
        data = {f.name: (None if f.name == "per_episode" else plain(getattr(self, f.name)))
                for f in dataclasses.fields(self)}
        outcomes = self.resimulated()
        names = [f.name for f in dataclasses.fields(EpisodeReplay)]

        def entry(e: EpisodeReplay) -> dict:
            row = {name: getattr(e, name) for name in names}
            if outcomes is not None:
                row["resimulated"] = outcomes[(e.file, e.episode)] or None
            return row

        data["per_episode"] = Rows(self.per_episode, entry)
        if self.resimulation is None:
            data.pop("resimulation")
        if not self.ltl:
            data.pop("ltl")
        data["steps_per_s"] = round(self.steps / self.elapsed_s) if self.elapsed_s else None
        return data


def enabled_matrix(shield: Shield, cols: RunColumns) -> tuple[np.ndarray, tuple[str, ...]]:
    """(rows, operations) booleans: which operations the shield enables in each state (an
    operation with REAL parameters: some values within the run's action space allowed)."""
    check_variables(shield, cols)
    bounds = space_bounds(cols)
    enabled = shield.machine.enabled_batch(cols.states, _candidates(shield, cols, bounds),
                                           bounds=bounds)
    ops = tuple(shield.machine.operations)
    return np.stack([enabled[o] for o in ops], axis=1) if ops else \
        np.zeros((cols.n, 0), dtype=bool), ops


def space_bounds(cols: RunColumns) -> dict[str, tuple[dict, ...]]:
    """For each operation with REAL parameters in the run header of ``cols``'s file, the
    action space's bounds of its parameters: ({parameter: low}, {parameter: high}), a side
    without a bound left out (the header lists each operation's components in turn), and
    where the header says them, their float types ({parameter: "float32"}: the allowed
    values are those of that type). None for a run that declares no bounds (an import):
    the guard alone decides."""
    from ..episodes.reader import read_header

    try:
        header = read_header(cols.path)
    except (InputError, OSError):
        return {}
    declared = header.action_parameters or {}
    low, high = header.action_low or [], header.action_high or []
    kinds = header.action_floats or []
    found, offset = {}, 0
    for op, params in declared.items():
        ends: tuple[dict, dict] = ({}, {})
        for k, p in enumerate(params, start=offset):
            for side, given in zip(ends, (low, high)):
                if k < len(given) and given[k] is not None:
                    side[p] = float(given[k])
        floats = {p: kinds[k] for k, p in enumerate(params, start=offset) if k < len(kinds)}
        offset += len(params)
        if ends[0] or ends[1] or floats:
            found[op] = (*ends, floats) if floats else ends
    return found


def _candidates(shield: Shield, cols: RunColumns,
                bounds: dict[str, tuple[dict, dict]]) -> dict[str, list[dict]]:
    """For each operation with REAL parameters, values to try first in each state (see
    :meth:`~tracecheck.b.Machine.enabled_batch`): those recorded for the step that left it
    (the action taken there, when it is this operation), then zero — each only where it lies
    within the action space's ``bounds``. Only tried: the guard, evaluated with them,
    decides."""
    found: dict[str, list[dict]] = {}
    nxt = np.minimum(np.arange(cols.n) + 1, max(cols.n - 1, 0))
    same = (cols.episode[nxt] == cols.episode) & (np.arange(cols.n) + 1 < cols.n) \
        if cols.n else np.zeros(0, dtype=bool)
    for name, op in shield.machine.operations.items():
        if not (op.params and real_parameters(op)) or any(p in cols.states.names()
                                                          for p in op.params):
            continue
        tries = [{p: np.zeros(cols.n) for p in op.params}]
        if name in cols.action_names and all(p in cols.parameters for p in op.params):
            taken = same & (cols.action[nxt] == cols.action_names.index(name))
            tries.insert(0, {p: np.where(taken, cols.parameters[p][nxt], np.nan)
                             for p in op.params})
        low, high, floats = (*bounds.get(name, ({}, {})), {})[:3]
        for values in tries:  # a value outside the space, or not of its float type, is
            outside = np.zeros(cols.n, dtype=bool)  # no action the agent could take
            for p in op.params:
                with np.errstate(invalid="ignore", over="ignore"):
                    outside |= (values[p] < low.get(p, -np.inf)) | \
                        (values[p] > high.get(p, np.inf))
                    if p in floats:
                        outside |= values[p].astype(floats[p]).astype(float) != values[p]
            for p in op.params:
                values[p] = np.where(outside, np.nan, values[p])
        found[name] = tries
    return found


def _postconditions(shield: Shield, cols: RunColumns, rows: np.ndarray,
                    actions: np.ndarray) -> np.ndarray:
    """For each step row, whether the step breaks its operation's postcondition."""
    machine = shield.machine
    bad = np.zeros(len(rows), dtype=bool)
    shifted: Optional[Columns] = None  # every neighbouring pair, as views (no copies)
    for code, name in enumerate(cols.action_names):
        which = np.flatnonzero(actions == code)
        if not len(which) or name not in machine.operations:
            continue
        # a continuous action's effect with its parameters as recorded (checked present)
        params = machine.operations[name].params if real_parameters(
            machine.operations[name]) else ()
        if machine.postcondition(name) is None:  # no predicate: the steps one by one
            for i in which:
                r = rows[i]
                before = {**cols.states.row(r - 1),
                          **{p: float(cols.parameters[p][r]) for p in params}}
                bad[i] = not machine.effect_ok(name, before, cols.states.row(r))
            continue
        try:  # over every pair at once (views), the steps of this operation picked out
            if shifted is None:
                shifted = shifted_pairs(cols.states)
            views = dataclasses.replace(shifted, numbers={
                **shifted.numbers, **{p: cols.parameters[p][1:] for p in params}})
            bad[which] = ~machine.postcondition_batch(name, views)[rows[which] - 1]
        except TracecheckError:  # maybe a pair that is no step of it: only its steps
            pairs = step_pairs(cols.states, rows[which])
            for p in params:
                pairs.numbers[p] = cols.parameters[p][rows[which]]
            bad[which] = ~machine.postcondition_batch(name, pairs)
    return bad


def recorded_feasibility(shield: Shield, cols: RunColumns, matrix: np.ndarray,
                         ops: tuple[str, ...], *, margins: bool = True) -> tuple:
    """(the step rows, their action codes, per row whether its recorded action was allowed in
    the state before, by row the margins of infeasible continuous steps): replay's verdict
    on each step, from the :func:`enabled_matrix` ``matrix`` over ``ops``. A run whose action
    the shield has no operation for is refused (:func:`~.fit.check_actions`)."""
    op_index = {o: i for i, o in enumerate(ops)}
    rows = np.flatnonzero(cols.step > 0)
    actions = cols.action[rows]
    check_actions(shield, cols, rows, actions)
    to_op = np.array([op_index.get(a, 0) for a in cols.action_names] + [0], dtype=np.int64)
    feasible = np.ones(cols.n, dtype=bool)
    feasible[rows] = matrix[rows - 1, to_op[actions]]
    found = check_parameters(shield, cols, rows, actions, feasible, margins=margins)
    return rows, actions, feasible, found


def _replay_file(shield: Shield, cols: RunColumns, report: ReplayReport,
                 ltl: Sequence[tuple] = ()) -> None:
    matrix, ops = enabled_matrix(shield, cols)
    if ltl:
        _check_ltl(shield, cols, report, ltl, {o: matrix[:, i] for i, o in enumerate(ops)})
    rows, actions, feasible, margins = recorded_feasibility(shield, cols, matrix, ops)
    deadlock = ~matrix.any(axis=1) if ops else np.ones(cols.n, dtype=bool)
    machine = shield.machine
    invariant_ok = machine.invariant_batch(cols.states)
    post_bad = np.zeros(cols.n, dtype=bool)
    post_bad[rows] = _postconditions(shield, cols, rows, actions)
    checks = _FileChecks(ops, matrix, feasible, deadlock, invariant_ok, post_bad, margins,
                         EnabledNames(ops))
    largest = _largest_margins(cols, margins)
    # per episode: does it have anything to list (most of a campaign's have not)
    flagged = ~feasible | deadlock | ~invariant_ok | post_bad | cols.crashed
    any_flag = np.logical_or.reduceat(flagged, cols.starts[:-1]) if cols.n else flagged
    quiet = {}
    for i, (ep, lo, hi) in enumerate(zip(cols.episode_ids.tolist(), cols.starts[:-1].tolist(),
                                         cols.starts[1:].tolist())):
        if any_flag[i]:
            report.per_episode.append(_episode(cols, checks, ep, lo, hi, largest.get(i)))
        else:  # nothing happened in it: the one record of such an episode, its length apart
            if hi - lo not in quiet:
                quiet[hi - lo] = _episode(cols, checks, ep, lo, hi)
            _append_as(report.per_episode, quiet[hi - lo], ep)


@dataclass(frozen=True)
class _Margin:
    """An infeasible continuous action: its recorded values, what the shield allowed in the
    state before, and how far outside (None: ``note`` says why)."""

    point: dict[str, float]
    allowed_set: Any  # the AllowedSet, or None
    margin: Optional[float]
    note: Optional[str] = None

    @property
    def allowed(self) -> Optional[str]:
        """The allowed set in words (made only for the steps a report shows)."""
        return None if self.allowed_set is None else str(self.allowed_set)


def _append_as(episodes, like: EpisodeReplay, episode: int) -> None:
    """Episode ``episode``, ``like`` but for its id, to a report's episodes (compactly where
    they are :class:`EpisodeRows`)."""
    if isinstance(episodes, EpisodeRows):
        episodes.append_as(like, episode)
    else:
        episodes.append(dataclasses.replace(like, episode=episode))


def check_parameters(shield: Shield, cols: RunColumns, rows: np.ndarray, actions: np.ndarray,
                     feasible: np.ndarray, *, margins: bool = True) -> dict[int, _Margin]:
    """Decide the steps of continuous actions in ``feasible`` (over the rows of ``cols``):
    by the guard with the recorded parameters, not by "some value allowed" as the enabled
    matrix has it; ``rows`` are the step rows, ``actions`` their action codes. With
    ``margins``: by its row, the margin of each infeasible one. Replay and diff both decide
    steps this way."""
    machine = shield.machine
    found: dict[int, _Margin] = {}
    bounds = {op: b[:2] for op, b in space_bounds(cols).items()} if margins else {}  # reals
    for code, name in enumerate(cols.action_names):
        op = machine.operations.get(name)
        if op is None or not op.params:
            continue
        which = rows[actions == code]
        if not len(which):
            continue
        if not real_parameters(op):
            refuse_recorded_values(shield, cols, op, which)
            continue
        feasible[which] = ok = _guard_with_parameters(shield, cols, op, which)
        if margins:
            found.update(_margins(machine, op, cols, which[~ok], bounds.get(name)))
    return found


def _margins(machine, op, cols: RunColumns, bad: np.ndarray,
             bounds: Optional[tuple[dict, dict]] = None) -> dict[int, _Margin]:
    """The margin of each infeasible step row in ``bad`` (all of ``op``), to the values
    allowed within the action space's ``bounds``: for one parameter in float arithmetic
    over all of them at once where that decides it
    (:func:`~tracecheck.b.linear_batch.batch_margins`, each interval cut to the bounds; a
    row at an end is left to the exact path), else exactly, row by row."""
    from ..b.linear_batch import batch_margins

    found: dict[int, _Margin] = {}
    decided = np.zeros(len(bad), dtype=bool)
    if len(op.params) == 1 and len(bad):
        (p,) = op.params
        space = (-np.inf, np.inf) if bounds is None else \
            (bounds[0].get(p, -np.inf), bounds[1].get(p, np.inf))
        distance, nothing, decided = batch_margins(machine, op.name,
                                                   cols.states.take(bad - 1),
                                                   cols.parameters[p][bad], space)
        for i in np.flatnonzero(decided).tolist():
            r = int(bad[i])
            allowed = _Later(machine, op.name, cols, r, bounds)
            found[r] = _Margin({p: float(cols.parameters[p][r])}, allowed,
                               None if nothing[i] else float(distance[i]),
                               "nothing allowed" if nothing[i] else None)
    for r in bad[~decided].tolist():
        found[r] = _margin(machine, op, cols, r, bounds)
    return found


class _Later:
    """The allowed set of a step, made only when a report shows it."""

    def __init__(self, machine, op: str, cols: RunColumns, r: int,
                 bounds: Optional[tuple[dict, dict]] = None) -> None:
        self.machine, self.op, self.cols, self.r, self.bounds = machine, op, cols, r, bounds

    def __str__(self) -> str:
        return str(_within(self.machine.allowed(self.op, self.cols.states.row(self.r - 1)),
                           self.bounds))


def _within(allowed, bounds: Optional[tuple[dict, dict]]):
    """``allowed`` within the action space's ``bounds`` (as it is without them)."""
    return allowed if bounds is None else allowed.within(*bounds)


def _guard_with_parameters(shield: Shield, cols: RunColumns, op, which: np.ndarray
                           ) -> np.ndarray:
    """For each step row in ``which`` (all of ``op``): does ``op``'s guard hold in the state
    before, its parameters bound to the recorded values? One batch evaluation."""
    machine = shield.machine
    names = cols.states.names() | set(machine.variables)
    for p in op.params:
        if p in names:
            raise InputError(f"{cols.path}: the parameter {p} of {op.name} in the shield "
                             f"{shield.name} has the name of a state variable, so its recorded "
                             "value cannot be told from the state's",
                             hint=f"rename the parameter in {shield.name}")
        values = cols.parameters.get(p)
        missing = which if values is None else which[np.isnan(values[which])]
        if len(missing):
            r = int(missing[0])
            raise InputError(f"{cols.path}, episode {int(cols.episode[r])}, step "
                             f"{int(cols.step[r])}: the recorded action {op.name} has no value "
                             f"for its parameter {p}",
                             hint="a continuous action is replayed with the parameter values "
                                  "recorded with it (a step's `parameters`)")
    before = cols.states.take(which - 1)
    for p in op.params:
        before.numbers[p] = cols.parameters[p][which]
    if cols.states.label is not None:
        label = cols.states.label
        before.label = lambda i: (f"{label(int(which[i]))} ({op.name}'s guard in the state "
                                  "before, its parameters as recorded)")
    guard = machine.cached(_BATCH_BOUND_GUARDS, op.name,
                           lambda: machine.batch(op.guard))
    return np.asarray(guard(before), dtype=bool)


def _margin(machine, op, cols: RunColumns, r: int,
            bounds: Optional[tuple[dict, dict]] = None) -> _Margin:
    """How far the recorded values of step row ``r`` lay from what the shield allowed in
    the state before within the action space's ``bounds``, over the reals
    (:meth:`~tracecheck.b.linear.AllowedSet.distance`)."""
    point = {p: float(cols.parameters[p][r]) for p in op.params}
    try:
        allowed = _within(machine.allowed(op.name, cols.states.row(r - 1)), bounds)
    except UnsupportedError as exc:
        return _Margin(point, None, None, f"no margin: {exc.message}")
    try:
        distance = allowed.distance(point)
        if distance == 0.0:  # on an open end: as far as the nearest float the guard allows
            nearest = allowed.nearest(point)
            distance = None if nearest is None else float(np.hypot.reduce(
                [nearest[p] - point[p] for p in op.params]))
    except (UnsupportedError, OverflowError) as exc:
        why = exc.message if isinstance(exc, UnsupportedError) else "a value beyond floats"
        return _Margin(point, None, None, f"no margin: {why}")
    if distance is not None:
        return _Margin(point, allowed, distance)
    from .solved_set import SolvedSet

    if isinstance(allowed, SolvedSet):  # the solver proved nothing allowed
        why = "nothing allowed"
    elif not allowed.separable:
        why = ("no margin: the allowed set is not a union of boxes (a constraint names "
               "several parameters)")
    elif str(allowed).endswith("∅"):
        why = "nothing allowed"
    else:
        why = "no margin: no float near the allowed set passes the guard"
    return _Margin(point, allowed, None, why)


def _check_ltl(shield: Shield, cols: RunColumns, report: ReplayReport, ltl: Sequence[tuple],
               enabled: dict) -> None:
    """Each (name, text, formula) on every episode of ``cols``, added to ``report.ltl``."""
    from .crashflag import flagged, with_crash_flag
    from .ltl import check_ltl

    cols, machine = with_crash_flag(cols), flagged(shield.machine)
    for name, text, formula in ltl:
        result = check_ltl(name, text, formula, cols, machine, enabled)
        _add_ltl(report, {"name": name, "formula": text, "episodes": result.episodes,
                          "satisfied": result.satisfied,
                          "violations": [{"file": cols.path, "episode": ep, "first_step": step}
                                         for ep, step in result.violations]})


def _add_ltl(report: ReplayReport, entry: dict) -> None:
    """One formula's result on one file, added to the report's result for that formula."""
    mine = next((e for e in report.ltl if e["name"] == entry["name"]), None)
    if mine is None:
        report.ltl.append(entry)
    else:
        for key in ("episodes", "satisfied", "violations"):
            mine[key] += entry[key]


def ltl_formulas(shield: Shield, formulas: Sequence[str] = (), assertions: bool = False
                 ) -> list[tuple]:
    """(name, text, parsed formula) for ``--ltl`` formulas and, with ``assertions``, the
    shield machine's ``ASSERT_LTL`` definitions (parse errors located in the formula)."""
    from .crashflag import flagged
    from .ltl import assertions as machine_assertions
    from .ltl import parse_ltl

    machine = flagged(shield.machine)  # the recorded crash flag is in scope too
    out = []
    if assertions:
        found = machine_assertions(shield.machine)
        if not found:
            raise InputError(f"the shield {shield.name} has no ASSERT_LTL definitions",
                             hint="give formulas with --ltl FORMULA")
        for name, text in found.items():
            out.append((name, text, parse_ltl(text, machine, where=name)))
    for i, text in enumerate(formulas):
        name = f"--ltl {i + 1}" if len(formulas) > 1 else "--ltl"
        out.append((name, text, parse_ltl(text, machine, where=name)))
    return out


@dataclass(frozen=True)
class _FileChecks:
    """What replay found in each row of one file, for its episodes to pick from."""

    ops: tuple[str, ...]
    enabled: np.ndarray  # (rows, operations): which operations the shield enables
    feasible: np.ndarray  # whether the row's recorded action was enabled in the row before
    deadlock: np.ndarray
    invariant_ok: np.ndarray
    postcondition_bad: np.ndarray
    #: by row, the infeasible steps of continuous actions
    margins: dict[int, _Margin] = field(default_factory=dict)
    #: the operations a row of ``enabled`` allows, by name (one list per pattern)
    names: Optional[EnabledNames] = None


def _largest_margins(cols: RunColumns, margins: dict) -> dict[int, float]:
    """By episode index, the largest margin of its infeasible continuous steps (one pass
    over the margins: a scan per episode costs episodes × margins)."""
    largest: dict[int, float] = {}
    for r, m in margins.items():
        if m.margin is not None:
            i = int(np.searchsorted(cols.starts, r, side="right")) - 1
            largest[i] = max(largest.get(i, m.margin), m.margin)
    return largest


def _episode(cols: RunColumns, checks: _FileChecks, ep: int, lo: int, hi: int,
             largest: Optional[float] = None) -> EpisodeReplay:
    """Episode ``ep`` of ``cols``, rows ``lo`` (its initial state) to ``hi`` (excluded)."""
    bad_steps = np.flatnonzero(~checks.feasible[lo + 1:hi]) + 1
    first = int(bad_steps[0]) if len(bad_steps) else None
    action = enabled = alternative = None
    if first is not None:
        action = cols.action_names[cols.action[lo + first]]
        enabled = checks.names(checks.enabled[lo + first - 1])
        if cols.values is not None:
            q = cols.values[lo + first]  # the values that chose this step's action
            scored = [(q[cols.action_names.index(o)], o) for o in enabled
                      if o in cols.action_names and not np.isnan(q[cols.action_names.index(o)])]
            alternative = max(scored)[1] if scored else None
    crashes = np.flatnonzero(cols.crashed[lo:hi])
    crash_step = int(crashes[0]) if len(crashes) else None
    at = checks.margins.get(lo + first) if first is not None else None
    return EpisodeReplay(
        file=cols.path, episode=ep, steps=hi - lo - 1, first_infeasible=first, action=action,
        enabled=enabled, alternative=alternative, infeasible_steps=len(bad_steps),
        crashed=crash_step is not None, crash_step=crash_step,
        crash_after_infeasible=crash_step is not None and first is not None
        and crash_step >= first,
        deadlock_states=shared(np.flatnonzero(checks.deadlock[lo:hi]).tolist()),
        postcondition_violations=shared(np.flatnonzero(checks.postcondition_bad[lo:hi]).tolist()),
        invariant_violations=shared(np.flatnonzero(~checks.invariant_ok[lo:hi]).tolist()),
        max_margin=largest,
        **({} if at is None else dict(parameters=at.point, allowed=at.allowed,
                                      margin=at.margin, margin_note=at.note)),
    )


def replay_columns(cols: RunColumns, shield: Shield, ltl: Sequence[str] = (),
                   ltl_assertions: bool = False) -> ReplayReport:
    """Replay the already-read columns of one file (``cols.path``) against ``shield``, with
    the LTL formulas as :func:`replay`: for a caller that has the columns for more than
    replay (the report's statistics), so the file is read once."""
    return _replay_blocks(cols.path, [cols], shield, ltl_formulas(shield, ltl, ltl_assertions))


def _replay_blocks(path: str, blocks: Iterable[RunColumns], shield: Shield,
                   parsed: Sequence[tuple] = ()) -> ReplayReport:
    """The blocks of one file replayed, one after the other, with the formulas already
    parsed (:func:`ltl_formulas`)."""
    report = ReplayReport(shield=shield.identity, files=[path])
    for cols in blocks:
        report.warnings += cols.warnings
        _replay_file(shield, cols, report, parsed)
    add_up(report, report.per_episode, _EPISODE_COUNTS)
    return report


def _replay_one(path: str, shield: Shield, parsed: Sequence[tuple] = (),
                salvage: bool = False, block=None) -> ReplayReport:
    """One file (or one block of it), block by block, in whichever process runs it (the
    shield itself is sent there: pickled as its text, see :class:`Shield`; the parsed
    formulas as their dataclasses)."""
    return _replay_blocks(path, read_blocks(path, salvage=salvage, block=block), shield,
                          parsed)


def replay(paths: Iterable[str | Path], shield: Shield, *, executor: str = "local",
           ray_address: Optional[str] = None, ltl: Sequence[str] = (),
           ltl_assertions: bool = False, salvage: bool = False,
           workers: int = 1) -> ReplayReport:
    """Replay every episode of the files against ``shield`` (see the module docstring).

    Each file is read a block of episodes at a time (memory is set by the block, not the
    file).

    Args:
        paths: run files (MCAP).
        shield: the shield (:func:`~tracecheck.checking.shield.load_shield`).
        executor: ``local``, or ``ray`` (each block in a Ray task at ``ray_address``).
        workers: with ``local``, how many processes replay the blocks (the same report).
        ltl: LTL formulas to check on every episode (:mod:`tracecheck.checking.ltl`).
        ltl_assertions: also check the machine's ``ASSERT_LTL`` definitions.
        salvage: as :func:`~tracecheck.episodes.reader.read_run`.

    Returns:
        The :class:`ReplayReport`: per episode the first step the shield would have blocked.

    >>> from tracecheck.checking.shield import load_shield
    >>> replay(["sample_traces/base_none.mcap"], load_shield("paper")).episodes  # repo root
    24
    """
    paths = [str(p) for p in paths]
    report = ReplayReport(shield=shield.identity, files=paths)
    parsed = tuple(ltl_formulas(shield, ltl, ltl_assertions))  # errors before any file is read
    start = time.perf_counter()
    for _, part in map_file_blocks(_replay_one,
                                   lambda _, p, block: (p, shield, parsed, salvage, block), paths,
                                   executor, ray_address, workers):
        report.per_episode += part.per_episode
        report.warnings += part.warnings
        for entry in part.ltl:
            _add_ltl(report, entry)
    report.elapsed_s = round(time.perf_counter() - start, 6)
    add_up(report, report.per_episode, _EPISODE_COUNTS)
    return report


#: each count of a replay report: what one episode adds to it
_EPISODE_COUNTS: dict[str, Callable[[EpisodeReplay], int]] = {
    "episodes": lambda e: 1,
    "steps": lambda e: e.steps,
    "feasible_episodes": lambda e: e.first_infeasible is None,
    "infeasible_episodes": lambda e: e.first_infeasible is not None,
    "infeasible_steps": lambda e: e.infeasible_steps,
    "crashes": lambda e: e.crashed,
    "crashes_after_infeasible": lambda e: e.crash_after_infeasible,
    "deadlock_states": lambda e: len(e.deadlock_states),
    "postcondition_violations": lambda e: len(e.postcondition_violations),
    "invariant_violations": lambda e: len(e.invariant_violations),
}


def add_up(report, parts: Sequence, counts: dict[str, Callable]) -> None:
    """Each count of ``report`` (replay's, diff's) as the sum over its ``parts`` (episodes,
    files) of what ``counts[name]`` says one part adds: a total is never kept by hand."""
    if isinstance(parts, EpisodeRows):
        parts = parts.records()  # what is counted does not depend on an episode's id
    totals = dict.fromkeys(counts, 0)
    for part in parts:
        for name, count in counts.items():
            totals[name] += int(count(part))
    for name, total in totals.items():
        setattr(report, name, total)
