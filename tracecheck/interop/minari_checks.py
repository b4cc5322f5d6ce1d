"""What a Minari dataset's episodes must be before ``import minari`` reads them: observations
in the dataset's observation space, tracecheck's own infos well-formed, declared counts equal
to what is there (:mod:`tracecheck.interop.minari_import` calls these).

Each refusal is an :class:`~tracecheck.errors.InputError` naming the dataset, the episode and
the step, info key or metadata field — never a value cut to fit: an observation 0.5 of a
``Discrete(64)`` space would be cell 0, a short ``infos/allowed`` would lose the shield's
decisions that replay reads exactly.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import InputError

__all__ = ["check_observations", "check_infos", "check_counts", "check_episode_steps"]

#: the infos tracecheck's export writes, and the ones import reads back
SHIELD_INFOS = ("allowed", "intervened", "deadlock", "preferred", "action_values", "b_state",
                "crashed")


# ------------------------------------------------------------------ observations


def check_observations(observations, space, n: int, where: str) -> None:
    """Every one of the ``n + 1`` observations is in ``space`` (vectorised for Discrete,
    Box, MultiDiscrete and MultiBinary; Dict and Tuple part by part; others one by one with
    ``space.contains``)."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        if not isinstance(observations, dict) or set(observations) != set(space.spaces):
            raise InputError(f"{where}: the observations are not the dataset's Dict space's "
                             f"parts ({', '.join(space.spaces)})")
        for key, sub in space.spaces.items():
            check_observations(observations[key], sub, n, f"{where}, observation part {key}")
        return
    if isinstance(space, spaces.Tuple):
        if not isinstance(observations, (tuple, list)) or len(observations) != len(space):
            raise InputError(f"{where}: the observations are not the dataset's Tuple space's "
                             f"{len(space)} parts")
        for i, sub in enumerate(space.spaces):
            check_observations(observations[i], sub, n, f"{where}, observation part {i}")
        return
    if isinstance(space, (spaces.Discrete, spaces.Box, spaces.MultiDiscrete,
                          spaces.MultiBinary)):
        _check_array(np.asarray(observations), space, n, where)
        return
    for k in range(n + 1):
        if not space.contains(observations[k]):
            raise InputError(f"{where}, step {k}: the observation is not in the dataset's "
                             f"observation space {space}")


def _check_array(obs: np.ndarray, space, n: int, where: str) -> None:
    from gymnasium import spaces

    shape = (n + 1, *space.shape)
    if obs.shape != shape:
        raise InputError(f"{where}: the observations have shape {obs.shape}, not {shape} (one "
                         f"per step, each of the dataset's observation space {space})")
    if obs.dtype.kind not in "biuf":
        raise InputError(f"{where}: the observations are {obs.dtype} values, not numbers of "
                         f"the dataset's observation space {space}")
    rows = obs.reshape(n + 1, -1)
    integral = not isinstance(space, spaces.Box) or np.dtype(space.dtype).kind in "biu"
    if integral:
        whole = np.all(rows == np.floor(rows), axis=1) if obs.dtype.kind == "f" else \
            np.ones(n + 1, dtype=bool)
        _first(~whole, rows, where, f"is not an integer, as the dataset's {space} needs")
    if isinstance(space, spaces.Discrete):
        lo, hi = int(space.start), int(space.start) + int(space.n) - 1
        _first(~((rows >= lo) & (rows <= hi)).all(axis=1), rows, where,
               f"is not one of the dataset's {space} ({lo} … {hi})")
    elif isinstance(space, spaces.MultiDiscrete):
        start = np.asarray(getattr(space, "start", 0)).reshape(-1)
        top = start + np.asarray(space.nvec).reshape(-1) - 1
        _first(~((rows >= start) & (rows <= top)).all(axis=1), rows, where,
               f"is out of the dataset's {space}")
    elif isinstance(space, spaces.MultiBinary):
        _first(~np.isin(rows, (0, 1)).all(axis=1), rows, where, f"is not 0/1, as the "
               f"dataset's {space} needs")
    else:
        low, high = space.low.reshape(1, -1), space.high.reshape(1, -1)
        with np.errstate(invalid="ignore"):
            inside = ((rows >= low) & (rows <= high)).all(axis=1)
        _first(~inside, rows, where, f"is out of the bounds of the dataset's {space}")


