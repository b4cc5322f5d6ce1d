"""Commands that check recordings against shields: replay (with re-simulation), diff."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from .common import (app, out, err, warn, Executor, FILE_EXECUTOR, RAY_ADDRESS, OutputFormat,
                     FailOn, SHIELD_HELP, ROWS, run_shield, SALVAGE)


@app.command("replay")
def replay_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    salvage: bool = SALVAGE,
    shield: str = typer.Option(..., "--shield", "-s", help=SHIELD_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print the full report as JSON."),
    fmt: OutputFormat = typer.Option(OutputFormat.text, "--format", help="text or md."),
    all_rows: bool = typer.Option(False, "--all", help=f"List every episode that matters "
                                  f"(default: the first {ROWS})."),
    ltl: list[str] = typer.Option([], "--ltl", help="An LTL formula in ProB's syntax to check "
                                  "on every episode, e.g. 'G({Crash = FALSE})' (repeatable; "
                                  "see docs/statistics.md)."),
    ltl_assertions: bool = typer.Option(False, "--ltl-assertions", help="Check the shield "
                                        "machine's ASSERT_LTL definitions on every episode."),
    fail_on: list[FailOn] = typer.Option([], "--fail-on",
                                         help="Exit 1 when this occurs (repeatable)."),
    resimulate: bool = typer.Option(False, "--resimulate",
                                    help="Re-run each infeasible episode from its seed with the "
                                         "agent under the shield: was the crash prevented?"),
    agent: Optional[Path] = typer.Option(None, "--agent", help="The agent that recorded the "
                                         "episodes (default: the bundled agent of that name). "
                                         "Loading it runs code from the file."),
    env: Optional[str] = typer.Option(None, "--env", help="For --resimulate: the environment "
                                      "adapter (default: the installed one the file names)."),
    executor: Executor = FILE_EXECUTOR,
    ray_address: Optional[str] = RAY_ADDRESS,
) -> None:
    """Replay episodes against a shield: where would it have blocked the recorded action?"""
    from ..checking.replay import replay
    from ..render.text import replay_markdown, replay_text

    loaded = run_shield(shield, runs)
    report = replay(runs, loaded, executor=executor.value, ray_address=ray_address, ltl=ltl,
                    ltl_assertions=ltl_assertions)
    warn(report.warnings)
    if resimulate:
        report.resimulation = _resimulate(runs, loaded, report, agent, env)
    rows = len(report.per_episode) if all_rows else ROWS
    if as_json:
        out.print_json(json.dumps(report.to_json()))
    elif fmt == OutputFormat.md:
        out.print(replay_markdown(report, rows), markup=False)
    else:
        replay_text(out, report, rows)
    counts = {FailOn.infeasible: report.infeasible_steps,
              FailOn.deadlock: report.deadlock_states,
              FailOn.postcondition: report.postcondition_violations,
              FailOn.invariant: report.invariant_violations}
    failed = [f.value for f in fail_on if counts[f]]
    if failed:
        err.print(f"failing: {', '.join(failed)} found (--fail-on)")
        raise typer.Exit(1)



def _resimulate(runs: list[Path], shield, report, agent: Optional[Path],
                env: Optional[str] = None) -> dict:
    from rich.progress import BarColumn, Progress, TextColumn

    from ..checking.resimulate import resimulate, summary

    results = []
    todo = sum(e.first_infeasible is not None for e in report.per_episode)
    with Progress(TextColumn("re-simulating under " + shield.name), BarColumn(),
                  TextColumn("{task.completed}/{task.total} episodes"), console=err,
                  transient=True) as bar:
        task = bar.add_task("resim", total=todo)
        for run in runs:
            results += resimulate(run, shield, report, agent=agent, env=env,
                                  progress=lambda r: bar.advance(task))
    return summary(results)


@app.command("diff")
def diff_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    salvage: bool = SALVAGE,
    shield: str = typer.Option(..., "--shield", "-s", help="The new shield. " + SHIELD_HELP),
    against: str = typer.Option(..., "--against", "-a",
                                help="The shield to compare with (old version, baseline)."),
    as_json: bool = typer.Option(False, "--json", help="Print the full report as JSON."),
    fail_on_change: bool = typer.Option(False, "--fail-on-change",
                                        help="Exit 1 when anything changed."),
    executor: Executor = FILE_EXECUTOR,
    ray_address: Optional[str] = RAY_ADDRESS,
) -> None:
    """Compare two shields on every recorded state: which steps does the change block or allow?"""
    from ..checking.replay import diff
    from ..render.text import diff_text

    report = diff(runs, run_shield(shield, runs), run_shield(against, runs),
                  executor=executor.value, ray_address=ray_address)
    warn(report.warnings)
    if as_json:
        out.print_json(json.dumps(report.to_json()))
    else:
        diff_text(out, report, ROWS)
    if fail_on_change and report.anything_changed:
        err.print("failing: the shields differ on these episodes (--fail-on-change)")
        raise typer.Exit(1)
