"""Commands that change a shield's numbers against recordings: tune, repair."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from ..outputs import input_paths
from .common import FORCE, FORMAT, JSON, OutputFormat, app, out, output_format, progress, \
    run_shield, SHIELD_HELP, warn

PARAM = typer.Option([], "--param", help="The number to tune: NAME[=LO..HI], NAME a CONSTANT "
                     "the PROPERTIES give by an equality (Limit = 4.0) or a DEFINITION that "
                     "is a number (default range: half to one and a half times its value). "
                     "Two numbers (--param or --literal twice): on --grid N values of each, "
                     "exact along each line.")
LITERAL = typer.Option([], "--literal", help="Or a number written in a guard or definition: "
                       "SCOPE:VALUE[@LINE:COLUMN][=LO..HI], e.g. Brake:40.0=20..60 (the error "
                       "lists the numbers of SCOPE where VALUE is not one of them).")
PLOT = typer.Option(None, "--plot", help="Also draw the figures over the range and the Pareto "
                    "front, the machine's value marked, to this .png or .svg file.")


def parse_range(spec: str, what: str) -> tuple[str, Optional[tuple[float, float]]]:
    """``NAME`` or ``NAME=LO..HI`` as (name, (lo, hi) or None)."""
    name, sep, rng = spec.rpartition("=") if "=" in spec else (spec, "", "")
    if not sep:
        return spec.strip(), None
    lo, dots, hi = rng.partition("..")
    try:
        low, high = float(lo), float(hi)
    except ValueError:
        low = high = None
    if not dots or low is None or high is None:
        raise InputError(f"{what} {spec}: the range must be LO..HI with two numbers "
                         f"(e.g. {name}=2.0..8.0)")
    if not (math.isfinite(low) and math.isfinite(high)):
        raise InputError(f"{what} {spec}: the range must be finite numbers")
    if not low <= high:
        raise InputError(f"{what} {spec}: the range goes down ({low} > {high})")
    return name.strip(), (low, high)


def targets_of(shield, params: list[str], literals: list[str]) -> list:
    """(target, low, high) for each ``--param`` and ``--literal``: one or two of them."""
    given = [(p, None) for p in params] + [(None, lit) for lit in literals]
    if not 1 <= len(given) <= 2:
        raise InputError("give the number to tune: --param NAME[=LO..HI] or --literal "
                         "SCOPE:VALUE[=LO..HI] (one, or two for a grid)")
    return [target_of(shield, p, lit) for p, lit in given]


def target_of(shield, param: Optional[str], literal: Optional[str]):
    """The target and its range from ``--param`` or ``--literal`` (one of them)."""
    from ..search.tune_target import check_range, resolve_target

    spec, what = (param, "--param") if param is not None else (literal, "--literal")
    name, rng = parse_range(spec, what)
    target = resolve_target(shield.machine, **({"param": name} if param is not None
                                               else {"literal": name}))
    v = float(target.value)
    low, high = rng if rng is not None else ((v - abs(v) / 2, v + abs(v) / 2) if v else
                                             (-1.0, 1.0))
    if target.integer and rng is None:
        low, high = float(int(low)), float(int(high) + (high != int(high)))
    check_range(shield.machine, target, low, high)
    return target, low, high


def _values(at: list[str], what: str) -> list:
    found = []
    for a in at:
        if a.strip() == "knee":
            found.append("knee")
            continue
        try:
            found.append(float(a))
        except ValueError:
            raise InputError(f"{what} {a}: a number, or knee (the Pareto front's)") from None
    return found


def _check_plot(plot: Optional[Path], inputs, force: bool) -> None:
    if plot is None:
        return
    from ..outputs import check_output
    from ..render.tune_plot import PLOT_SUFFIXES

    if plot.suffix.lower() not in PLOT_SUFFIXES:
        raise InputError(f"--plot {plot}: a plot is written as .png or .svg",
                         hint="e.g. --plot tune.png")
    check_output(plot, inputs, force=force, what="--plot")


@app.command("tune")
def tune_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    shield: str = typer.Option(..., "--shield", "-s", help=SHIELD_HELP),
    param: list[str] = PARAM,
    literal: list[str] = LITERAL,
    grid: Optional[int] = typer.Option(None, "--grid", min=2, max=10_000, help="The figures at "
                                       "N values evenly over the range only, each by replay of "
                                       "the machine with it written in (for a number the guards "
                                       "do not read linearly)."),
    at: list[str] = typer.Option([], "--at", help="A value to report on its own (repeatable; "
                                 "knee: the Pareto front's)."),
    resimulate: int = typer.Option(0, "--resimulate", min=0, help="Re-run this many recorded "
                                   "episodes from their seeds under the shield with each --at "
                                   "value (and the machine's own): crashes and interventions, "
                                   "paired."),
    agent: Optional[Path] = typer.Option(None, "--agent", help="For --resimulate: the agent "
                                         "(default: the one the run names). Loading it runs "
                                         "code from the file."),
    env: Optional[str] = typer.Option(None, "--env", help="For --resimulate: the environment "
                                      "adapter (default: the installed one the run names)."),
    plot: Optional[Path] = PLOT,
    force: bool = FORCE,
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Tune one number of a shield against recorded episodes: for every value of it, how many
    steps the shield would block, in how many episodes, how many crashes came at or after a
    blocked step, how many states are deadlocks — exact where the guards are linear in it —
    and the Pareto front of interventions against crashes."""
    from ..render.emit import emit
    from ..render.tune_text import TuneOutput
    from ..search.tuning import tune, tune_grid

    fmt = output_format(fmt, as_json)
    loaded = run_shield(shield, runs)
    found = targets_of(loaded, param, literal)
    values = _values(at, "--at")
    _check_plot(plot, [*runs, *input_paths(shield)], force)
    if len(found) == 2:
        _pair(runs, loaded, found, grid, values, resimulate, plot, fmt)
        return
    target, low, high = found[0]
    fixed = [v for v in values if v != "knee"]
    for v in fixed:
        if not low <= v <= high:
            raise InputError(f"--at {v}: outside the range tuned ({low}..{high})")
        if target.integer and v != int(v):
            raise InputError(f"--at {v}: {target.label} is an INTEGER; give a whole number")
    if grid is not None:
        from ..search.tune_pair import grid_values

        result = tune_grid(runs, loaded, target,
                           grid_values(low, high, grid, target.integer) + fixed)
    else:
        result = tune(runs, loaded, target, low, high, at=fixed, knee_too="knee" in values)
    warn(result.warnings)
    resim = None
    if resimulate:
        from ..search.tune_resim import resimulate_values

        chosen = list(dict.fromkeys(
            result.knee.value if v == "knee" else v for v in values
            if v != "knee" or result.knee is not None))
        total = resimulate * len(set([float(target.value), *chosen]))
        with progress("re-simulating", total) as advance:
            resim = resimulate_values(runs, loaded, target, chosen, resimulate, agent=agent,
                                      env=env, progress=lambda: advance())
    if plot is not None:
        from ..render.tune_plot import tune_plot

        tune_plot(result, plot)
    emit(TuneOutput(result, str(plot) if plot is not None else None, resim), fmt.value, out)


