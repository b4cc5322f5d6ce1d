"""Statistics of a run's continuous actions: how often, how far and how the shield moved them.

For a run whose actions are operations with REAL parameters (see
:mod:`tracecheck.live.continuous`), per step, over the steps that recorded what it needs:

``interventions``
    the share of steps whose executed values differ from the agent's proposal (a parameter
    whose recorded values differ; read from the columns ``par:P`` and ``prop:P``);
``projection_distance``
    the mean and the largest distance the shield moved a proposal (the column ``dist``), over
    all steps and over the steps it intervened in;
``boundary``
    the share of steps whose executed value lies on an end of an allowed interval that the
    shield's guard draws — within :data:`TOLERANCE` of it, relative to the end's magnitude
    (at least that much absolutely, so an end at 0 counts). An end that is a bound of the
    action space itself (the run header's ``action_low``/``action_high``) is not counted: an
    agent that asks for full throttle where everything is allowed is at the space's edge,
    not pressed against the shield;
``fallback``
    the share of steps where the shield confirmed no action and took the fallback (the
    step's ``deadlock``).

The shares come with a 95 % interval of the method asked for (Wilson by default) that treats
the steps as independent trials, which steps of one episode are not: read them as a
description of the recorded steps more than as an estimate for new episodes (the per-episode
``interventions`` metric is that).

The allowed intervals and the deadlock flag are in the step messages, not in the columns, so
the boundary and fallback shares decode a continuous run's steps once (a discrete run is
never decoded here).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from .levels import CONFIDENCE
from ..episodes.columns import RunColumns
from ..episodes.model import Episode

__all__ = ["ContinuousSteps", "TOLERANCE", "INTERVALS", "interventions", "continuous_steps",
           "read_continuous_steps", "continuous_summary"]

#: how near an end of an allowed interval an executed value is "on the boundary" (relative):
#: the live shield sends the value in the action space's float type that the guard allows,
#: up to 64 float32 steps (64 × 2⁻²³ ≈ 7.6e-6, relative) inside the exact end it recorded
TOLERANCE = 1e-5


@dataclass
class ContinuousSteps:
    """Per row of a run's columns, what the continuous statistics count (rows that recorded
    none of it, step 0 among them, are False in every mask)."""

    parameters: tuple[str, ...]
    acted: np.ndarray  # the row has an executed continuous action
    judged: np.ndarray  # … and the agent's proposal for each of its parameters
    intervened: np.ndarray  # … which the shield changed
    distance: np.ndarray  # the projection distance (NaN where none was recorded)
    bounded: np.ndarray  # the row's allowed intervals were recorded
    boundary: np.ndarray  # … and an executed value lies on a shield's end of them
    decided: np.ndarray  # the row is a step, decoded (so ``fallback`` is known): of a
    #                      hybrid space's operations without parameters too
    fallback: np.ndarray  # the shield took the fallback (deadlock)


def joined_steps(parts: list[ContinuousSteps]) -> Optional[ContinuousSteps]:
    """The :class:`ContinuousSteps` of a file's blocks, one after the other (None: none)."""
    if not parts:
        return None
    names = tuple(sorted({p for part in parts for p in part.parameters}))
    return ContinuousSteps(names, *(np.concatenate([getattr(part, f.name) for part in parts])
                                    for f in fields(ContinuousSteps)[1:]))


def _executed(cols: RunColumns) -> np.ndarray:
    """Per row and parameter (in ``sorted(cols.parameters)`` order): the executed values."""
    names = sorted(cols.parameters)
    return np.column_stack([cols.parameters[p] for p in names]) if names \
        else np.zeros((cols.n, 0))


