"""Diff two shields on the same recorded episodes: which steps does a change of shield block
or allow?

Both shields are evaluated on every recorded state (over the numpy columns of each file at
once, as :mod:`.replay` does); a step is *changed* when its recorded action is enabled under
one shield and not under the other, and an episode is *changed* when its first step that
one of them would have blocked moves.

A changed step of a continuous action (an operation with REAL parameters) also carries its
recorded values and, for the first :data:`DETAILS` of them, the values each shield allowed
in the state before (:meth:`~tracecheck.b.machine.Machine.allowed`) and, for one parameter, how
the allowed interval moved from ``against`` to ``shield``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from fractions import Fraction
from operator import attrgetter
from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from ..b.linear import Interval, real_parameters
from ..episodes.columns import RunColumns, read_blocks
from ..errors import UnsupportedError
from .executors import map_file_blocks
from .shared import EnabledNames
from .fit import check_actions
from .replaying import add_up, check_parameters, enabled_matrix
from .shield import Shield
from ..jsontext import plain

__all__ = ["diff", "DiffReport", "ChangedStep", "AllowedValues", "AllowedChange", "DETAILS"]

#: how many changed steps of continuous actions get the allowed sets of both shields (the
#: first ones, in the order of the files and their steps); the rest only their values
DETAILS = 100
#: how many changed steps (and changed episodes) a diff lists unless told otherwise
LISTED = 10_000


@dataclass(frozen=True)
class AllowedValues:
    """What one shield allowed of a continuous action in the state before a step."""

    #: the allowed set in words (``a ∈ [-4.0, 0.5)``; an end followed by ``…`` is not
    #: exactly a float, the nearest float is shown); None where it was not computed
    text: Optional[str]
    #: per parameter the ``[low, high]`` pairs allowed (None: an unbounded end; open and
    #: closed ends alike, as the files record them), where the set is a product of
    #: intervals (one parameter, or one box); None otherwise
    intervals: Optional[dict[str, list[list[Optional[float]]]]] = None
    #: why ``text`` is None (the guard not linear in the parameters, no such operation)
    note: Optional[str] = None


@dataclass(frozen=True)
class AllowedChange:
    """The allowed values of a changed continuous step under both shields."""

    shield: AllowedValues
    against: AllowedValues
    #: one parameter, both computed: how its interval moved from ``against`` to ``shield``
    #: (``upper end +0.75``)
    moved: Optional[str] = None


@dataclass(frozen=True, slots=True)  # slots: a campaign has 10^6 of them
class ChangedStep:
    """A step whose recorded action one shield enables and the other does not."""

    file: str
    episode: int
    step: int
    action: str
    feasible_under_shield: bool
    feasible_under_against: bool
    enabled_shield: list[str]
    enabled_against: list[str]
    #: a continuous action: the recorded parameter values, by name
    parameters: Optional[dict[str, float]] = None
    #: … and what each shield allowed there (None beyond the first :data:`DETAILS`)
    allowed: Optional[AllowedChange] = None


@dataclass
class DiffReport:
    """What changes from ``against`` (the old shield, or the baseline) to ``shield``."""

    shield: dict
    against: dict
    files: list[str]
    episodes: int = 0
    steps: int = 0
    states: int = 0
    changed_steps: int = 0
    newly_blocked: int = 0
    newly_allowed: int = 0
    enabled_set_changes: int = 0
    episodes_changed: int = 0
    crashes_in_changed_episodes: int = 0
    #: how many changed continuous steps get the allowed sets of both shields (the first)…
    details: int = DETAILS
    #: … and how many more there were, whose allowed sets were not computed
    details_left_out: int = 0
    #: how many changed steps and changed episodes are listed (the first ones; None: all) …
    listed: Optional[int] = LISTED
    #: … and how many more there were, counted but not listed
    changes_left_out: int = 0
    episodes_left_out: int = 0
    elapsed_s: float = 0.0
    changes: list[ChangedStep] = field(default_factory=list)
    changed_episodes: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def anything_changed(self) -> bool:
        return bool(self.changed_steps or self.enabled_set_changes)

    def to_json(self) -> dict:
        return plain(self)


#: each count of a diff report: the sum of the counts of its files
_FILE_COUNTS = {name: attrgetter(name) for name in (
    "episodes", "steps", "states", "changed_steps", "newly_blocked", "newly_allowed",
    "enabled_set_changes", "episodes_changed", "crashes_in_changed_episodes",
    "details_left_out", "changes_left_out", "episodes_left_out")}


def diff(paths: Iterable[str | Path], shield: Shield, against: Shield, *,
         executor: str = "local", ray_address: Optional[str] = None,
         salvage: bool = False, details: int = DETAILS,
         listed: Optional[int] = LISTED, workers: int = 1) -> DiffReport:
    """Evaluate both shields on every recorded state and report what changes from ``against``
    (the old version, or the baseline) to ``shield``.

    Args:
        paths: run files.
        shield: the new shield.
        against: the shield it is compared with.
        executor: ``local``, or ``ray`` (each block of a file in a Ray task at
            ``ray_address``; locally a file is read a block at a time all the same).
        workers: with ``local``, how many processes diff the blocks (the same report).
        salvage: as :func:`~tracecheck.episodes.reader.read_run`.
        details: how many changed steps of continuous actions get both shields' allowed sets.
        listed: how many changed steps and episodes the report lists (the others counted;
            None: all).

    Returns:
        The :class:`DiffReport`.

    >>> from tracecheck.checking.shield import load_shield
    >>> d = diff(["sample_traces/base_none.mcap"], load_shield("strict"), load_shield("paper"))
    >>> d.episodes  # repo root
    24
    """
    paths = [str(p) for p in paths]
    report = DiffReport(shield=shield.identity, against=against.identity, files=paths,
                        details=details, listed=listed)
    start = time.perf_counter()
    parts = [part for _, part in map_file_blocks(
        _diff_one, lambda _, p, block: (p, shield, against, salvage, details, block, listed),
        paths, executor, ray_address, workers)]
    trimmed = [0, 0, 0]
    for part in parts:
        report.changes += part.changes
        report.changed_episodes += part.changed_episodes
        report.warnings += part.warnings
        trimmed = [t + n for t, n in zip(trimmed, _keep_listed(report))]
    add_up(report, parts, _FILE_COUNTS)
    report.changes_left_out += trimmed[0]
    report.episodes_left_out += trimmed[1]
    report.details_left_out -= trimmed[2]  # counted by their part, now not listed at all
    _keep_details(report, details)
    report.elapsed_s = round(time.perf_counter() - start, 6)
    return report


def _diff_one(path: str, a: Shield, b: Shield, salvage: bool = False,
              details: int = DETAILS, block=None,
              listed: Optional[int] = LISTED) -> DiffReport:
    """One file's diff (or one block's), block by block, in whichever process runs it (both
    shields sent there themselves)."""
    report = DiffReport(shield=a.identity, against=b.identity, files=[path], details=details,
                        listed=listed)
    for cols in read_blocks(path, salvage=salvage, block=block):
        report.warnings += cols.warnings
        done = sum(c.allowed is not None for c in report.changes)
        _diff_file(cols, a, b, report, max(details - done, 0))
    return report


def _keep_listed(report: DiffReport) -> tuple[int, int, int]:
    """Only the first ``report.listed`` changed steps and changed episodes: how many of each
    were left out here, and how many of the steps left out were counted as having their
    values only (``details_left_out``: they are not listed at all now)."""
    out = []
    values_only = 0
    for items in (report.changes, report.changed_episodes):
        extra = 0 if report.listed is None else max(len(items) - report.listed, 0)
        if items is report.changes:
            values_only = sum(c.parameters is not None and c.allowed is None
                              for c in items[len(items) - extra:])
        del items[len(items) - extra:]
        out.append(extra)
    return out[0], out[1], values_only


def _keep_details(report: DiffReport, details: int) -> None:
    """The allowed sets of the first ``details`` changed continuous steps over all files
    (each file computed up to ``details`` of its own), the others left out and counted."""
    kept = 0
    for i, c in enumerate(report.changes):
        if c.allowed is not None:
            kept += 1
            if kept > details:
                report.changes[i] = replace(c, allowed=None)
                report.details_left_out += 1


def _aligned(shield: Shield, cols: RunColumns, names: tuple[str, ...]) -> np.ndarray:
    matrix, ops = enabled_matrix(shield, cols)
    index = {o: i for i, o in enumerate(ops)}
    out = np.zeros((cols.n, len(names)), dtype=bool)
    for j, name in enumerate(names):
        if name in index:
            out[:, j] = matrix[:, index[name]]
    return out


def _with_parameters(shield: Shield, cols: RunColumns, rows: np.ndarray, ok: np.ndarray
                     ) -> np.ndarray:
    """``ok`` (per step row) with the steps of continuous actions decided as replay decides
    them: the guard with the recorded parameter values."""
    full = np.ones(cols.n, dtype=bool)
    full[rows] = ok
    check_parameters(shield, cols, rows, cols.action[rows], full, margins=False)
    return full[rows]


def _diff_file(cols: RunColumns, a: Shield, b: Shield, report: DiffReport,
               details: int = DETAILS) -> None:
    names = tuple(dict.fromkeys(list(a.machine.operations) + list(b.machine.operations)))
    rows = np.flatnonzero(cols.step > 0)
    for shield in (a, b):  # as replay: an action one of them cannot take is no "change"
        check_actions(shield, cols, rows, cols.action[rows])
    ma, mb = _aligned(a, cols, names), _aligned(b, cols, names)
    col = {n: j for j, n in enumerate(names)}
    to_col = np.array([col.get(x, -1) for x in cols.action_names] + [-1], dtype=np.int64)
    acts = to_col[cols.action[rows]]
    known = acts >= 0
    fa = np.ones(len(rows), dtype=bool)
    fb = np.ones(len(rows), dtype=bool)
    fa[known] = ma[rows[known] - 1, acts[known]]
    fb[known] = mb[rows[known] - 1, acts[known]]
    fa, fb = _with_parameters(a, cols, rows, fa), _with_parameters(b, cols, rows, fb)
    changed = fa != fb
    report.episodes += len(cols.episode_ids)
    report.steps += len(rows)
    report.states += cols.n
    report.changed_steps += int(changed.sum())
    report.newly_blocked += int((fb & ~fa).sum())
    report.newly_allowed += int((fa & ~fb).sum())
    report.enabled_set_changes += int(np.any(ma != mb, axis=1).sum())
    enabled = EnabledNames(names)  # a campaign has 10^5 changed steps: names by pattern
    params = {action: _parameter_names(cols, a, b, action) for action in cols.action_names}
    changed_at = np.flatnonzero(changed).tolist()
    if report.listed is not None:  # the first ones listed, the others counted
        room = max(report.listed - len(report.changes), 0)
        report.changes_left_out += max(len(changed_at) - room, 0)
        changed_at = changed_at[:room]
    for i in changed_at:
        r = int(rows[i])
        action = cols.action_names[cols.action[r]]
        parameters = None if params[action] is None else \
            {p: float(cols.parameters[p][r]) for p in params[action]}
        allowed = None
        if parameters is not None:
            if details > 0:
                details -= 1
                allowed = _allowed_change(a, b, action, cols.states.row(r - 1))
            else:
                report.details_left_out += 1
        report.changes.append(ChangedStep(
            file=cols.path, episode=int(cols.episode[r]), step=int(cols.step[r]),
            action=action, feasible_under_shield=bool(fa[i]),
            feasible_under_against=bool(fb[i]),
            enabled_shield=enabled(ma[r - 1]), enabled_against=enabled(mb[r - 1]),
            parameters=parameters, allowed=allowed))
    first_a = _first_false(cols, rows, fa)
    first_b = _first_false(cols, rows, fb)
    for i, ep in enumerate(cols.episode_ids):
        if first_a[i] != first_b[i]:
            lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
            crashed = bool(cols.crashed[lo:hi].any())
            report.episodes_changed += 1
            report.crashes_in_changed_episodes += crashed
            if report.listed is not None and len(report.changed_episodes) >= report.listed:
                report.episodes_left_out += 1
                continue
            report.changed_episodes.append({
                "file": cols.path, "episode": int(ep), "crashed": crashed,
                "first_infeasible_shield": first_a[i], "first_infeasible_against": first_b[i]})


def _first_false(cols: RunColumns, rows: np.ndarray, ok: np.ndarray) -> list[Optional[int]]:
    out: list[Optional[int]] = []
    episode_of_row = np.searchsorted(cols.starts, rows, side="right") - 1
    firsts: dict[int, int] = {}
    for i in np.flatnonzero(~ok):
        e = int(episode_of_row[i])
        firsts.setdefault(e, int(cols.step[rows[i]]))
    for e in range(len(cols.episode_ids)):
        out.append(firsts.get(e))
    return out


def _parameter_names(cols: RunColumns, a: Shield, b: Shield, action: str
                     ) -> Optional[tuple[str, ...]]:
    """The parameters whose recorded values a step of ``action`` shows, if either shield
    has it as an operation with REAL parameters (a continuous action); else None."""
    for shield in (a, b):
        op = shield.machine.operations.get(action)
        if op is not None and real_parameters(op) and \
                all(p in cols.parameters for p in op.params):
            return tuple(op.params)
    return None


def _allowed_change(a: Shield, b: Shield, action: str, state: dict) -> AllowedChange:
    """What ``a`` and ``b`` allow of ``action`` in ``state``, and how it moved from ``b``'s
    to ``a``'s (one parameter)."""
    new, new_intervals = _allowed_values(a, action, state)
    old, old_intervals = _allowed_values(b, action, state)
    moved = None
    if new_intervals is not None and old_intervals is not None:
        moved = _moved(old_intervals, new_intervals)
    return AllowedChange(new, old, moved)