def _first(bad: np.ndarray, rows: np.ndarray, where: str, what: str) -> None:
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        shown = rows[k].tolist()
        shown = shown[0] if len(shown) == 1 else shown
        raise InputError(f"{where}, step {k}: the observation {str(shown)[:120]} {what}")


# ------------------------------------------------------------------ infos


def check_infos(infos, n: int, actions: int, where: str) -> None:
    """tracecheck's infos (:data:`SHIELD_INFOS`), where a dataset has them, are what its
    export writes: one entry per observation (``n + 1``); ``allowed`` true/false per action,
    ``action_values`` one number (or NaN: not recorded) per action, ``preferred`` an action
    index or -1, ``deadlock`` and ``intervened`` true/false."""
    if not isinstance(infos, dict):
        return
    for key, width, kinds, what in (
            ("allowed", actions, "b", "true/false"),
            ("action_values", actions, "f", "numbers"),
            ("preferred", None, "iu", "action indices"),
            ("deadlock", None, "b", "true/false"),
            ("intervened", None, "b", "true/false"),
            ("b_state", None, "OSU", "texts"),
            ("crashed", None, "b", "true/false")):
        if key not in infos:
            continue
        value = np.asarray(infos[key])
        want = (n + 1,) if width is None else (n + 1, width)
        label = f"{where}: its infos/{key}"
        if value.shape != want:
            per = "" if width is None else f" × {width} (one column per action)"
            raise InputError(f"{label} has shape {value.shape}; tracecheck's infos have one "
                             f"row per observation: {n + 1}{per}")
        if value.dtype.kind not in kinds:
            raise InputError(f"{label} holds {value.dtype} values, not {what}")
        if key == "preferred":
            bad = np.flatnonzero((value < -1) | (value >= actions))
            if bad.size:
                raise InputError(f"{label}, step {int(bad[0])}: {int(value[bad[0]])} is not an "
                                 f"action index (0 … {actions - 1}) or -1 (none recorded)")
        if key == "action_values":
            known = np.isfinite(value)
            bad = np.flatnonzero(np.isinf(value).any(axis=1) |
                                 (known.any(axis=1) & ~known.all(axis=1)))
            if bad.size:
                raise InputError(f"{label}, step {int(bad[0])}: the values "
                                 f"{value[bad[0]].tolist()} are neither all numbers nor all "
                                 "NaN (not recorded)")


# ------------------------------------------------------------------ declared counts

_EPISODE = re.compile(r"episode_(\d+)")


def check_episode_steps(group, where: str) -> int:
    """The steps of an episode group (its rewards); its ``total_steps`` attribute, where it
    has one, must say the same."""
    steps = int(group["rewards"].shape[0])
    declared = group.attrs.get("total_steps")
    if declared is not None:
        if isinstance(declared, np.ndarray) and declared.shape == ():
            declared = declared[()]
        if isinstance(declared, (bool, np.bool_)) or not isinstance(declared,
                                                                    (int, np.integer)):
            raise InputError(f"{where}: its total_steps attribute is {str(declared)[:40]!r}, "
                             "not a number of steps")
        if int(declared) != steps:
            raise InputError(f"{where}: its total_steps attribute says {int(declared)}, it "
                             f"holds {steps} step(s)")
    return steps


def check_counts(file, meta: dict, steps: int, dataset_id: str) -> None:
    """The metadata's ``total_episodes`` and ``total_steps`` are what the data file holds
    (more episode groups than declared would be left out without a word)."""
    groups = sorted(int(m.group(1)) for k in file if (m := _EPISODE.fullmatch(k)))
    total = meta["total_episodes"]
    if len(groups) != total:
        raise InputError(f"{dataset_id}: the metadata field total_episodes says {total}, the "
                         f"data file holds {len(groups)} episode group(s) (episode_"
                         f"{groups[0]} … episode_{groups[-1]})" if groups else
                         f"{dataset_id}: the metadata field total_episodes says {total}, the "
                         "data file holds no episode group")
    if meta["total_steps"] != steps:
        raise InputError(f"{dataset_id}: the metadata field total_steps says "
                         f"{meta['total_steps']}, the episodes hold {steps} step(s)")