def interventions(cols: RunColumns) -> tuple[np.ndarray, np.ndarray]:
    """(judged, intervened) per row: the row has the agent's proposal (values of an
    operation's parameters, which only a live recording keeps, or for a hybrid space the
    agent's score of every operation); some executed value differs from it, or the executed
    operation is another (a hybrid space's: other parameters, or not the best-scored one).

    >>> import numpy as np
    >>> from types import SimpleNamespace as S
    >>> cols = S(n=3, parameters={"a": np.array([np.nan, 1.0, 0.5])},
    ...          proposals={"a": np.array([np.nan, 1.0, 2.0])})
    >>> [m.tolist() for m in interventions(cols)]
    [[False, True, True], [False, False, True]]
    >>> hybrid = S(n=2, parameters={"a": np.array([np.nan, 1.0]), "b": np.array([2.0, np.nan])},
    ...            proposals={"a": np.array([1.0, 1.0])})
    >>> [m.tolist() for m in interventions(hybrid)]
    [[True, True], [True, False]]
    """
    names = sorted(set(cols.parameters) | set(cols.proposals))
    executed = np.column_stack([cols.parameters.get(p, np.full(cols.n, np.nan))
                                for p in names]) if names else np.zeros((cols.n, 0))
    proposed = np.column_stack([cols.proposals.get(p, np.full(cols.n, np.nan))
                                for p in names]) if names else np.zeros((cols.n, 0))
    has, asked = np.isfinite(executed), np.isfinite(proposed)
    judged = np.any(asked, axis=1)
    intervened = judged & np.any((has != asked) | (has & (executed != proposed)), axis=1)
    scores = getattr(cols, "values", None)
    if scores is not None and cols.n:  # a hybrid space: the operation the agent scored best
        scored = np.all(np.isfinite(scores), axis=1) & (cols.action >= 0)
        rows = np.flatnonzero(scored)
        taken = np.zeros(cols.n)
        taken[rows] = scores[rows, cols.action[rows]]
        best = np.max(np.where(np.isfinite(scores), scores, -np.inf), axis=1)
        intervened = intervened | (scored & (taken < best))  # a tie with the best is none
        judged = judged | scored
    return judged, intervened


def _rows(cols: RunColumns, episodes: Iterable[Episode]) -> Iterable[tuple[int, Episode]]:
    """(first row, episode) of each episode whose rows are in ``cols`` (matched by id and
    number of states)."""
    first = {int(e): (int(a), int(b - a)) for e, a, b in
             zip(cols.episode_ids, cols.starts[:-1], cols.starts[1:])}
    for ep in episodes:
        start, length = first.get(int(ep.id), (None, None))
        if start is not None and length == len(ep.steps):
            yield start, ep


def continuous_steps(cols: RunColumns, episodes: Iterable[Episode], header=None
                     ) -> Optional[ContinuousSteps]:
    """The per-row masks of :class:`ContinuousSteps` from a run's columns and its decoded
    ``episodes`` (their allowed intervals and deadlock flags; ``header``: the run header,
    whose action space bounds are not shield ends); None for a run without continuous
    actions (one whose steps all took operations without parameters is one, where its
    header declares parameters or it kept a proposal)."""
    if not (cols.parameters or cols.proposals or getattr(header, "action_parameters", None)):
        return None
    names = tuple(sorted(cols.parameters))
    index = {p: j for j, p in enumerate(names)}
    executed = _executed(cols)
    judged, intervened = interventions(cols)
    bounded, decided, fallback = (np.zeros(cols.n, dtype=bool) for _ in range(3))
    rows, params, ends = [], [], []  # every finite end of every recorded interval
    for start, ep in _rows(cols, episodes):
        for k, step in enumerate(ep.steps):
            r = start + k
            decided[r] = True
            fallback[r] = bool(step.deadlock)
            if step.allowed_intervals is None:
                continue
            bounded[r] = True
            for name, intervals in step.allowed_intervals.items():
                for interval in intervals if name in index else ():
                    for end in interval:
                        if end is not None:
                            rows.append(r)
                            params.append(index[name])
                            ends.append(end)
    acted = np.any(np.isfinite(executed), axis=1)
    bounded &= acted
    boundary = np.zeros(cols.n, dtype=bool)
    if ends:
        rows_a, params_a, ends_a = np.array(rows), np.array(params), np.array(ends, dtype=float)
        near = _near(executed[rows_a, params_a], ends_a)
        near &= ~_space_bound(ends_a, params_a, names, header)
        boundary[rows_a[near]] = True
    distance = cols.distance if cols.distance is not None else np.full(cols.n, np.nan)
    return ContinuousSteps(names, acted, judged, intervened, np.asarray(distance, dtype=float),
                           bounded, boundary & bounded, decided & (cols.step > 0),
                           fallback & (cols.step > 0))


