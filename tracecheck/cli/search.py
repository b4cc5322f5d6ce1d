"""Commands that search episodes on purpose: falsify."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from ..outputs import input_paths
from .common import FORMAT, JSON, OutputFormat, app, err, out, output_format, progress, \
    record_settings
from .run_options import EXTERNAL_MODE, RunOptions, run_options


@app.command("falsify")
@run_options
def falsify_cmd(
    run: RunOptions,
    param: list[str] = typer.Option(
        [], "--param", help="What the search varies: NAME=LO..HI (a range of numbers) or "
        "NAME={a,b} (choices); NAME is seed (the episode's seed), a setting of the "
        "environment (--env-config keys) or one of its reset parameters (what an episode "
        "starts from, tracecheck envs lists them). Repeat for several."),
    prop: Optional[str] = typer.Option(
        None, "--property", help="The property each episode must keep: an STL formula "
        "(G({d > 2.0}): its robustness guides the search) or an LTL one (G({Crash = "
        "FALSE})), read in the shield's machine (the environment's own where --shield none). "
        "Default: the episode does not crash."),
    budget: int = typer.Option(100, "--budget", min=1, help="Episodes per search."),
    optimizer: str = typer.Option("tpe", "--optimizer", help="random, halton (scipy's "
                                  "low-discrepancy sequence), cmaes (pycma), tpe (optuna) or "
                                  "gp (optuna's Gaussian process, with PyTorch), or one an "
                                  "installed package adds."),
    repeat: int = typer.Option(1, "--repeat", min=1, help="Independent searches (the "
                               "falsification rate is over them)."),
    search_seed: int = typer.Option(0, "--search-seed", min=0, max=2**32 - 1,
                                    help="The search's own seed (repetition r: seed + r)."),
    baseline: bool = typer.Option(True, "--baseline/--no-baseline", help="Also run uniform "
                                  "random on the same budget and repetitions, in the same "
                                  "file (default: on)."),
    attribute: int = typer.Option(
        5, "--attribute", min=0, help="Attribute each violation by branching "
        "re-simulation at this many steps before it (shield gap, unavoidable under the "
        "shield, agent's choice); 0: not attributed."),
    guide: str = typer.Option(
        "margin", "--guide", help="margin (the default): an episode that keeps a true/false "
        "property (LTL, or no crash) is valued by how close the actions taken came to their "
        "shield guards flipping, which guides the search; none: all such episodes +1."),
    stop_at_first: bool = typer.Option(
        False, "--stop-at-first", help="End each search at its first violation (ARCH-COMP's "
        "protocol): the figures are the same, the rest of its budget is not run."),
    plot: Optional[Path] = typer.Option(
        None, "--plot", help="Also draw the objective over the search (the lowest value so "
        "far per optimiser and search) to this .png or .svg file."),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Search the episode seed and the environment's settings for episodes where the agent
    under its shield violates a property, with an optimiser (TPE, CMA-ES, Halton, random);
    every evaluation is a recorded episode that replays and re-simulates."""
    from ..interop.foxglove import FoxgloveChannels
    from ..render.emit import emit
    from ..render.falsify_text import FalsifyOutput
    from ..search.falsify import FalsifySettings, falsify

    fmt = output_format(fmt, as_json)
    if run.mode == EXTERNAL_MODE:
        raise InputError("falsify runs an agent itself (--agent); an --external script "
                         "chooses its own scenarios")
    if run.seed is not None and any(p.partition("=")[0].strip() == "seed" for p in param):
        raise InputError(f"--seed {run.seed} and --param seed=…: the search chooses each "
                         "episode's seed; give one of the two")
    settings = FalsifySettings(record_settings(run, budget), tuple(param), prop, budget,
                               optimizer, repeat, search_seed, baseline, attribute, guide,
                               stop_at_first)
    if plot is not None:
        from ..outputs import check_output
        from ..render.falsify_plot import PLOT_SUFFIXES

        if plot.suffix.lower() not in PLOT_SUFFIXES:
            raise InputError(f"--plot {plot}: a plot is written as .png or .svg",
                             hint="e.g. --plot runs/falsify.png")
        check_output(plot, [run.output, *input_paths(run.agent, run.shield)],
                     force=run.force, what="--plot")
        if plot.resolve() == run.output.resolve():
            raise InputError(f"--plot {plot} is the run file -o writes")
    total = budget * repeat * len(settings.optimizers())
    existed = run.output.exists()
    seen = {"episodes": 0, "violations": 0}
    with progress("falsifying", total, detail=", {task.fields[found]} violation(s)",
                  found=0) as advance:

        def report(ep) -> None:
            seen["episodes"] += 1
            seen["violations"] += bool(ep.search and ep.search.violated)
            advance(found=seen["violations"])

        try:
            result = falsify(settings, run.output, report, force=run.force,
                             channels=FoxgloveChannels.drawn_by(settings.record.env))
        except KeyboardInterrupt:
            err.print(f"interrupted: {run.output} keeps every finished episode"
                      if seen["episodes"] else
                      f"interrupted before an episode was finished: {run.output} was not "
                      + ("changed" if existed else "written"), markup=False)
            raise typer.Exit(130) from None
    if plot is not None:
        from ..render.falsify_plot import objective_plot

        objective_plot(result.values, plot, title=f"{result.property} ({result.logic})")
    emit(FalsifyOutput(result, str(plot) if plot is not None else None), fmt.value, out)
