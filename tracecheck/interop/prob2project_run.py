"""Running a ProB2-UI project's validation tasks (``tracecheck project``), as ProB2-UI's
validation table would, each with its verdict: success, failed or not run (with the reason).

* ``REPLAY_TRACE``: the ``.prob2trace`` file replayed against the machine
  (:func:`tracecheck.checking.replay_columns`): success when its ``$setup_constants`` gives
  the machine's constants, the INITIALISATION can give its first state, every step's
  operation is enabled in the state before it and its effect gives the recorded state; else
  failed at the first bad step.
* ``SIMULATION``: SimB's hypothesis tests, estimations and Monte Carlo runs
  (:mod:`tracecheck.stats.simb_tasks`) on executions from a folder of SimB timed traces
  (``Timed_Simulation_*.json``: the simulation's path when it is a folder, or a folder given
  with ``traces``) or from the external script the simulation names, run with ``python``
  (:mod:`tracecheck.live.external`; only with ``scripts=True``, the CLI's
  ``--run-scripts``: ProB2-UI runs them, but a project file is data). The tasks of one
  simulation share its executions: the script runs once, for the most executions any of them asks for, cut where the longest of
  their windows surely ends (else at the script's ``done``). A task with fewer executions
  than it asks for is not run.
* every other task (LTL, model checking, symbolic checking, proof obligations …): not run,
  with the reason.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Callable, Mapping, Optional

from ..errors import InputError, TracecheckError
from ..episodes.columns import RunColumns
from ..stats.simb_tasks import (FAILED, NOT_RUN, SUCCESS, TaskOutcome, Window, evaluate_task,
                                has_setup, task_columns)
from .prob2project import REPLAY_TRACE, SIMULATION, Project, ProjectMachine, Task

__all__ = ["RunOptions", "TaskReport", "ProjectReport", "run_project", "script_episodes",
           "run_bounds", "exit_code", "STATUSES"]

STATUSES = (SUCCESS, FAILED, NOT_RUN)
#: the exit code of ``tracecheck project`` when no task failed but some were not run
NOT_ALL_RUN = 3


@dataclass(frozen=True)
class RunOptions:
    """How to run a project. ``traces``: a folder of SimB timed traces per simulation path
    (as the project writes it, or its file name; the key ``""``: every simulation without
    its own); ``scripts``: whether a simulation's script may be run (off unless the user
    says so: a project file is data, and its scripts are code; even then only scripts in
    the project's folder); ``python``: the
    interpreter that runs the scripts; ``seed``: SimB's random steps before a property
    (``MAX_STEPS_BEFORE_PROPERTY``)."""

    machines: tuple[str, ...] = ()
    executions: Optional[int] = None
    traces: Mapping[str, Path] = field(default_factory=dict)
    scripts: bool = False
    python: str = "python3"
    seed: int = 0
    step_timeout: float = 30.0


@dataclass
class TaskReport:
    """One row of the validation table."""

    machine: str
    task: str  # the task's id, else #number
    kind: str  # REPLAY_TRACE, HYPOTHESIS_TEST, ESTIMATION, MONTE_CARLO_SIMULATION, LTL, …
    checks: str
    status: str
    executions: int = 0
    result: str = ""
    reason: str = ""
    source: str = ""  # where the executions came from
    where: str = ""  # the task's JSON path in the project file
    selected: bool = True  # False: deselected in the project (not counted in the exit code)
    details: dict = field(default_factory=dict)


@dataclass
class ProjectReport:
    project: str
    file: str
    tasks: list[TaskReport] = field(default_factory=list)

    def count(self, status: str, *, selected_only: bool = True) -> int:
        return sum(1 for t in self.tasks if t.status == status
                   and (t.selected or not selected_only))

    def to_json(self) -> dict:
        return {"project": self.project, "file": self.file,
                "summary": {s: self.count(s) for s in STATUSES},
                "exit_code": exit_code(self), "tasks": [asdict(t) for t in self.tasks]}


def exit_code(report: ProjectReport) -> int:
    """1 when a task failed; else 3 when a (selected) task was not run, so that a project of
    which nothing ran never passes for validated; else 0."""
    if report.count(FAILED):
        return 1
    return NOT_ALL_RUN if report.count(NOT_RUN) else 0


def script_episodes(command: tuple[str, ...], episodes: int, cwd: Path, shield, *,
                    ending_time_ms: Optional[float], max_steps: Optional[int],
                    step_timeout: float) -> list:
    """Episodes of an external script speaking SimB's protocol (the seam tests replace)."""
    from ..live.external import ExternalSettings, external_episodes

    settings = ExternalSettings(command=command, episodes=episodes, cwd=cwd,
                                ending_time_ms=ending_time_ms, max_steps=max_steps,
                                step_timeout=step_timeout)
    return list(external_episodes(settings, shield))


