"""Repair a shield gap (``tracecheck repair``): the smallest change of one number of the shield
that blocks the action that sealed a crash the shield did not prevent.

The crash is an episode of a run that crashed with no blocked step at or before it (what
``replay`` calls a crash not after a blocked step); the step to block is the one ``falsify``
attributed it to (a *shield gap*: the action there sealed the failure), the one the user names
with ``--step``, or else the crash step's own action. For each number the guard of that
action reads (those named, or every numeric constant and definition and each number written
in the guard), the values for which
the guard still allows the action in the state before are found exactly
(:mod:`tracecheck.b.threshold`); the nearest value outside them — the float nearest, decided
by the engine's own evaluation — is the smallest change that blocks it. The smallest of those
over the numbers is the repair; what it costs is what ``diff`` of the repaired machine against
the original finds on the recordings (steps newly blocked and allowed). A number no value of
which blocks the action (or only values outside what the PROPERTIES allow) is said to be
unable to close the gap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Optional, Sequence

from ..b.memo import MEMO_KEY
from ..b.threshold import ThresholdCompiler, Values
from ..checking.shield import Shield
from ..episodes.columns import RunColumns, read_columns
from ..episodes.reader import read_run
from ..errors import InputError, TracecheckError, UnsupportedError
from .tune_target import (Target, check_range, literal_specs, numeric_names,
                          resolve_target)

__all__ = ["Gap", "Candidate", "RepairResult", "find_gap", "repair"]

#: how many floats past an open end are tried before a value is given up as not blocking
_ULPS = 64


@dataclass(frozen=True)
class Gap:
    """The step to block: episode ``episode`` of ``path``, its step ``step`` (the action
    ``action`` taken in the state before it), and why that step (``reason``)."""

    path: str
    episode: int
    step: int
    action: str
    crash_step: int
    reason: str


@dataclass(frozen=True)
class Candidate:
    """One number and what it can do: ``value`` (None: it cannot close the gap, ``why``)."""

    label: str
    current: float
    value: Optional[float]
    why: str = ""

    @property
    def change(self) -> Optional[float]:
        """The change relative to the current value (absolute where that is 0)."""
        if self.value is None:
            return None
        return abs(self.value - self.current) / (abs(self.current) or 1.0)


@dataclass
class RepairResult:
    """What :func:`repair` found and did."""

    shield: dict
    gap: Gap
    candidates: list[Candidate] = field(default_factory=list)
    chosen: Optional[Candidate] = None
    output: Optional[str] = None
    newly_blocked: Optional[int] = None
    newly_allowed: Optional[int] = None
    episodes_changed: Optional[int] = None
    deadlock_free: dict = field(default_factory=dict)  # "original"/"repaired" -> status
    symbolic: list[dict] = field(default_factory=list)  # per operation: status, detail


def find_gap(paths: Sequence[str], shield: Shield, episode: Optional[int] = None,
             step: Optional[int] = None) -> Gap:
    """The crash to close and the step whose action to block (see the module docstring)."""
    from ..checking.replaying import replay

    report = replay(paths, shield)
    gaps = [e for e in report.per_episode if e.crashed and not e.crash_after_infeasible]
    if episode is not None:
        found = [e for e in report.per_episode if e.episode == episode]
        if not found:
            raise InputError(f"no episode {episode} in {', '.join(paths)}")
        e = found[0]
        if not e.crashed:
            raise InputError(f"episode {episode} did not crash: there is no gap to close",
                             hint=_listing(gaps))
        if e.crash_after_infeasible:
            raise InputError(f"episode {episode}: the shield already blocks step "
                             f"{e.first_infeasible} ({e.action}), before its crash at step "
                             f"{e.crash_step}: nothing to repair", hint=_listing(gaps))
    elif not gaps:
        raise InputError("no episode crashed with the shield allowing every step before: no "
                         "gap to close", hint="falsify finds such episodes")
    else:
        e = gaps[0]
    cols = read_columns(e.file)
    i = int(list(cols.episode_ids).index(e.episode))
    lo = int(cols.starts[i])
    attributed = _attributed(e.file, e.episode)
    if step is not None:
        if not 1 <= step <= e.crash_step:
            raise InputError(f"--step {step}: episode {e.episode} crashed at step "
                             f"{e.crash_step}; give a step from 1 to it")
        k, reason = step, "the step given (--step)"
    elif attributed is not None:
        k, reason = attributed, "the step falsify's attribution says sealed the crash"
    else:
        k, reason = e.crash_step, ("the crash step's own action (no attribution recorded: "
                                   "falsify --attribute finds the action that sealed it)")
    action = cols.action_names[cols.action[lo + k]]
    return Gap(e.file, e.episode, k, action, e.crash_step, reason)


def _listing(gaps) -> str:
    if not gaps:
        return "no episode of these runs crashed with every step before allowed"
    return "episodes that did: " + ", ".join(str(e.episode) for e in gaps[:10])


def _attributed(path: str, episode: int) -> Optional[int]:
    ep = read_run(path, only={episode}).episodes[0]
    search = ep.search
    if search is not None and search.attribution == "shield gap":
        return search.attribution_step
    return None


def blocking_value(shield: Shield, target: Target, gap: Gap, cols: RunColumns) -> Candidate:
    """The value of ``target`` nearest its current one for which the guard of the gap's
    action does not allow it in the state before the step (see the module docstring)."""
    machine = shield.machine
    current = float(target.value)
    guard = target.guards.get(gap.action)
    if guard is None:
        return Candidate(target.label, current, None, f"the guard of {gap.action} does not "
                         "read it")
    i = int(list(cols.episode_ids).index(gap.episode))
    r = int(cols.starts[i]) + gap.step
    env = machine.env(cols.states.row(r - 1))
    params = tuple(machine.operations[gap.action].params)
    for p in params:
        env[p] = float(cols.parameters[p][r])
    try:
        allowed = ThresholdCompiler(machine, target.name, params, target.integer).pred(guard)(env)
    except UnsupportedError as exc:
        return Candidate(target.label, current, None, exc.message)
    comp = machine.compiler()
    with comp.binding(params + (target.name,)):
        plain = comp.compile(guard)

    def blocks(v: float) -> bool:
        local = dict(env)
        local.pop(MEMO_KEY, None)
        local[target.name] = int(v) if target.integer else v
        return not plain(local)

    if blocks(current):
        return Candidate(target.label, current, current, "it blocks the action already")
    found = _nearest(allowed.complement(), current, target.integer, blocks)
    if found is None:
        return Candidate(target.label, current, None, f"no value of it blocks {gap.action} "
                         "there")
    return Candidate(target.label, current, found)


def _nearest(blocked: Values, current: float, integer: bool, blocks) -> Optional[float]:
    """The float (or integer) nearest ``current`` that ``blocks``, in the interval of
    ``blocked`` whose end is nearest it (see :func:`_first_blocking`)."""
    best: Optional[float] = None
    if blocked.contains(current):  # blocked over the reals, allowed by the float evaluation
        for toward in (-math.inf, math.inf):
            v = _first_blocking(current, None, toward, integer, blocks, current)
            if v is not None and (best is None or abs(v - current) < abs(best - current)):
                best = v
    for lo, hi, lc, hc in blocked.intervals():
        for end, closed, other, toward in ((hi, hc, lo, -math.inf), (lo, lc, hi, math.inf)):
            if end is None or (toward < 0) != (end < current):
                continue  # only the ends that face the current value
            v = _first_blocking(_float_at(end, closed, toward, integer), other, toward,
                                integer, blocks, current)
            if v is not None and (best is None or abs(v - current) < abs(best - current)):
                best = v
    return best


def _first_blocking(v: float, other, toward: float, integer: bool, blocks,
                    current: float) -> Optional[float]:
    """From ``v`` (the end of a blocking interval over the reals that faces ``current``,
    which the guard allows), the float nearest ``current`` the engine's own float evaluation
    blocks at. Its rounding can move the end either way (``s + θ`` rounds to ``s`` for a
    tiny θ): steps double inward from ``v`` until one blocks (never past the interval's
    other end), then the floats between ``current`` and that one are bisected."""
    limit = None if other is None else float(other)
    step, trial = (1.0 if integer else max(abs(v), 1.0) * 2.0 ** -52), v
    for _ in range(_ULPS + 60):
        if blocks(trial):
            break
        trial = v + step if toward > 0 else v - step
        if limit is not None and (trial - limit) * (1 if toward > 0 else -1) >= 0:
            return None
        step *= 2
    else:
        return None
    allowed = current  # the guard allows the action at the current value (checked)
    if integer:
        while abs(trial - allowed) > 1:
            mid = float(math.floor((allowed + trial) / 2)) if toward > 0 else \
                float(math.ceil((allowed + trial) / 2))
            allowed, trial = (allowed, mid) if blocks(mid) else (mid, trial)
        return trial
    for _ in range(2200):  # the floats between the allowed and the blocking one, halved
        mid = (allowed + trial) / 2
        if mid in (allowed, trial):
            break
        allowed, trial = (allowed, mid) if blocks(mid) else (mid, trial)
    return trial


def _float_at(end: Fraction, closed: bool, toward: float, integer: bool) -> float:
    """The float (integer) at ``end``, or next to it inside the interval (``toward`` its
    inside) where ``end`` itself is not in it."""
    if integer:
        v = math.floor(end) if toward < 0 else math.ceil(end)
        if not closed and v == end:
            v += -1 if toward < 0 else 1
        return float(v)
    v = float(end)
    inside = (lambda x: x <= end) if toward < 0 else (lambda x: x >= end)
    while not inside(Fraction(v)) or (not closed and Fraction(v) == end):
        v = math.nextafter(v, toward)
    return v


def repair(paths: Sequence[str], shield: Shield, gap: Gap, *, names: Sequence[str] = (),
           literals: Sequence[str] = (), output: Optional[Path] = None,
           timeout_s: float = 10.0) -> RepairResult:
    """The smallest change that blocks ``gap``'s step over the numbers named (every numeric
    constant and definition, and every number written in the action's guard, when none),
    written to ``output`` and checked (see the module
    docstring)."""
    machine = shield.machine
    result = RepairResult(shield.identity, gap)
    cols = read_columns(gap.path)
    specs = [("param", n) for n in names] + [("literal", s) for s in literals]
    if not specs:  # every number the guard reads: constants, definitions, the numbers in it
        specs = [("param", n) for n in numeric_names(machine)] + \
            [("literal", s) for s in literal_specs(machine, gap.action)]
    seen: set = set()
    for kind, spec in specs:
        try:
            target = resolve_target(machine, **{kind: spec})
        except InputError:
            if names or literals:
                raise
            continue  # not one the guard reads: no candidate
        if target.span in seen:
            continue  # a definition's number, named both ways: once
        seen.add(target.span)
        if not (names or literals) and gap.action not in target.guards:
            continue  # of all the numbers, only those the action's guard reads
        cand = blocking_value(shield, target, gap, cols)
        if cand.value is not None and cand.value != cand.current:
            try:
                check_range(machine, target, min(cand.value, cand.current),
                            max(cand.value, cand.current))
            except InputError as exc:
                cand = Candidate(cand.label, cand.current, None, exc.message)
        result.candidates.append(cand)
        if cand.value is not None and (result.chosen is None or cand.change < result.chosen.change):
            result.chosen, chosen_target = cand, target
    if result.chosen is None or result.chosen.value == result.chosen.current:
        return result
    _apply(paths, shield, chosen_target, result, output, timeout_s)
    return result


def _confirm(fixed: Shield, gap: Gap) -> None:
    """Replay of the repaired machine must block the gap's step (else tracecheck's exact
    answer and its evaluator disagree: nothing is written)."""
    from ..checking.replaying import replay
    from ..errors import Disagreement

    found = [e for e in replay([gap.path], fixed).per_episode if e.episode == gap.episode]
    if not found or found[0].first_infeasible is None or found[0].first_infeasible > gap.step:
        raise Disagreement(f"the repaired machine does not block {gap.action} at step "
                           f"{gap.step} of episode {gap.episode} when replayed: tracecheck's "
                           "exact sets and its evaluator disagree (a bug); nothing was written")


def _apply(paths, shield: Shield, target: Target, result: RepairResult,
           output: Optional[Path], timeout_s: float) -> None:
    from ..checking.diffing import diff
    from ..checking.proving import prove, symbolic_diff
    from ..outputs import atomic_file
    from .tuning import shield_with

    fixed = shield_with(shield, target, result.chosen.value)
    _confirm(fixed, result.gap)
    report = diff(paths, fixed, shield)
    result.newly_blocked, result.newly_allowed = report.newly_blocked, report.newly_allowed
    result.episodes_changed = report.episodes_changed
    if output is not None:
        with atomic_file(Path(output)) as stream:
            stream.write(fixed.machine.source.encode("utf-8"))
        result.output = str(output)
    for name, m in (("original", shield.machine), ("repaired", fixed.machine)):
        try:
            result.deadlock_free[name] = prove(m, deadlock_free=True, timeout_s=timeout_s)[0].status
        except TracecheckError as exc:
            result.deadlock_free[name] = f"unknown: {exc.message}"
    try:
        found = symbolic_diff(fixed.machine, shield.machine, timeout_s=timeout_s,
                              labels=("repaired", "original"))
        result.symbolic = [{"operation": r.obligation, "status": r.status,
                            "detail": (r.reason or "")[:300]} for r in found]
    except TracecheckError as exc:
        result.symbolic = [{"operation": "*", "status": "unknown", "detail": exc.message}]
