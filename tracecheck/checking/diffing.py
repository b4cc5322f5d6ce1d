"""Diff two shields on the same recorded episodes: which steps does a change of shield block
or allow?

Both shields are evaluated on every recorded state (over the numpy columns of each file at
once, as :mod:`.replay` does); a step is *changed* when its recorded action is enabled under
one shield and not under the other, and an episode is *changed* when its first step that
one of them would have blocked moves.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from operator import attrgetter
from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from ..episodes.columns import RunColumns, read_columns
from .executors import map_files
from .replaying import add_up, check_parameters, enabled_matrix
from .shield import Shield

__all__ = ["diff", "DiffReport", "ChangedStep"]


@dataclass(frozen=True)
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
    elapsed_s: float = 0.0
    changes: list[ChangedStep] = field(default_factory=list)
    changed_episodes: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def anything_changed(self) -> bool:
        return bool(self.changed_steps or self.enabled_set_changes)

    def to_json(self) -> dict:
        return asdict(self)


#: each count of a diff report: the sum of the counts of its files
_FILE_COUNTS = {name: attrgetter(name) for name in (
    "episodes", "steps", "states", "changed_steps", "newly_blocked", "newly_allowed",
    "enabled_set_changes", "episodes_changed", "crashes_in_changed_episodes")}


def diff(paths: Iterable[str | Path], shield: Shield, against: Shield, *,
         executor: str = "local", ray_address: Optional[str] = None,
         salvage: bool = False) -> DiffReport:
    """Evaluate both shields on every recorded state and report what changes from
    ``against`` (the old version, or the baseline) to ``shield``; with
    ``executor="ray"`` each file in a Ray task; ``salvage``: as
    :func:`~tracecheck.episodes.reader.read_run`."""
    paths = [str(p) for p in paths]
    report = DiffReport(shield=shield.identity, against=against.identity, files=paths)
    start = time.perf_counter()
    parts = map_files(_diff_one, [(p, shield, against, salvage) for p in paths], executor,
                      ray_address)
    for part in parts:
        report.changes += part.changes
        report.changed_episodes += part.changed_episodes
        report.warnings += part.warnings
    add_up(report, parts, _FILE_COUNTS)
    report.elapsed_s = round(time.perf_counter() - start, 6)
    return report


def _diff_one(path: str, a: Shield, b: Shield, salvage: bool = False) -> DiffReport:
    """One file's diff, in whichever process runs it (both shields sent there themselves)."""
    report = DiffReport(shield=a.identity, against=b.identity, files=[path])
    cols = read_columns(path, salvage=salvage)
    report.warnings += cols.warnings
    _diff_file(cols, a, b, report)
    return report


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


def _diff_file(cols: RunColumns, a: Shield, b: Shield, report: DiffReport) -> None:
    names = tuple(dict.fromkeys(list(a.machine.operations) + list(b.machine.operations)))
    ma, mb = _aligned(a, cols, names), _aligned(b, cols, names)
    rows = np.flatnonzero(cols.step > 0)
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
    for i in np.flatnonzero(changed):
        r = rows[i]
        report.changes.append(ChangedStep(
            file=cols.path, episode=int(cols.episode[r]), step=int(cols.step[r]),
            action=cols.action_names[cols.action[r]], feasible_under_shield=bool(fa[i]),
            feasible_under_against=bool(fb[i]),
            enabled_shield=[n for n, ok in zip(names, ma[r - 1]) if ok],
            enabled_against=[n for n, ok in zip(names, mb[r - 1]) if ok]))
    first_a = _first_false(cols, rows, fa)
    first_b = _first_false(cols, rows, fb)
    for i, ep in enumerate(cols.episode_ids):
        if first_a[i] != first_b[i]:
            lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
            crashed = bool(cols.crashed[lo:hi].any())
            report.episodes_changed += 1
            report.crashes_in_changed_episodes += crashed
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