def run_project(project: Project, options: RunOptions = RunOptions(),
                on_task: Optional[Callable[[TaskReport], None]] = None) -> ProjectReport:
    """Every task of the project's machines (those named in ``options.machines``, all when
    empty), in the project's order; ``on_task`` hears of each as it is done."""
    report = ProjectReport(project.name, str(project.file))
    shared: dict = {}  # each folder of traces read once for machines of the same variables
    for machine in _selected(project, options.machines):
        runner = _MachineRun(project, machine, options, shared)
        for task in machine.tasks:
            row = runner.run(task)
            report.tasks.append(row)
            if on_task is not None:
                on_task(row)
    return report


def _selected(project: Project, names: tuple[str, ...]) -> list[ProjectMachine]:
    known = [m.name for m in project.machines]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise InputError(f"the project {project.name} has no machine {unknown[0]!r}; it has "
                         f"{', '.join(known) or 'none'}", hint="give --machine NAME of one of "
                         "them (repeatable), or leave it out for all")
    return [m for m in project.machines if not names or m.name in names]


class _MachineRun:
    """The tasks of one machine: its shield loaded once, each simulation's executions read
    or run once."""

    def __init__(self, project: Project, machine: ProjectMachine, options: RunOptions,
                 shared: Optional[dict] = None) -> None:
        self.project, self.machine, self.options = project, machine, options
        self._shield = None
        self._shield_error: Optional[str] = None
        #: per simulation: (its executions as columns, or None; where they came from; why
        #: there are none)
        self._executions: dict[Path, tuple[Optional[RunColumns], str, str]] = {}
        shared = shared if shared is not None else {}  # with the project's other machines:
        self._read = shared.setdefault("traces", {})  # see _read_traces
        self._cut: set[Path] = set()  # simulations whose script run was cut

    @property
    def shield(self):
        if self._shield is None and self._shield_error is None:
            from ..checking.shield import load_shield

            if not self.machine.location.is_file():
                self._shield_error = f"no machine file at {self.machine.location}"
            else:
                try:
                    self._shield = load_shield(self.machine.location)
                except TracecheckError as exc:
                    self._shield_error = f"tracecheck cannot load the machine: {exc.render()}"
        return self._shield

    def run(self, task: Task) -> TaskReport:
        row = TaskReport(self.machine.name, task.label, task.kind, task.description,
                         NOT_RUN, where=task.where, selected=task.selected)
        if not task.selected:
            row.reason = "deselected in the project (ProB2-UI does not run it either)"
        elif task.kind not in (REPLAY_TRACE, SIMULATION):
            row.reason = f"tracecheck does not run {task.kind} tasks (it replays traces and " \
                         "runs SimB simulations)"
        elif self.shield is None:
            row.reason = self._shield_error or ""
        elif task.kind == REPLAY_TRACE:
            self._replay(task, row)
        else:
            self._simulate(task, row)
        return row

    # ---------------------------------------------------------- trace replay

    def _replay(self, task: Task, row: TaskReport) -> None:
        from ..checking.replaying import replay_columns
        from ..episodes.columns import episode_columns
        from .common import vocabulary_of
        from .prob2trace import read_prob2trace

        row.source = str(task.trace)
        if not task.trace.is_file():
            row.reason = f"no trace file at {task.trace}"
            return
        machine = self.shield.machine
        try:
            episode = read_prob2trace(task.trace, 0, vocabulary_of(machine), machine,
                                      constants=False)  # _first_state judges them
            actions = sorted({s.action for s in episode.steps if s.action})
            replayed = replay_columns(episode_columns([episode], actions), self.shield)
        except TracecheckError as exc:
            row.reason = f"tracecheck cannot replay it: {exc.render()}"
            return
        first = _first_state(task.trace, episode, machine)
        if first is not None:
            row.status, why = first
            row.executions = 1
            row.result = why if row.status == FAILED else ""
            row.reason = why
            return
        ep = replayed.per_episode[0]
        row.executions = 1
        row.status, row.result, row.reason = _replay_verdict(ep, episode)
        row.details = {"steps": ep.steps, "first_infeasible": ep.first_infeasible,
                       "enabled_there": ep.enabled,
                       "postcondition_violations": ep.postcondition_violations,
                       "invariant_violations": ep.invariant_violations}

    # ---------------------------------------------------------- simulations

    def _simulate(self, task: Task, row: TaskReport) -> None:
        simb = task.simb
        row.kind, row.checks = simb.kind, simb.checks
        if self.options.executions is not None:
            simb = replace(simb, executions=self.options.executions)
        columns, source, error = self._executions_of(task)
        row.source = source
        if error:
            row.reason = error
            return
        count = 0 if columns is None else len(columns.episode_ids)
        if simb.executions is not None and count < simb.executions:
            row.executions = count
            row.reason = _too_few(count, simb.executions, source)
            return
        where = f"{self.project.file}: {task.where}"
        outcome: TaskOutcome = evaluate_task(simb, (), self.shield.machine,
                                             seed=self.options.seed, where=where,
                                             run_cut=task.simulation in self._cut,
                                             columns=columns)
        row.status, row.executions = outcome.status, outcome.executions
        row.result, row.reason, row.details = outcome.result, outcome.reason, outcome.details

    def _executions_of(self, task: Task) -> tuple[Optional[RunColumns], str, str]:
        """(the executions as columns, or None; where they came from; why there are none)
        for a simulation: read or run once for all its tasks."""
        key = task.simulation
        if key not in self._executions:
            self._executions[key] = self._load(task)
        return self._executions[key]

    def _traces_for(self, task: Task) -> Optional[Path]:
        given = self.options.traces
        for name in (task.simulation_text, Path(task.simulation_text or "").name, ""):
            if name in given:
                return Path(given[name])
        return task.simulation if task.simulation.is_dir() else None

    def _wanted(self, task: Task) -> tuple[Optional[int], list[Task]]:
        """The most executions any task of this simulation asks for (None: all there are),
        and those tasks."""
        group = [t for t in self.machine.tasks if t.kind == SIMULATION and t.selected
                 and t.simulation == task.simulation]
        if self.options.executions is not None:
            return self.options.executions, group
        counts = [t.simb.executions for t in group]
        return (None if any(c is None for c in counts) else max(counts)), group

    def _load(self, task: Task) -> tuple[Optional[RunColumns], str, str]:
        folder = self._traces_for(task)
        wanted, group = self._wanted(task)
        if folder is not None:
            return self._read_traces(folder, wanted)
        path = task.simulation
        if path.suffix != ".py":
            kind = "SimB simulation file" if path.suffix == ".json" else "file"
            return None, str(path), (
                f"the {kind} {path} is neither an external script (.py) nor a folder of "
                "timed traces; tracecheck does not run SimB's own simulations: give a "
                "folder of its traces with --traces")
        if not self.options.scripts:
            return None, str(path), (f"it runs the script {path}, which only the project file "
                                   "names: give --run-scripts to run the project's scripts "
                                   "(with your permissions; only for projects you trust), "
                                   "or a folder of timed traces with --traces")
        outside = self._outside_project(path)
        if outside:
            return None, str(path), outside
        if not path.is_file():
            return None, str(path), f"no script at {path}"
        return self._run_script(path, wanted or 1, group)

    def _outside_project(self, path: Path) -> str:
        """Why a script is not run even with ``--run-scripts``: it lies outside the
        project's folder (``../x.py``, an absolute path), "" when it is inside."""
        home = self.project.folder.resolve()
        try:
            path.resolve().relative_to(home)
        except ValueError:
            return (f"the script {path} lies outside the project's folder {home}; tracecheck "
                    "runs only the scripts inside it, even with --run-scripts")
        return ""

    def _read_traces(self, folder: Path, wanted: Optional[int]
                     ) -> tuple[Optional[RunColumns], str, str]:
        from .common import expand_paths, vocabulary_of

        source = f"traces {folder}"
        if not folder.is_dir():
            return None, source, f"no folder of timed traces at {folder}"
        machine = self.shield.machine
        try:
            files = expand_paths([folder], "*.json")
            if wanted is not None:
                files = files[:wanted]
            vocab = vocabulary_of(machine)
            # what reading and checking the states depends on: machines that agree on it
            # (a project's variants of one machine) read each folder once
            key = (tuple(str(f) for f in files), vocab.variables, vocab.actions,
                   vocab.set_name, _variable_types(machine))
            if key not in self._read:
                self._read[key] = _columns_of_traces(folder, files, vocab, machine)
            return self._read[key], source, ""
        except TracecheckError as exc:
            return None, source, f"tracecheck cannot read the traces: {exc.render()}"

    def _run_script(self, path: Path, wanted: int, group: list[Task]
                    ) -> tuple[Optional[RunColumns], str, str]:
        ending_time, max_steps = run_bounds([t.simb.window for t in group],
                                            has_setup(self.shield.machine))
        source = f"script {path} ({self.options.python})"
        if ending_time is not None or max_steps is not None:
            self._cut.add(path)
        try:
            episodes = script_episodes(
                (self.options.python, path.name), wanted, path.parent, self.shield,
                ending_time_ms=ending_time, max_steps=max_steps,
                step_timeout=self.options.step_timeout)
        except ModuleNotFoundError as exc:
            return None, source, f"this tracecheck cannot run external scripts ({exc})"
        except TracecheckError as exc:
            return None, source, f"the script failed: {exc.render()}"
        return (task_columns(episodes) if episodes else None), source, ""