def _pair(runs, shield, found, grid, values, resimulate, plot, fmt) -> None:
    """Two numbers: on a grid, exact along each line."""
    from ..render.emit import emit
    from ..render.tune_text import PairOutput
    from ..search.tune_pair import tune_pair

    if grid is None:
        raise InputError("two numbers are tuned on a grid: give --grid N (N values of each)")
    if values or resimulate or plot is not None:
        raise InputError("--at, --resimulate and --plot take one number; with two, the grid's "
                         "crossings are the values reported")
    result = tune_pair(runs, shield, [t for t, _, _ in found], [(lo, hi) for _, lo, hi in found],
                       grid)
    emit(PairOutput(result), fmt.value, out)


@app.command("repair")
def repair_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files: one has the crash to close."),
    shield: str = typer.Option(..., "--shield", "-s", help=SHIELD_HELP),
    output: Path = typer.Option(..., "--output", "-o", help="Where the repaired machine is "
                                "written (.mch; a new file, or --force)."),
    param: list[str] = typer.Option([], "--param", help="A number that may change: a CONSTANT "
                                    "or numeric DEFINITION (repeatable; default: every one)."),
    literal: list[str] = typer.Option([], "--literal", help="A number written in a guard that "
                                      "may change: SCOPE:VALUE[@LINE:COLUMN] (repeatable)."),
    episode: Optional[int] = typer.Option(None, "--episode", help="The crash to close (default: "
                                          "the first the shield did not block)."),
    step: Optional[int] = typer.Option(None, "--step", min=1, help="The step whose action to "
                                       "block (default: the one falsify's attribution names, "
                                       "else the crash step)."),
    timeout: float = typer.Option(10.0, "--timeout", min=0.001, help="Seconds the solver may "
                                  "take per question (prove --deadlock-free, diff --symbolic)."),
    force: bool = FORCE,
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Close a gap of a shield: the smallest change of one of its numbers that blocks the
    action that sealed a crash it did not prevent; the repaired machine written, checked for
    deadlock freedom and compared with the original over every state."""
    from ..outputs import check_output
    from ..render.emit import emit
    from ..render.tune_text import RepairOutput
    from ..search.repair import find_gap, repair

    fmt = output_format(fmt, as_json)
    if output.suffix != ".mch":
        raise InputError(f"--output {output}: the repaired machine is a .mch file")
    check_output(output, [*runs, *input_paths(shield)], force=force, what="--output")
    loaded = run_shield(shield, runs)
    gap = find_gap([str(r) for r in runs], loaded, episode, step)
    result = repair([str(r) for r in runs], loaded, gap, names=param, literals=literal,
                    output=output, timeout_s=timeout)
    emit(RepairOutput(result), fmt.value, out)
    if result.chosen is None:
        raise typer.Exit(1)
