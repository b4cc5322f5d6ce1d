"""Commands that draw: render, report."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from .common import (app, out, err, SHIELD_HELP, PROPERTIES_HELP, SALVAGE, FORCE, RUN_ENV,
                     run_adapter)


@app.command("render")
def render_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    salvage: bool = SALVAGE,
    episode: int = typer.Option(..., "--episode", "-e", help="The episode number."),
    shield: Optional[str] = typer.Option(None, "--shield", "-s", help=SHIELD_HELP),
    output: Path = typer.Option(..., "--output", "-o", help="The HTML page to write."),
    ltl: list[str] = typer.Option([], "--ltl", help="Mark where the episode first violates "
                                  "this LTL formula (repeatable; needs --shield)."),
    ltl_assertions: bool = typer.Option(False, "--ltl-assertions", help="Mark the shield "
                                        "machine's ASSERT_LTL definitions."),
    env: Optional[str] = RUN_ENV,
    force: bool = FORCE,
) -> None:
    """Write one episode as a self-contained HTML viewer (top view, shield zones, timeline)."""
    from ..checking.replaying import ltl_formulas
    from ..render.viewer import render_episode
    from ..checking.shield import load_shield
    from ..errors import InputError
    from ..outputs import check_output, input_paths, write_file

    inputs = [run, *input_paths(shield)]
    path = check_output(output, inputs, force=force, example="episode.html")
    adapter = run_adapter(env)  # its scene() hook draws the picture; else the run's own
    if adapter is not None and run.exists():
        from ..stats.formulas import check_environment

        check_environment(adapter, run)  # never another environment's picture
    loaded = load_shield(shield) if shield else None
    if (ltl or ltl_assertions) and loaded is None:
        raise InputError("--ltl and --ltl-assertions need --shield: the machine the formulas "
                         "are read in")
    formulas = ltl_formulas(loaded, ltl, ltl_assertions) if loaded is not None else []
    page = write_file(path, render_episode(run, episode, loaded, formulas, adapter=adapter,
                                           salvage=salvage))
    out.print(f"wrote episode {episode} -> {page} ({page.stat().st_size / 1000:.0f} kB)",
              markup=False)


@app.command("report")
def report_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    salvage: bool = SALVAGE,
    shield: Optional[str] = typer.Option(None, "--shield", "-s", help=SHIELD_HELP),
    properties: Optional[str] = typer.Option(
        None, "--properties", "-p", help=PROPERTIES_HELP),
    env: Optional[str] = RUN_ENV,
    output: Path = typer.Option(..., "--output", "-o", help="The HTML report to write (its "
                                "viewer pages go into NAME_files/ beside it)."),
    resimulate: bool = typer.Option(False, "--resimulate", help="Re-run the episodes the "
                                    "shield would have blocked, under the shield (as replay "
                                    "--resimulate): the report's headline says how many "
                                    "crashes it would have prevented."),
    agent: Optional[Path] = typer.Option(None, "--agent", help="For --resimulate: the agent "
                                         "that recorded the episodes (default: the bundled "
                                         "agent of that name)."),
    force: bool = FORCE,
) -> None:
    """Write an HTML validation report: the runs side by side, replay and re-simulation,
    comparisons, statistics with plots, episode pictures and viewers."""
    from ..checking.shield import load_shield
    from ..outputs import input_paths
    from ..render.report import check_report_output, render_report
    from ..stats.formulas import default_set
    from ..stats.properties import load_properties
    from ..stats.validation import validate

    inputs = input_paths(shield, properties)
    check_report_output(output, [*runs, *inputs], force=force)
    loaded = load_shield(shield) if shield else None
    adapter = run_adapter(env)
    pset, notes = (load_properties(properties), []) if properties else default_set(runs, adapter)
    for line in notes:
        err.print(f"note: {line}")
    validation = validate(runs, shield=loaded, pset=pset, resimulate=resimulate, agent=agent,
                          env=env, adapter=adapter, salvage=salvage)
    page, pages = render_report(validation, output, force=force, inputs=inputs,
                                adapter=adapter, salvage=salvage)
    out.print(f"wrote {page} and {pages} episode page(s)", markup=False)