#: traces read into columns at a time (a folder's columns are joined from such blocks: the
#: episodes themselves are not all held at once)
CHUNK = 256


def _columns_of_traces(folder: Path, files: list[Path], vocab, machine) -> Optional[RunColumns]:
    """The SimB traces ``files`` of ``folder`` as the columns of their executions."""
    from ..episodes.columns import join
    from .simb import read_simb

    if not files:
        return None
    blocks = [task_columns([read_simb(f, lo + k, vocab, machine, constants=False)
                            for k, f in enumerate(files[lo:lo + CHUNK])])
              for lo in range(0, len(files), CHUNK)]
    try:
        columns = join(str(folder), blocks)
    except InputError:  # a variable of different kinds in different blocks: all at once,
        #                 as one block of columns takes it (row by row, where it must)
        columns = task_columns([read_simb(f, k, vocab, machine, constants=False)
                                for k, f in enumerate(files)])
    columns.states.label = None  # a state is named by its row, as in one block
    return columns


def _variable_types(machine) -> tuple:
    """The machine's variables' types and its sets' elements: all that checking a state of
    only its variables (what a trace read in its vocabulary has) depends on."""
    from ..b.btypes import resolve_all

    types = tuple((v, repr(resolve_all(machine.type_objects[v])))
                  for v in machine.variables if v in machine.type_objects)
    return types, tuple(sorted(machine.element_sets().items()))


