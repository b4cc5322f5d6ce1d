"""ProB2 trace files (``.prob2trace``), read and written.

A trace is a JSON object whose ``transitionList`` starts with ``$setup_constants`` and
``$initialise_machine``; each transition's ``destState`` holds only the variables that
changed, the others carry over. ProB traces have no clock: tracecheck puts the paper's one
second between steps.
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path
from typing import Iterable, Optional, Sequence

from .. import __version__
from ..b.linear import real_parameters
from ..b.values import format_value
from ..episodes.model import Episode
from ..episodes.vocabulary import Vocabulary
from ..errors import InputError
from .common import (INIT, SETUP, build_episode, check_setup_constants, check_types,
                     expand_paths, load_json, read_literal, state_changes)

__all__ = ["import_prob2trace", "read_prob2trace", "export_prob2trace", "prob2trace_document"]

STEP_SECONDS = 1.0


def read_prob2trace(path: Path, episode_id: int, vocab: Vocabulary,
                    machine=None, step_seconds: float = STEP_SECONDS, *,
                    constants: bool = True) -> Episode:
    """One ProB2 trace file as an episode (``constants``: refuse a ``$setup_constants``
    that gives ``machine``'s constants other values; a project's task judges that itself)."""
    data = load_json(path)
    where = str(path)
    if not isinstance(data, dict) or not isinstance(data.get("transitionList"), list):
        raise InputError(f"{where}: not a ProB trace (no 'transitionList')")
    items: list[tuple[Optional[str], dict, float]] = []
    state: dict = {}
    for i, transition in enumerate(data["transitionList"]):
        here = f"{where}, transition {i}"
        if not isinstance(transition, dict) or "name" not in transition:
            raise InputError(f"{here}: a transition is a JSON object with a 'name'")
        op = transition["name"]
        dest = transition.get("destState") or {}
        if not isinstance(dest, dict):
            raise InputError(f"{here} ({op}): 'destState' must be a JSON object")
        if op == SETUP:
            if constants:
                check_setup_constants(machine, dest, here)
            continue
        step = len(items)
        if op != INIT and not items:
            raise InputError(f"{here}: the trace does not start with {INIT}")
        if op == INIT and items:
            raise InputError(f"{here}: {INIT} after the trace has started")
        state = dict(state)
        for name, text in dest.items():
            state[name] = read_literal(text, f"{where}, step {step}, variable {name}")
        items.append((None if op == INIT else op, state, step * step_seconds,
                      _parameters(transition.get("params"), f"{where}, step {step}", op,
                                  machine)))
    episode = build_episode(episode_id, where, items, vocab, where)
    check_types(machine, episode, where)
    return episode


def _parameters(params, where: str, op: str, machine=None) -> Optional[dict]:
    """A transition's parameters as a continuous action's values (all of them real numbers,
    of an operation whose parameters are all REAL). A run keeps no other parameter values,
    so a trace that gives some (``Jump(n)`` with ``n = 7``), gives parameters the machine's
    operation does not have, or lacks some it has, is refused: replay could not judge that
    step by what the trace did."""
    if params is not None and not isinstance(params, dict):
        raise InputError(f"{where}: 'params' must be a JSON object")
    given = {str(name): read_literal(text, f"{where}, parameter {name}")
             for name, text in (params or {}).items()}
    declared = machine.operations[op].params if machine is not None and \
        op in machine.operations else None
    if declared is not None and set(given) != set(declared):
        raise InputError(f"{where}: {op} takes "
                         f"{', '.join(declared) or 'no parameters'}; the trace gives "
                         f"{', '.join(given) or 'none'}")
    if not given:
        return None
    if declared is not None and not real_parameters(machine.operations[op]) or \
            any(type(v) is not float for v in given.values()):
        shown = ", ".join(f"{n} = {format_value(v)}" for n, v in given.items())
        raise InputError(f"{where}: {op}({shown}): a run keeps the values of REAL "
                         "parameters only (a continuous action's), so replay could not "
                         "judge this step",
                         hint=f"give each such choice an operation of its own ({op}_1, "
                              f"{op}_2, …), or type the parameters REAL")
    return given


def import_prob2trace(paths: Iterable[str | Path], *, vocab: Vocabulary,
                      machine=None, first_id: int = 0) -> Iterable[Episode]:
    """Episodes from ``.prob2trace`` files (and folders of them)."""
    for k, path in enumerate(expand_paths(paths, "*.prob2trace")):
        yield read_prob2trace(path, first_id + k, vocab, machine)


def prob2trace_document(episode: Episode, vocab: Vocabulary) -> dict:
    """A ProB2 trace of ``episode``, in the format ProB2-UI writes (format version 5)."""
    transitions = [_transition(SETUP, {}, [])]
    prev: dict = {}
    for s in episode.steps:
        changed = state_changes(prev, s.state)
        same = [k for k in s.state if k not in changed]
        transitions.append(_transition(s.action or INIT, {k: format_value(v)
                                                          for k, v in changed.items()}, same,
                                       {p: format_value(v)
                                        for p, v in (s.parameters or {}).items()}))
        prev = dict(s.state)
    variables = sorted(episode.steps[0].state)
    used = sorted({s.action for s in episode.steps[1:]})
    return {
        "description": f"episode {episode.id} exported by tracecheck {__version__}",
        "transitionList": transitions,
        "variableNames": variables,
        "constantNames": [],
        "setNames": [vocab.set_name] if vocab.set_name else [],
        "machineOperationInfos": {op: _operation_info(op, variables, _names(episode, op))
                                  for op in used},
        "globalIdentifierTypes": {},
        "metadata": {
            "fileType": "Trace",
            "formatVersion": 5,
            "savedAt": _dt.datetime.now(_dt.timezone.utc).isoformat().replace("+00:00", "Z"),
            "creator": f"tracecheck {__version__}",
            "modelName": vocab.name,
        },
    }


def _transition(name, dest, same, params=None):
    return {"name": name, "params": params or {}, "results": {}, "destState": dest,
            "destStateNotChanged": same, "preds": [], "postconditions": [], "description": ""}


def _names(episode: Episode, op: str) -> list[str]:
    """The parameter names of ``op`` in ``episode`` (a continuous action's)."""
    return list(next((s.parameters for s in episode.steps if s.action == op and s.parameters),
                     {}))


def _operation_info(op, variables, parameters):
    return {"operationName": op, "parameterNames": parameters, "outputParameterNames": [],
            "topLevel": True, "type": "CLASSICAL_B", "readVariables": [],
            "writtenVariables": variables, "nonDetWrittenVariables": variables}


def export_prob2trace(episode: Episode, path: str | Path, vocab: Vocabulary, *,
                      force: bool = False, inputs: Sequence[Path] = (),
                      lossy: bool = False) -> Path:
    """Write ``episode`` as a ``.prob2trace`` file, by the output rule
    (:mod:`tracecheck.outputs`): not one of ``inputs``, an existing file only with
    ``force``, renamed into place once complete. What a ProB trace has no place for (a
    crash without a ``Crash`` variable, rewards, proposals) is refused, unless ``lossy``."""
    from ..outputs import check_output, write_file
    from ..jsontext import json_text
    from .common import refuse_lossy

    refuse_lossy([episode], "a ProB2 trace", allow=lossy)

    path = check_output(Path(path), inputs, force=force, example="episode.prob2trace")
    return write_file(path, json_text(prob2trace_document(episode, vocab), indent=2,
                                       ensure_ascii=False))
