"""``tracecheck project``: a ProB2-UI project's validation tasks, run as its validation
table would, each with its verdict."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from .common import FORMAT, JSON, OutputFormat, app, err, out, output_format


def _traces(values: list[str]) -> dict[str, Path]:
    """``--traces [SIMULATION=]DIR`` values as {simulation path or "": folder}."""
    found: dict[str, Path] = {}
    for value in values:
        name, sep, folder = value.rpartition("=")
        key = name if sep else ""
        if not folder:
            raise InputError(f"--traces {value!r}: give a folder of SimB timed traces, "
                             "DIR or SIMULATION=DIR")
        if key in found:
            which = f"for {key}" if key else "without SIMULATION="
            raise InputError(f"--traces is given twice {which}; give one folder each")
        found[key] = Path(folder)
    return found


@app.command("project")
def project_cmd(
    project: Path = typer.Argument(..., help="A ProB2-UI project file (.prob2project)."),
    machine: list[str] = typer.Option([], "--machine", "-m", help="Only this machine's tasks "
                                      "(its name in the project; repeatable)."),
    executions: Optional[int] = typer.Option(None, "--executions", "-n", min=1,
                                             help="Executions per simulation task, instead "
                                                  "of each task's EXECUTIONS."),
    traces: list[str] = typer.Option([], "--traces", help="A folder of SimB timed traces "
                                     "(Timed_Simulation_*.json) to take a simulation's "
                                     "executions from instead of running its script: "
                                     "SIMULATION=DIR for one simulation (its path as the "
                                     "project writes it, or its file name), DIR for every "
                                     "other one (repeatable)."),
    run_scripts: bool = typer.Option(False, "--run-scripts/--no-scripts",
                                     help="Run the simulations' scripts the project names "
                                          "(code, with your permissions: only for projects "
                                          "you trust; only scripts in the project's folder). "
                                          "Without it, a simulation without --traces is not "
                                          "run."),
    python: str = typer.Option("python3", "--python", help="The Python that runs the "
                               "simulations' scripts (the authors' need their own pinned "
                               "packages)."),
    seed: int = typer.Option(0, "--seed", help="Seeds SimB's random steps before a property "
                             "(MAX_STEPS_BEFORE_PROPERTY)."),
    step_timeout: float = typer.Option(30.0, "--step-timeout", min=0.1, help="Seconds a "
                                       "script may take to answer one step."),
    fmt: OutputFormat = FORMAT,
    as_json: bool = JSON,
) -> None:
    """Run a ProB2-UI project's validation tasks: trace replays, SimB hypothesis tests,
    estimations and Monte Carlo runs. A simulation's script (which ProB2-UI would run) runs
    only with --run-scripts; else give its timed traces with --traces. Exit 0 when every task
    ran and succeeded, 1 when one failed, 3 when none failed but some were not run."""
    from ..interop.prob2project import read_project
    from ..interop.prob2project_run import RunOptions, exit_code, run_project
    from ..render.emit import emit
    from ..render.project_text import ProjectOutput

    fmt = output_format(fmt, as_json)
    options = RunOptions(machines=tuple(machine), executions=executions,
                         traces=_traces(traces), scripts=run_scripts, python=python,
                         seed=seed, step_timeout=step_timeout)
    report = run_project(read_project(project), options)
    shown = ProjectOutput(report)
    emit(shown, fmt.value, out)
    code = exit_code(report)
    if code == 3 and fmt != OutputFormat.text:
        err.print(f"note: {shown.summary()}", highlight=False)
    if code:
        raise typer.Exit(code)