def _replay_verdict(ep, episode) -> tuple[str, str, str]:
    """(status, result, reason) of a replayed trace."""
    post = ep.postcondition_violations
    bad = [k for k in (ep.first_infeasible, post[0] if post else None) if k is not None]
    note = f"; the invariant fails in state {ep.invariant_violations[0]}" \
        if ep.invariant_violations else ""
    if not bad:
        return SUCCESS, f"{ep.steps} steps, all feasible{note}", ""
    k = min(bad)
    op = episode.steps[k].action
    if k == ep.first_infeasible:
        enabled = ", ".join(ep.enabled or []) or "none"
        why = f"step {k}: {op} is not enabled (enabled: {enabled})"
    else:
        why = f"step {k}: {op} cannot reach the recorded state"
    return FAILED, f"{ep.steps} steps; {why}{note}", why


def _too_few(have: int, wanted: int, source: str) -> str:
    """Why a task with ``have`` of the ``wanted`` executions is not run."""
    if source.startswith("traces "):
        return (f"the folder has {have} timed traces; the task asks for {wanted} executions "
                f"— give --executions {have} to run it on them")
    return (f"the script gave {have} complete executions; the task asks for {wanted} — "
            "it must not end before tracecheck sends finished")


def run_bounds(windows: list[Window], setup: bool) -> tuple[Optional[float], Optional[int]]:
    """(ENDING_TIME in ms, operations after the INITIALISATION) at which a script run can
    be cut with every window in ``windows`` inside it (None, None: run to the script's
    ``done``). ``setup``: the machine's executions start with ``$setup_constants`` (see
    :func:`tracecheck.stats.simb_tasks.spans`). A window is bounded in steps when it starts
    after a known number of transitions (no condition or ``START_AFTER_STEPS``, after up to
    ``MAX_STEPS_BEFORE_PROPERTY`` − 1 random ones) and ends after ``STEPS_PER_EXECUTION``;
    in time when it starts at once (clock 0) and ends at ``ENDING_TIME``; a starting
    predicate or time, or an ending predicate, leave it unbounded."""
    times: list[Optional[float]] = []
    steps: list[Optional[int]] = []
    for w in windows:
        known = w.starting_predicate is None and w.starting_predicate_activated is None \
            and w.starting_time is None
        start = max(w.start_after_steps or 0, w.max_steps_before - 1, 0)
        steps.append(max(start + w.steps_per_execution - 1 - int(setup), 0)
                     if known and w.steps_per_execution is not None else None)
        times.append(float(w.ending_time) if known and start == 0
                     and w.steps_per_execution is None and w.ending_predicate is None
                     and w.ending_time is not None else None)
    if windows and None not in steps:
        return None, max(steps)
    if windows and None not in times:
        return max(times), None
    return None, None