def _allowed_values(shield: Shield, action: str, state: dict
                    ) -> tuple[AllowedValues, Optional[tuple[Interval, ...]]]:
    """(what ``shield`` allows of ``action`` in ``state``, its exact intervals where it has
    one parameter); where the set cannot be computed, the reason instead."""
    if action not in shield.machine.operations:
        return AllowedValues(None, note=f"not computed: {shield.name} has no operation "
                                        f"{action}"), None
    try:
        allowed = shield.machine.allowed(action, state)  # the solver's, where not linear
        text, bands = str(allowed), allowed.bands()
    except UnsupportedError as exc:
        return AllowedValues(None, note=f"not computed: {exc.message}"), None
    pairs = None if bands is None else {
        p: [[_end(i.low), _end(i.high)] for i in found] for p, found in bands.items()}
    return AllowedValues(text, pairs), allowed.intervals


def _end(x: Optional[Fraction]) -> Optional[float]:
    return None if x is None else float(x)


def _moved(old: tuple[Interval, ...], new: tuple[Interval, ...]) -> str:
    """How one parameter's allowed intervals moved from ``old`` to ``new``, in words: each
    end of the whole (its lowest and highest) that moved, by how much (exactly, then
    rounded); how many intervals, where that changed."""
    if not old or not new:
        return ("nothing allowed under either" if not old and not new else
                "nothing was allowed" if not old else "nothing is allowed now")
    said = []
    for word, was, now, was_open, now_open in (
            ("lower", old[0].low, new[0].low, old[0].low_open, new[0].low_open),
            ("upper", old[-1].high, new[-1].high, old[-1].high_open, new[-1].high_open)):
        if was == now:
            if now is not None and was_open != now_open:
                said.append(f"{word} end now {'open' if now_open else 'closed'}")
        elif now is None:
            said.append(f"{word} end now unbounded")
        elif was is None:
            said.append(f"{word} end now {float(now):.6g}")
        else:
            said.append(f"{word} end {float(now - was):+.6g}")
    if len(old) != len(new):
        said.append(f"{len(old)} interval(s) → {len(new)}")
    if said:
        return ", ".join(said)
    return ("unchanged over the reals (the guard's float arithmetic decides the step)"
            if old == new else "the same ends, the gaps between them moved")
