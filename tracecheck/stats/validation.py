"""A validation campaign in one call: each run replayed against a shield (and re-simulated
where asked), and the statistics of all runs — what ``tracecheck report`` draws.

The pipeline is here, in the library; :func:`tracecheck.render.report.render_report` only
draws a :class:`Validation`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

from ..errors import InputError

__all__ = ["CheckedRun", "Validation", "validate"]


@dataclass(frozen=True)
class CheckedRun:
    """One run: its file, its header, its replay against the shield (None without one)
    and what re-simulation found (None when not asked)."""

    file: str
    header: Any
    replay: Any = None
    resimulation: Optional[dict] = None


@dataclass(frozen=True)
class Validation:
    """Every run checked, and their statistics (:func:`~tracecheck.stats.estimates.statistics`)."""

    runs: tuple[Path, ...]
    shield: Any
    pset: Any
    checked: tuple[CheckedRun, ...]
    statistics: dict
    resimulated: bool


def validate(runs: Sequence[str | Path], *, shield, pset, resimulate: bool = False,
             agent: Optional[Path] = None, env: Optional[str] = None, adapter=None,
             salvage: bool = False) -> Validation:
    """Replay each run against ``shield``, re-simulate its blocked episodes (with
    ``resimulate``), and compute the statistics of ``pset`` — each run's columns read once.

    Args:
        runs: the run files.
        shield: the shield to replay against (None: no replay).
        pset: the property set of the statistics.
        resimulate: re-run the episodes the shield would have blocked, under it.
        agent: for ``resimulate``, the agent (None: the one each run names).
        env: for ``resimulate``, the environment (None: the one each run names).
        adapter: the runs' environment adapter, where the user gave it.
        salvage: as :func:`~tracecheck.episodes.reader.read_run`.

    Returns:
        The :class:`Validation`.

    Raises:
        InputError: a run file missing or without a complete episode; ``resimulate``
            without a shield.
    """
    from ..checking.replaying import replay_columns
    from ..episodes.columns import read_columns
    from ..episodes.reader import read_header
    from .estimates import statistics

    if resimulate and shield is None:
        raise InputError("--resimulate needs --shield: the shield to re-simulate under")
    columns = []
    for run in runs:
        if not Path(run).exists():
            raise InputError(f"no such file: {run}")
        columns.append(read_columns(run, salvage=salvage))  # read once: statistics take them
        if not len(columns[-1].episode_ids):
            raise InputError(f"{run} holds no complete episode: nothing to report")
    checked = []
    for run, cols in zip(runs, columns):
        replayed = resimulation = None
        if shield is not None:
            replayed = replay_columns(cols, shield)
            if resimulate:
                from ..live.resimulate import resimulate as again, summary

                resimulation = summary(again(run, shield, replayed, agent=agent, env=env,
                                             cols=cols))
                # the replay's table shows what re-simulation found
                replayed = dataclasses.replace(replayed, resimulation=resimulation)
        checked.append(CheckedRun(str(run), read_header(run), replayed, resimulation))
    result = statistics(list(runs), pset, columns=columns, adapter=adapter, salvage=salvage)
    return Validation(tuple(Path(r) for r in runs), shield, pset, tuple(checked), result,
                      resimulate)