def _first_state(path: Path, episode, machine) -> Optional[tuple[str, str]]:
    """(status, why) when the trace's ``$setup_constants`` does not give the machine's
    constants or its INITIALISATION cannot give the trace's first state — as ProB2-UI's
    replay executes both; None when both are fine."""
    from ..b.transitions import initial_state_ok
    from ..errors import UnsupportedError
    from .common import load_json, other_constants

    transitions = load_json(path).get("transitionList") or []
    setup = next((t for t in transitions if isinstance(t, dict)
                  and t.get("name") == "$setup_constants"), None)
    values = setup.get("destState") if setup else None
    if values and isinstance(values, dict):
        try:
            differ = other_constants(machine, values, f"{path}: $setup_constants")
        except TracecheckError as exc:
            return NOT_RUN, f"tracecheck cannot check its $setup_constants: {exc.render()}"
        if differ:
            return FAILED, ("step 0: $setup_constants gives constants the machine does not "
                            f"have ({_short('; '.join(differ))})")
    state = episode.steps[0].state
    try:
        ok = initial_state_ok(machine, state)
    except UnsupportedError as exc:
        return NOT_RUN, f"tracecheck cannot check its initial state: {exc.render()}"
    except TracecheckError as exc:
        return FAILED, f"step 0: {exc.render()}"
    if ok:
        return None
    return FAILED, "step 0: the INITIALISATION cannot give the recorded state" + \
        _differing(machine, state)


def _differing(machine, state) -> str:
    """`` (pos = 1, not 0)`` naming the variables a deterministic INITIALISATION gives
    other values ("" when it is not deterministic)."""
    from ..b.values import format_value

    try:
        init = machine.successor(None, {}, None, fixed={}).state
    except TracecheckError:
        return ""
    diff = [f"{v} = {format_value(state[v])}, not {format_value(init[v])}"
            for v in machine.variables if v in init and init[v] != state.get(v)]
    return f" ({'; '.join(diff)})" if diff else ""


def _short(text: str, limit: int = 120) -> str:
    return text if len(text) <= limit else text[:limit] + " …"
