"""What both importers share: checking names and values, building episodes, finding files."""

from __future__ import annotations

import bisect
import fnmatch
import os
import re
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Optional, Sequence

from ..b.notation import parse_literal
from ..b.values import Elem
from ..episodes.model import Episode, StepRecord, make_end
from ..episodes.vocabulary import Vocabulary
from ..errors import InputError, TracecheckError
from ..inputs import read_json

__all__ = ["load_json", "read_literal", "build_episode", "natural_key", "expand_paths",
           "FoundFiles", "trace_variables", "other_constants", "check_setup_constants"]

INIT = "$initialise_machine"
SETUP = "$setup_constants"


_RUNS = re.compile(r"(\d+)")


def natural_key(name: str) -> str:
    """A key that sorts ``Timed_Simulation_10`` after ``Timed_Simulation_9``: the name's runs
    of digits compared by their value, the text between them as text — as one short string
    (a folder of 10⁵ traces sorts in a few MB, not the 20 MB lists of parts would take).

    >>> sorted(["t_10.json", "t_9.json", "t_09b.json"], key=natural_key)
    ['t_9.json', 't_09b.json', 't_10.json']
    """
    out = []
    for k, part in enumerate(_RUNS.split(name)):
        if k % 2:  # a run of digits: its length (as one character), then itself
            digits = str(int(part))
            out.append(chr(len(digits)) + digits)
        else:  # text, ended by a character below any a name holds
            out.append(part + "\x00")
    return "".join(out)


class FoundFiles(Sequence[Path]):
    """The files :func:`expand_paths` found, in order, kept as their folders' names and theirs;
    a :class:`~pathlib.Path` is made when one is asked for (a Path per file takes ~300 B:
    30 MB for a folder of 10⁵ traces)."""

    def __init__(self) -> None:
        self._groups: list[tuple[Optional[Path], list[str]]] = []
        self._starts: list[int] = [0]

    def add(self, folder: Optional[Path], names: list[str]) -> None:
        """``names`` inside ``folder`` (None: each name is a whole path)."""
        self._groups.append((folder, names))
        self._starts.append(self._starts[-1] + len(names))

    def __len__(self) -> int:
        return self._starts[-1]

    def __iter__(self) -> Iterator[Path]:
        for folder, names in self._groups:
            for name in names:
                yield _path(folder, name)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        n = len(self)
        if not -n <= k < n:
            raise IndexError(k)
        k %= n
        g = bisect.bisect_right(self._starts, k) - 1
        folder, names = self._groups[g]
        return _path(folder, names[k - self._starts[g]])


def _path(folder: Optional[Path], name: str) -> Path:
    return Path(name) if folder is None else folder / name


def expand_paths(paths: Iterable[str | Path], pattern: str) -> FoundFiles:
    """Files given directly, and the files matching ``pattern`` inside folders given (sorted
    by :func:`natural_key`, ties by name)."""
    out = FoundFiles()
    for p in map(Path, paths):
        if p.is_dir():
            try:
                with os.scandir(p) as entries:
                    names = [e.name for e in entries if fnmatch.fnmatchcase(e.name, pattern)]
            except OSError as exc:
                raise InputError(f"cannot read the folder {p}: {exc.strerror or exc}") from None
            if not names:
                raise InputError(f"the folder {p} holds no {pattern} files")
            names.sort()
            names.sort(key=natural_key)
            out.add(p, names)
        elif p.exists():
            out.add(None, [str(p)])
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
                             hint="the states are read in the vocabulary of "
                                  f"{vocab.name} unless --model MACHINE.mch names their "
                                  "machine")
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
    try:
        return float(value)
    except OverflowError:  # an integer of 400 digits: no float holds it
        raise InputError(f"{where}: Reward is an integer of {len(str(abs(value)))} digits, "
                         "too large for the float a reward is kept as") from None


def _flag(value: Any, where: str) -> bool:
    if type(value) is not bool:
        raise InputError(f"{where}: Crash must be TRUE or FALSE, not {value!r}")
    return value


def vocabulary_of(machine) -> Vocabulary:
    """The variables and operations of a loaded machine, as an import vocabulary."""
    set_name = next(iter(machine.sets), "")
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


def lossy(episodes: Iterable[Episode], fmt: str) -> list[str]:
    """What writing ``episodes`` in ``fmt`` (a ProB or SimB trace: states and actions) would
    leave out: a crash where the states have no ``Crash`` variable, a reward where they have
    no ``Reward`` one, what a continuous shield did with a proposal. One line per kind,
    naming the first episode and step; empty when nothing is lost."""
    found: dict[str, str] = {}
    for episode in episodes:
        for s in episode.steps:
            here = f"episode {episode.id}, step {s.step}"
            if s.crashed and "Crash" not in s.state:
                found.setdefault("crash", f"the crash ({here}; the states have no Crash "
                                          "variable)")
            if s.reward and "Reward" not in s.state:
                found.setdefault("reward", f"the rewards ({here}: {s.reward}; the states have "
                                           "no Reward variable)")
            if s.proposal or s.allowed_intervals or s.projection_distance is not None:
                found.setdefault("proposal", f"the agent's proposals and the shield's allowed "
                                             f"intervals ({here})")
    return [f"{fmt} has no place for {found[kind]}" for kind in ("crash", "reward", "proposal")
            if kind in found]


