"""ProB2-UI project files (``.prob2project``): their machines and validation tasks.

A project is JSON. Two layouts are read, the ones the authors' projects and current ProB2-UI
write:

* **per machine lists** (ProB2-UI 1.1, and the paper authors' project):
  ``traces: [{location, selected}]`` and ``simulations: [{path, simulationItems: [{id, type,
  information}]}]``, beside ``temporalFormulas``, ``modelcheckingItems``,
  ``symbolicCheckingFormulas``, ``proofObligationItems``, ``testCases``…;
* **validation tasks** (ProB2-UI 1.2 and later): ``validationTasks: [{taskType, id, …}]``,
  ``REPLAY_TRACE`` tasks with ``location``, ``SIMULATION`` tasks with ``simulationPath``,
  ``type`` and ``information``, and every other kind (``LTL``, ``MODEL_CHECKING``,
  ``SYMBOLIC_MODEL_CHECKING``, ``PROOF_OBLIGATION``…) by its ``taskType``.

Paths inside a project are relative to the project file's folder. Every task becomes a
:class:`Task`, those tracecheck cannot run too (with the reason), so nothing is dropped
silently. A field of the wrong type is an :class:`InputError` naming the file and the JSON
path of the field (``machines[0].simulations[1].simulationItems[2].information.PROBABILITY``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import InputError, printable
from ..inputs import read_json
from ..stats.simb_tasks import (CHECKING_TYPES, ESTIMATION, HYPOTHESIS, PREDICATE_TYPES, SimbTask,
                                Window)

__all__ = ["Project", "ProjectMachine", "Task", "read_project", "REPLAY_TRACE", "SIMULATION"]

REPLAY_TRACE, SIMULATION = "REPLAY_TRACE", "SIMULATION"

# ------------------------------------------------------------------ the file, as pydantic


class _Model(BaseModel):
    # ProB2-UI adds fields from version to version: unknown ones are kept, known ones checked
    model_config = ConfigDict(extra="allow", strict=True)


class _Information(_Model):
    """SimB's task settings (``SimulationItem.SimulationCheckingInformation``)."""

    EXECUTIONS: Optional[int] = Field(None, ge=0)
    MAX_STEPS_BEFORE_PROPERTY: Optional[int] = Field(None, ge=0)
    PREDICATE: Optional[str] = None
    EXPRESSION: Optional[str] = None
    CHECKING_TYPE: Optional[str] = None
    HYPOTHESIS_CHECKING_TYPE: Optional[str] = None
    ESTIMATION_TYPE: Optional[str] = None
    PROBABILITY: Optional[float] = Field(None, ge=0, le=1)
    SIGNIFICANCE: Optional[float] = Field(None, gt=0, lt=1)
    DESIRED_VALUE: Optional[float] = None
    EPSILON: Optional[float] = Field(None, ge=0)
    TIME: Optional[int] = Field(None, ge=0)
    STEPS_PER_EXECUTION: Optional[int] = Field(None, ge=0)
    ENDING_PREDICATE: Optional[str] = None
    ENDING_TIME: Optional[int] = Field(None, ge=0)
    START_AFTER_STEPS: Optional[int] = Field(None, ge=0)
    STARTING_PREDICATE: Optional[str] = None
    STARTING_PREDICATE_ACTIVATED: Optional[str] = None
    STARTING_TIME: Optional[int] = Field(None, ge=0)


class _SimulationItem(_Model):
    id: Optional[str] = None
    type: str
    information: _Information = Field(default_factory=_Information)
    selected: Optional[bool] = None


class _Simulation(_Model):
    path: str
    simulationItems: list[_SimulationItem] = Field(default_factory=list)


class _Trace(_Model):
    id: Optional[str] = None
    location: str
    selected: Optional[bool] = None


class _ValidationTask(_Model):
    taskType: str
    id: Optional[str] = None
    selected: Optional[bool] = None
    location: Optional[str] = None  # REPLAY_TRACE
    simulationPath: Optional[str] = None  # SIMULATION
    type: Optional[str] = None
    information: Optional[_Information] = None


#: the older per-machine lists of tasks tracecheck does not run, with the kind each holds
OTHER_LISTS = {"temporalFormulas": "LTL", "ltlFormulas": "LTL",
               "symbolicCheckingFormulas": "SYMBOLIC_MODEL_CHECKING",
               "symbolicAnimationFormulas": "SYMBOLIC_ANIMATION",
               "modelcheckingItems": "MODEL_CHECKING", "proofObligationItems": "PROOF_OBLIGATION",
               "testCases": "TEST_CASE_GENERATION"}


