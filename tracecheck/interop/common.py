"""What both importers share: checking names and values, building episodes, finding files."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Iterable, Mapping, Optional

from ..b.notation import parse_literal
from ..episodes.model import Episode, StepRecord, make_end
from ..episodes.vocabulary import HIGHWAY, Vocabulary
from ..errors import InputError, TracecheckError
from ..inputs import read_json

__all__ = ["load_json", "read_literal", "build_episode", "natural_key", "expand_paths"]

INIT = "$initialise_machine"
SETUP = "$setup_constants"


def natural_key(path: Path):
    """Sort ``Timed_Simulation_10`` after ``Timed_Simulation_9``."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", path.name)]


def expand_paths(paths: Iterable[str | Path], pattern: str) -> list[Path]:
    """Files given directly, and the files matching ``pattern`` inside folders given."""
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(p.glob(pattern), key=natural_key)
            if not found:
                raise InputError(f"the folder {p} holds no {pattern} files")
            out += found
        elif p.exists():
            out.append(p)
        else:
            raise InputError(f"no such file or folder: {p}")
    return out


def load_json(path: Path) -> Any:
    return read_json(path, "trace file")


def read_literal(text: Any, where: str) -> Any:
    if not isinstance(text, str):
        raise InputError(f"{where}: expected a B literal (a string), found {text!r}")
    try:
        return parse_literal(text)
    except TracecheckError as exc:
        raise InputError(f"{where}: {exc.message} at column {exc.column}: {text[:80]!r}") \
            from None


def build_episode(episode_id: int, origin: str, items: list[tuple],
                  vocab: Vocabulary, where: str, reason: Optional[str] = None) -> Episode:
    """An episode from (action, state, time) per step — or (action, state, time,
    parameters) for a continuous action's values; checks names against ``vocab``."""
    if not items:
        raise InputError(f"{where}: the trace has no initial state ({INIT})")
    steps = []
    for k, (action, state, t, *more) in enumerate(items):
        here = f"{where}, step {k}"
        if k > 0 and action not in vocab.actions:
            raise InputError(f"{here}: unknown operation {action!r}; the actions are "
                             f"{', '.join(vocab.actions)}")
        unknown = sorted(set(state) - set(vocab.variables))
        if unknown:
            raise InputError(f"{here}: unknown variable {unknown[0]!r}; the variables are "
                             f"{', '.join(vocab.variables)}",
                             hint="the states are read in the paper's highway vocabulary "
                                  "unless --model MACHINE.mch names their machine"
                             if vocab is HIGHWAY else None)
        missing = [v for v in vocab.variables if v not in state]
        if missing:
            raise InputError(f"{here}: no value for {', '.join(missing)}")
        steps.append(StepRecord(step=k, time=t, action=action if k else None, state=state,
                                reward=_number(state.get("Reward", 0.0), here),
                                crashed=_flag(state.get("Crash", False), here),
                                parameters=(more[0] or None) if more and k else None))
    steps_t = tuple(steps)
    return Episode(id=episode_id, steps=steps_t, end=make_end(steps_t, reason), origin=origin)


def _number(value: Any, where: str) -> float:
    if type(value) not in (int, float):
        raise InputError(f"{where}: Reward must be a number, not {value!r}")
    return float(value)


def _flag(value: Any, where: str) -> bool:
    if type(value) is not bool:
        raise InputError(f"{where}: Crash must be TRUE or FALSE, not {value!r}")
    return value


def vocabulary_of(machine) -> Vocabulary:
    """The variables and operations of a loaded machine, as an import vocabulary."""
    set_name = next(iter(machine.sets), "Vehicles")
    return Vocabulary(tuple(machine.variables), tuple(machine.operations), machine.name,
                      set_name)


def check_types(machine, episode: Episode, where: str) -> None:
    """Every state of ``episode`` fits the machine's variable types."""
    if machine is None:
        return
    for s in episode.steps:
        machine.check_state(s.state, where=f"{where}, step {s.step}")


def refuse_continuous(episodes: Iterable[Episode], fmt: str) -> None:
    """Formats without a place for a continuous action's values refuse a run that has
    them (rather than write the action without them)."""
    for episode in episodes:
        step = next((s for s in episode.steps if s.parameters), None)
        if step is not None:
            raise InputError(f"episode {episode.id}, step {step.step}: the action "
                             f"{step.action} has continuous values "
                             f"({', '.join(step.parameters)}), which {fmt} has no place for: "
                             "exporting would drop them",
                             hint="export prob2trace keeps them; the run file itself is the "
                                  "complete record")


def state_changes(prev: Mapping[str, Any], state: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in state.items() if k not in prev or prev[k] != v}