def _near(values: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Each value within :data:`TOLERANCE` of its end, relative to the end's magnitude and
    at least that much absolutely (a value that is not a number is near nothing)."""
    with np.errstate(invalid="ignore"):
        return np.abs(values - ends) <= TOLERANCE * np.maximum(np.abs(ends), 1.0)


def _space_bound(ends: np.ndarray, params: np.ndarray, names: tuple[str, ...],
                 header) -> np.ndarray:
    """Which ends are a bound of the action space (the header's, by parameter name; a null
    bound is none)."""
    out = np.zeros(len(ends), dtype=bool)
    declared = getattr(header, "action_parameters", None) or {}
    low, high = getattr(header, "action_low", None), getattr(header, "action_high", None)
    offset = 0  # the bounds list each operation's components in turn
    for order in declared.values():
        for component, name in enumerate(order, start=offset):
            if name not in names:
                continue
            mine = params == names.index(name)
            for bounds in (low, high):  # a bound may be null: the space has none there
                if bounds is not None and component < len(bounds) \
                        and bounds[component] is not None:
                    out |= mine & _near(ends, np.full(len(ends), float(bounds[component])))
        offset += len(order)
    return out


def read_continuous_steps(path: str | Path, cols: RunColumns, *, salvage: bool = False
                          ) -> Optional[ContinuousSteps]:
    """:func:`continuous_steps` of a run file (its steps decoded, only when ``cols`` has
    continuous actions; the damage ``cols`` was read with is not warned about again)."""
    from ..errors import DamagedEpisode
    from ..episodes.reader import read_episodes, read_header

    header = read_header(path)
    if not (cols.parameters or cols.proposals or header.action_parameters):
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DamagedEpisode)
        return continuous_steps(cols, read_episodes(path, salvage=salvage), header)


#: the interval methods: tracecheck's names (``stats --interval``) -> scipy's
INTERVALS = {"wilson": "wilson", "clopper-pearson": "exact"}


def _share(count: int, steps: int, interval: str) -> dict:
    """``count`` of ``steps`` with a 95 % interval by ``interval`` (``wilson``,
    ``clopper-pearson``); no ratio and no interval (None) without steps."""
    from scipy import stats

    out = {"count": count, "steps": steps, "ratio": None, "ci95": None, "method": interval}
    if steps:
        ci = stats.binomtest(count, steps).proportion_ci(confidence_level=CONFIDENCE,
                                                         method=INTERVALS[interval])
        out.update(ratio=count / steps, ci95=[float(ci.low), float(ci.high)])
    return out


def _spread(values: np.ndarray) -> dict:
    """Mean and largest of the finite ``values``, and how many there are (None without)."""
    values = values[np.isfinite(values)]
    if not len(values):
        return {"mean": None, "max": None, "steps": 0}
    return {"mean": float(np.mean(values)), "max": float(np.max(values)),
            "steps": int(len(values))}


def continuous_summary(steps: ContinuousSteps, interval: str = "wilson") -> dict:
    """The statistics of :class:`ContinuousSteps` as JSON-ready data (see the module
    docstring; ``interval``: the method of the shares' intervals, as ``stats --interval``)."""
    distance = _spread(steps.distance[steps.acted])
    distance["intervened"] = _spread(steps.distance[steps.intervened])
    return {
        "parameters": list(steps.parameters),
        "steps": int(np.count_nonzero(steps.acted)),
        "interventions": _share(int(np.count_nonzero(steps.intervened)),
                                int(np.count_nonzero(steps.judged)), interval),
        "projection_distance": distance,
        "boundary": {**_share(int(np.count_nonzero(steps.boundary)),
                              int(np.count_nonzero(steps.bounded)), interval),
                     "tolerance": TOLERANCE},
        "fallback": _share(int(np.count_nonzero(steps.fallback)),
                           int(np.count_nonzero(steps.decided)), interval),
        "note": "shares of steps; the intervals treat the steps as independent trials",
    }