class _Machine(_Model):
    name: str
    location: str
    description: Optional[str] = None
    traces: list[_Trace] = Field(default_factory=list)
    simulations: list[_Simulation] = Field(default_factory=list)
    validationTasks: list[_ValidationTask] = Field(default_factory=list)


class _Project(_Model):
    name: Optional[str] = None
    machines: list[_Machine]


# ------------------------------------------------------------------ inside tracecheck


@dataclass(frozen=True)
class Task:
    """One validation task of a machine. ``kind``: REPLAY_TRACE, SIMULATION or another
    ProB2-UI task type (which tracecheck lists as not run). ``where``: its JSON path."""

    machine: str
    number: int  # 1, 2, … within its machine
    kind: str
    where: str
    id: Optional[str] = None
    selected: bool = True
    trace: Optional[Path] = None  # REPLAY_TRACE
    simulation: Optional[Path] = None  # SIMULATION: a script, a folder of traces, a file
    simulation_text: Optional[str] = None  # the path as the project writes it
    simb: Optional[SimbTask] = None
    description: str = ""

    @property
    def label(self) -> str:
        """The task's id, else its number within its machine."""
        return self.id or f"#{self.number}"


@dataclass(frozen=True)
class ProjectMachine:
    name: str
    location: Path
    tasks: tuple[Task, ...] = ()


@dataclass(frozen=True)
class Project:
    name: str
    file: Path
    machines: tuple[ProjectMachine, ...] = field(default_factory=tuple)

    @property
    def folder(self) -> Path:
        return self.file.parent


def _json_path(loc: tuple) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _invalid(path: Path, exc: ValidationError) -> InputError:
    first = exc.errors()[0]
    where = _json_path(tuple(first["loc"])) or "the top level"
    shown = printable(repr(first.get("input")))[:60]
    more = len(exc.errors()) - 1
    tail = f" ({more} more problem{'s' if more > 1 else ''} after this one)" if more else ""
    return InputError(f"{where}: {first['msg'].lower()}, not {shown}{tail}", file=str(path),
                      hint="fix the field in the project file (ProB2-UI writes it so)")


def read_project(path: str | Path) -> Project:
    """The project in ``path`` with every task of every machine (see the module docstring).

    >>> read_project("tests/fixtures/prob2project/Corridor.prob2project").machines[0].name
    'Corridor'
    """
    path = Path(path)
    data = read_json(path, "ProB2-UI project file")
    if not isinstance(data, dict) or "machines" not in data:
        raise InputError("not a ProB2-UI project: a project file is a JSON object with "
                         "'machines'", file=str(path))
    try:
        model = _Project.model_validate(data)
    except ValidationError as exc:
        raise _invalid(path, exc) from None
    folder = path.parent
    try:
        machines = tuple(_machine(m, i, folder, data["machines"][i])
                         for i, m in enumerate(model.machines))
    except InputError as exc:
        raise exc.located(file=str(path)) from None
    return Project(model.name or path.stem, path, machines)


def _machine(m: _Machine, i: int, folder: Path, raw: dict) -> ProjectMachine:
    here = f"machines[{i}]"
    tasks: list[Task] = []

    def add(kind: str, where: str, **fields) -> None:
        tasks.append(Task(m.name, len(tasks) + 1, kind, where, **fields))

    for k, t in enumerate(m.validationTasks):
        where = f"{here}.validationTasks[{k}]"
        kind, fields = _validation_task(t, where, folder, raw["validationTasks"][k])
        add(kind, where, **fields)
    for k, t in enumerate(m.traces):
        add(REPLAY_TRACE, f"{here}.traces[{k}]", id=t.id, selected=t.selected is not False,
            trace=folder / t.location, description=t.location)
    for k, sim in enumerate(m.simulations):
        for j, item in enumerate(sim.simulationItems):
            where = f"{here}.simulations[{k}].simulationItems[{j}]"
            add(SIMULATION, where, id=item.id, selected=item.selected is not False,
                simulation=folder / sim.path, simulation_text=sim.path,
                simb=_simb(item.type, item.information, where), description=sim.path)
    for key, kind in OTHER_LISTS.items():
        items = raw.get(key) or []
        if not isinstance(items, list):
            raise InputError(f"{here}.{key}: expected a list of tasks, not "
                             f"{printable(repr(items))[:60]}")
        for k, item in enumerate(items):
            add(_other_kind(item, kind), f"{here}.{key}[{k}]", id=_text(item, "id"),
                description=_described(item))
    return ProjectMachine(m.name, folder / m.location, tuple(tasks))