def refuse_lossy(episodes: Iterable[Episode], fmt: str, *, allow: bool) -> list[str]:
    """Refuse to write ``episodes`` in ``fmt`` where it would drop data (:func:`lossy`);
    with ``allow`` (``--lossy``) return what is dropped, for a note."""
    dropped = lossy(episodes, fmt)
    if dropped and not allow:
        raise InputError(f"{dropped[0]}: exporting would drop it"
                         + (f" (and {len(dropped) - 1} more kind(s) of data)" if dropped[1:]
                            else ""),
                         hint="the run file itself is the complete record; --lossy exports "
                              "the states and actions anyway, saying what it leaves out")
    return dropped


def state_changes(prev: Mapping[str, Any], state: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in state.items() if k not in prev or prev[k] != v}


def trace_variables(kind: str, paths: Iterable[str | Path]) -> tuple[str, ...]:
    """The state variables of the first trace among ``paths`` (its initial state's), to find
    the environment whose vocabulary the traces are in.

    Args:
        kind: ``simb`` (SimB timed traces, ``*.json``) or ``prob2trace``.
        paths: trace files and folders of them.

    Returns:
        The variable names, sorted; none when the first trace has no state to read.
    """
    found = expand_paths(paths, "*.json" if kind == "simb" else "*.prob2trace")
    if not len(found):
        return ()
    data = load_json(found[0])
    if not isinstance(data, dict):
        return ()
    steps = data.get("activations") if kind == "simb" else data.get("transitionList")
    for step in steps if isinstance(steps, list) else ():
        if not isinstance(step, dict) or step.get("execute", step.get("name")) == SETUP:
            continue
        state = step.get("fixedVariables") if kind == "simb" else step.get("destState")
        if isinstance(state, dict) and state:
            return tuple(sorted(str(k) for k in state))
    return ()


def other_constants(machine, values: dict, where: str, *, lenient: bool = False
                    ) -> list[str]:
    """The constants ``values`` (name: ProB's text of a value) gives other values than the
    machine's, as ``"Far = 5, not 4"``. Each value is read as a literal of its constant's
    type — never spliced into a predicate, so ``"9 or TRUE = TRUE"`` is an error, not a
    formula. Raises :class:`TracecheckError` for a name that is not a constant, a value of
    another type, and — unless ``lenient``, which skips it — a value that is not a literal
    (ProB prints ``1..1000000``, ``/*@symbolic*/ %x.…``), a set's name (``NATURAL``) or
    one it cannot compare."""
    from ..b.typecheck import describe_value_type, type_of_value, unify_quiet
    from ..b.values import format_value

    owners, differ = machine.element_sets(), []
    for name, text in values.items():
        if name not in machine.constants:
            if name in machine.constants_declared:  # the machine fixes none: nothing to
                continue                              # compare (the solver could not)
            raise InputError(f"{where}: {name} is not a constant of {machine.name} (its "
                             f"constants are {', '.join(machine.constants_declared) or 'none'})")
        try:
            value = read_literal(text, f"{where}: {name}")
        except TracecheckError:
            if lenient:  # 1..1000000, /*@symbolic*/ %x.…: not a literal, not judged
                continue
            raise
        wanted = machine.type_objects.get(name)
        if wanted is not None and not unify_quiet(wanted, type_of_value(value, owners)):
            if lenient and isinstance(value, Elem):  # NATURAL: a set's name, not judged
                continue
            raise InputError(f"{where}: {name} must be of type {machine.types[name]}, but "
                             f"{text!r} is of type {describe_value_type(value, owners)}")
        try:
            if value != machine.constants[name]:
                differ.append(f"{name} = {text}, not {format_value(machine.constants[name])}")
        except TracecheckError:
            if not lenient:  # a set held by its definition: cannot be compared
                raise
    return differ


def check_setup_constants(machine, values, where: str) -> None:
    """Refuse a trace whose ``$setup_constants`` (``values``: name -> ProB's text) gives
    the machine's constants other values, or names one it does not have: it was made with
    another machine, whose guards are not these (tracecheck judges the steps with the
    machine's own constants). A value it cannot read as a literal of the constant's type,
    or compare, is not judged."""
    if machine is None or not values or not isinstance(values, dict):
        return
    differ = other_constants(machine, values, f"{where}: $setup_constants", lenient=True)
    if differ:
        raise InputError(f"{where}: $setup_constants gives {'; '.join(differ)} — the trace "
                         f"was made with another machine than {machine.name}",
                         hint="import it with the machine it was made with (--model); "
                              "replay can then judge it against any shield")
