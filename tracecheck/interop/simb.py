"""SimB timed-simulation traces (``Timed_Simulation_N.json``), read and written.

A trace is a JSON object whose ``activations`` run ``$setup_constants``,
``$initialise_machine`` and then one operation each; ``fixedVariables`` holds the state after
it as B literals and ``after`` the delay before it in milliseconds.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from pathlib import Path
from typing import Any, Iterable, Optional, Sequence

from .. import __version__
from ..b.values import format_value
from ..episodes.model import Episode
from ..episodes.vocabulary import Vocabulary
from ..errors import InputError, printable
from .common import (INIT, SETUP, build_episode, check_setup_constants, check_types,
                     expand_paths, load_json, read_literal, refuse_continuous, refuse_lossy)

__all__ = ["import_simb", "read_simb", "export_simb", "simb_document"]


def read_simb(path: Path, episode_id: int, vocab: Vocabulary,
              machine=None, *, constants: bool = True) -> Episode:
    """One SimB trace file as an episode (``constants``: refuse a ``$setup_constants``
    that gives ``machine``'s constants other values; a project's task leaves that to
    ProB2-UI's rules)."""
    data = load_json(path)
    where = f"{path}"
    if not isinstance(data, dict) or not isinstance(data.get("activations"), list):
        raise InputError(f"{where}: not a SimB timed trace (no 'activations' list)")
    items: list[tuple[Optional[str], dict, float]] = []
    clock = 0.0
    for i, act in enumerate(data["activations"]):
        here = f"{where}, activation {i}"
        if not isinstance(act, dict):
            raise InputError(f"{here}: an activation must be a JSON object")
        op = act.get("execute")
        clock += _delay_s(act.get("after"), here)
        fixed = act.get("fixedVariables")
        if op == SETUP:
            if constants:
                check_setup_constants(machine, fixed, here)
            continue
        if op != INIT and not items and not fixed:
            continue
        if not isinstance(fixed, dict):
            raise InputError(f"{here} ({op}): no state ('fixedVariables')")
        step = len(items)
        state = {name: read_literal(text, f"{where}, step {step}, variable {name}")
                 for name, text in fixed.items()}
        if op == INIT:
            if items:
                raise InputError(f"{here}: {INIT} after the trace has started")
            clock = 0.0
        elif not items:
            raise InputError(f"{here}: the trace does not start with {INIT}")
        items.append((None if op == INIT else op, state, round(clock, 9)))
    ending = _ending_time(data.get("metadata"))
    reason = None
    if items and ending is not None and items[-1][2] >= ending - 1e-9:
        reason = "time-limit"
    episode = build_episode(episode_id, str(path), items, vocab, where, reason)
    if episode.end.crashed:
        episode = build_episode(episode_id, str(path), items, vocab, where, "crashed")
    check_types(machine, episode, where)
    return episode


def _ending_time(metadata) -> Optional[float]:
    creator = (metadata or {}).get("creator") if isinstance(metadata, dict) else None
    m = re.search(r"ENDING_TIME\s*:\s*(\d+)", creator or "")
    return int(m.group(1)) / 1000.0 if m else None


def import_simb(paths: Iterable[str | Path], *, vocab: Vocabulary,
                machine=None, first_id: int = 0) -> Iterable[Episode]:
    """Episodes from SimB trace files and folders of them (``Timed_Simulation_*.json``)."""
    for k, path in enumerate(expand_paths(paths, "*.json")):
        yield read_simb(path, first_id + k, vocab, machine)


def simb_document(episode: Episode, model_name: str) -> dict:
    """A SimB timed trace of ``episode``, as ProB writes them."""
    acts = [_activation("$setup_constants", "$setup_constants", 0, None, None)]
    ids = [f"{s.action}_{s.step + 1}" for s in episode.steps[1:]]
    acts.append(_activation("$initialise_machine", "$initialise_machine", 0,
                            episode.steps[0].state, ids[:1] or None))
    prev_t = episode.steps[0].time
    for k, s in enumerate(episode.steps[1:]):
        delay = int(round((s.time - prev_t) * 1000))
        prev_t = s.time
        acts.append(_activation(ids[k], s.action, delay, s.state, ids[k + 1:k + 2] or None))
    # ENDING_TIME says the simulation ran until its clock reached it: written only for an
    # episode that ended by its time limit (a crash read back as one was a wrong answer)
    ending = (f"; ENDING_TIME : {int(round(episode.steps[-1].time * 1000))}"
              if episode.end.reason == "time-limit" else "")
    return {
        "variables": {},
        "activations": acts,
        "listeners": [],
        "metadata": {
            "fileType": "Timed_Trace",
            "formatVersion": 3,
            "savedAt": _dt.datetime.now(_dt.timezone.utc).isoformat().replace("+00:00", "Z"),
            "creator": f"tracecheck {__version__}{ending}",
            "modelName": model_name,
        },
    }


#: The longest delay between two activations tracecheck reads: a year, in ms.
MAX_DELAY_MS = 365 * 24 * 3600 * 1000


def _delay_s(after: Any, here: str) -> float:
    """The delay ``after`` (ms, a number or a decimal text) in seconds."""
    try:
        if isinstance(after, bool):
            raise TypeError
        ms = float(after or 0)
    except (TypeError, ValueError):
        ms = math.nan
    if not 0 <= ms <= MAX_DELAY_MS:  # NaN fails this too
        raise InputError(f"{here}: 'after' must be a delay in ms between 0 and {MAX_DELAY_MS} "
                         f"(a year), not {printable(repr(after))[:40]}")
    return ms / 1000.0


def _activation(act_id, op, after_ms, state, activating):
    return {
        "id": act_id, "execute": op, "after": str(after_ms), "priority": 0,
        "additionalGuards": None, "activationKind": None,
        "fixedVariables": None if state is None else {k: format_value(v)
                                                      for k, v in state.items()},
        "probabilisticVariables": None, "activating": activating,
        "activatingOnlyWhenExecuted": True, "updating": None, "withPredicate": None,
    }


#: What ``export simb`` writes into its folder (``--force`` replaces only such a folder).
SIMB_FILES = ("Timed_Simulation_*.json",)


def check_simb_folder(folder: str | Path, inputs: Sequence[Path] = (), *,
                      force: bool = False) -> Path:
    """The output rule (:mod:`tracecheck.outputs`) for a folder of SimB traces: a new or
    empty folder, or with ``force`` one that holds only SimB traces; none of ``inputs``."""
    from ..outputs import check_output

    return check_output(Path(folder), inputs, force=force, kind="folder", contents=SIMB_FILES)


def export_simb(episodes: Iterable[Episode], folder: str | Path,
                model_name: str, *, force: bool = False,
                inputs: Sequence[Path] = (), lossy: bool = False) -> list[Path]:
    """Write one ``Timed_Simulation_N.json`` per episode (N from 1) into ``folder``.

    The traces go into a new folder beside it, which replaces ``folder`` once every trace
    is written: an error leaves an existing folder as it was (see :func:`check_simb_folder`
    for which folders may be replaced). What a timed trace has no place for (a crash
    without a ``Crash`` variable, rewards, a continuous action's values) is refused, unless
    ``lossy`` (:func:`~tracecheck.interop.common.lossy` says what is left out).
    """
    from ..outputs import atomic_folder, inside, open_new
    from ..jsontext import json_text

    folder = check_simb_folder(folder, inputs, force=force)
    episodes = list(episodes)
    refuse_continuous(episodes, "a SimB timed trace")
    refuse_lossy(episodes, "a SimB timed trace", allow=lossy)
    names = []
    with atomic_folder(folder) as tmp:
        for n, episode in enumerate(episodes, start=1):
            name = f"Timed_Simulation_{n}.json"
            with open_new(inside(tmp, name)) as stream:
                stream.write(json_text(simb_document(episode, model_name), indent=2,
                                        ensure_ascii=False).encode("utf-8"))
            names.append(name)
    return [folder / name for name in names]