def _validation_task(t: _ValidationTask, where: str, folder: Path, raw: dict) -> tuple:
    selected = t.selected is not False
    if t.taskType == REPLAY_TRACE:
        if t.location is None:
            raise InputError(f"{where}.location: a REPLAY_TRACE task names its trace file")
        return REPLAY_TRACE, {"id": t.id, "selected": selected,
                                     "trace": folder / t.location, "description": t.location}
    if t.taskType == SIMULATION:
        if t.simulationPath is None or t.type is None:
            missing = "simulationPath" if t.simulationPath is None else "type"
            raise InputError(f"{where}.{missing}: a SIMULATION task has a simulationPath and "
                             "a type")
        return SIMULATION, {
            "id": t.id, "selected": selected, "simulation": folder / t.simulationPath,
            "simulation_text": t.simulationPath, "description": t.simulationPath,
            "simb": _simb(t.type, t.information or _Information(), where)}
    return t.taskType, {"id": t.id, "selected": selected, "description": _described(raw)}


def _simb(kind: str, info: _Information, where: str) -> SimbTask:
    predicate_type = info.CHECKING_TYPE in PREDICATE_TYPES
    formula = info.PREDICATE if predicate_type else info.EXPRESSION
    _require(kind, info, where)
    window = Window(
        max_steps_before=info.MAX_STEPS_BEFORE_PROPERTY or 0,
        start_after_steps=info.START_AFTER_STEPS, starting_predicate=info.STARTING_PREDICATE,
        starting_predicate_activated=info.STARTING_PREDICATE_ACTIVATED,
        starting_time=info.STARTING_TIME, steps_per_execution=info.STEPS_PER_EXECUTION,
        ending_predicate=info.ENDING_PREDICATE, ending_time=info.ENDING_TIME)
    return SimbTask(kind, info.CHECKING_TYPE, formula, info.EXECUTIONS, window,
                    info.PROBABILITY, info.SIGNIFICANCE, info.HYPOTHESIS_CHECKING_TYPE,
                    info.ESTIMATION_TYPE, info.DESIRED_VALUE, info.EPSILON, info.TIME)


#: what each kind of SimB task must have (the checking type's formula comes on top)
_REQUIRED = {HYPOTHESIS: ("CHECKING_TYPE", "HYPOTHESIS_CHECKING_TYPE", "PROBABILITY",
                          "SIGNIFICANCE"),
             ESTIMATION: ("CHECKING_TYPE", "ESTIMATION_TYPE", "DESIRED_VALUE", "EPSILON")}


def _require(kind: str, info: _Information, where: str) -> None:
    """The fields a task of a kind and checking type tracecheck knows cannot do without
    (a task of another kind or type is listed as not run, with the reason)."""
    needed = list(_REQUIRED.get(kind, ()))
    if kind in _REQUIRED and info.CHECKING_TYPE in CHECKING_TYPES:
        needed.append("TIME" if info.CHECKING_TYPE == "TIMING" else
                      None if info.CHECKING_TYPE == "ALL_INVARIANTS" else
                      "PREDICATE" if info.CHECKING_TYPE in PREDICATE_TYPES else "EXPRESSION")
    for key in needed:
        if key is not None and getattr(info, key) is None:
            raise InputError(f"{where}.information.{key}: missing (a {kind} task with "
                             f"CHECKING_TYPE {info.CHECKING_TYPE} has one)")


def _text(item: Any, key: str) -> Optional[str]:
    value = item.get(key) if isinstance(item, dict) else None
    return value if isinstance(value, str) else None


def _other_kind(item: Any, default: str) -> str:
    kind = _text(item, "type") or _text(item, "taskType")
    return kind if kind and kind.isupper() else default


def _described(item: Any) -> str:
    """A task's formula or description, for the table (the first of the usual fields)."""
    for key in ("code", "formula", "predicate", "description", "name", "location"):
        text = _text(item, key)
        if text:
            return printable(text.replace("\n", " "))
    return ""
