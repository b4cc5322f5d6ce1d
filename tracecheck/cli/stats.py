"""Statistics commands: stats, simulate."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..outputs import input_paths
from .common import (external_settings, app, out, err, warn, Executor, FILE_EXECUTOR,
                     RAY_ADDRESS, OutputFormat, FORMAT, JSON, output_format, progress, Interval,
                     record_settings, PROPERTIES_HELP, SALVAGE, RUN_ENV, run_adapter, FORCE,
                     WORKERS)
from .run_options import EXTERNAL_MODE, RunOptions, run_options


def _print_stats(result: dict, fmt: OutputFormat, plot: Optional[Path],
                 force: bool = False) -> None:
    from ..render.emit import emit
    from ..render.stats_text import StatsOutput, stats_plots

    warn(result["warnings"])
    if plot is not None:
        written = stats_plots(result, plot, force=force)
        err.print(f"wrote {len(written)} plot file(s) into {plot}")
    emit(StatsOutput(result), fmt.value, out)


@app.command("stats")
def stats_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files: one column each."),
    salvage: bool = SALVAGE,
    properties: Optional[str] = typer.Option(
        None, "--properties", "-p", help=PROPERTIES_HELP),
    env: Optional[str] = RUN_ENV,
    names: Optional[list[str]] = typer.Option(None, "--names",
                                              help="Only these metrics and properties."),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
    interval: Interval = typer.Option(Interval.wilson, "--interval",
                                      help="Interval for property shares."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write PNG and SVG plots into "
                                        "this folder (a new or empty one, or --force)."),
    force: bool = FORCE,
    executor: Executor = FILE_EXECUTOR,
    ray_address: Optional[str] = RAY_ADDRESS,
    workers: int = WORKERS,
) -> None:
    """Estimate metrics and property shares per run, side by side like the paper's tables."""
    fmt = output_format(fmt, as_json)
    from ..stats.properties import load_properties
    from ..stats.estimates import statistics
    from ..stats.formulas import default_set

    from ..render.stats_text import check_plot_folder

    if plot is not None:  # before the statistics are computed
        check_plot_folder(plot, [*runs, *input_paths(properties)], force)
    adapter = run_adapter(env)
    pset, notes = (load_properties(properties), []) if properties else default_set(runs, adapter)
    pset = pset.select(names)
    for line in notes:
        err.print(f"note: {line}")
    result = statistics(runs, pset, interval=interval.value, executor=executor.value,
                        ray_address=ray_address, adapter=adapter, salvage=salvage,
                        workers=workers)
    _print_stats(result, fmt, plot, force)



@app.command("simulate")
@run_options
def simulate_cmd(
    run: RunOptions,
    episodes: int = typer.Option(..., "--episodes", "-n", min=1,
                                 help="Episodes (at most, with --until-ci-width)."),
    properties: Optional[str] = typer.Option(
        None, "--properties", "-p", help=PROPERTIES_HELP),
    until_ci_width: Optional[float] = typer.Option(
        None, "--until-ci-width", help="Stop once every property's 95 % interval is narrower "
                                       "than this (a share, e.g. 0.1)."),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Monte Carlo: record episodes and validate them in one go (SimB-style)."""
    from ..stats.properties import load_properties, with_generic
    from ..live.record import resolve
    from ..interop.foxglove import FoxgloveChannels
    from ..stats.simulate import simulate

    fmt = output_format(fmt, as_json)
    if run.mode == EXTERNAL_MODE:
        from ..stats.simulate import simulate_external

        settings, machine = external_settings(run, episodes)
        pset = load_properties(properties) if properties else with_generic(None)
        with progress("simulating", episodes) as advance:
            result = simulate_external(settings, machine, run.output, pset,
                                       until_width=until_ci_width, force=run.force,
                                       inputs=input_paths(properties),
                                       progress=lambda ep: advance(),
                                       channels=FoxgloveChannels)
        _print_simulation(result, fmt)
        return
    settings = record_settings(run, episodes)
    from ..stats.formulas import adapter_set

    pset = load_properties(properties) if properties else adapter_set(resolve(settings)[0])
    with progress("simulating", episodes) as advance:
        result = simulate(settings, run.output, pset, until_width=until_ci_width,
                          force=run.force, inputs=input_paths(properties),
                          progress=lambda ep: advance(),
                          channels=FoxgloveChannels.drawn_by(settings.env))
    _print_simulation(result, fmt)


def _print_simulation(result, fmt) -> None:
    seq = result.get("sequential")
    if seq is not None:
        widths = ", ".join(f"{k} {v:.3f}" for k, v in seq["widths"].items())
        err.print(f"sequential rule: {seq['rule']}; {seq['looks']} look(s), "
                  f"{'stopped early' if seq['stopped_early'] else 'ran to the end'}; "
                  f"widths {widths}", highlight=False, markup=False)
    _print_stats(result, fmt, None)
