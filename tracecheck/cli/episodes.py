"""Commands on run files and traces: import, export, info."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from ..outputs import input_paths
from .common import (app, out, err, warn, load_model, SALVAGE, FORMAT, JSON, OutputFormat,
                     output_format, progress, FORCE, say, WORKERS, RUN_ENV, run_adapter)


import_app = typer.Typer(help="Import ProB/SimB traces or a Minari dataset into an MCAP run "
                                "file.",
                         no_args_is_help=True)
export_app = typer.Typer(help="Export episodes: ProB/SimB traces, Foxglove channels, Minari "
                                "datasets.", no_args_is_help=True)
app.add_typer(import_app, name="import")
app.add_typer(export_app, name="export")


def _vocabulary(kind: str, paths: list[Path], model: Optional[Path], env: Optional[str]):
    """The vocabulary traces are read in, and the machine they are checked against: the
    machine ``--model`` names, else the environment ``--env`` names, else the installed
    environment whose variables the first trace's states have (said on stderr)."""
    from ..interop.common import trace_variables, vocabulary_of
    from ..live.adapter import claiming_adapter, load_adapter

    if model is not None:
        machine = load_model(model)
        return vocabulary_of(machine), machine, None
    if env is not None:
        adapter = load_adapter(env)
        return adapter.vocabulary(), None, adapter.name
    variables = trace_variables(kind, paths)
    adapter = claiming_adapter(variables) if variables else None
    if adapter is None:
        raise InputError(f"no --model or --env given, and no installed environment claims "
                         f"traces of these variables ({', '.join(variables) or 'none found'}) "
                         "as its own", hint="give --env NAME to read them in an installed "
                         "environment's vocabulary, or --model MACHINE.mch (the traces' "
                         "machine)")
    err.print(f"the traces' states are read in the vocabulary of the environment "
              f"{adapter.name} (their variables are its; --model or --env chooses another)",
              markup=False, highlight=False)
    return adapter.vocabulary(), None, adapter.name


def _import(kind: str, paths: list[Path], output: Path, model: Optional[Path],
            force: bool, env: Optional[str] = None, workers: int = 1) -> None:
    from ..episodes.files import check_run_output, write_run
    from ..episodes.writer import new_header
    from ..interop.common import expand_paths
    from ..interop.parallel import read_in_workers
    from ..interop.prob2trace import read_prob2trace
    from ..interop.simb import read_simb

    inputs = [*paths, *input_paths(model)]
    check_run_output(output, inputs, force=force)
    vocab, machine, environment = _vocabulary(kind, paths, model, env)
    read, pattern = (read_simb, "*.json") if kind == "simb" else \
        (read_prob2trace, "*.prob2trace")
    files = expand_paths(paths, pattern)
    header = new_header(f"imported-{kind}", model_name=vocab.name, environment=environment,
                        variables=list(vocab.variables), actions=list(vocab.actions),
                        shield_name=machine.name if machine is not None else None,
                        shield_sha256=machine.sha256 if machine is not None else None)
    with _writing(output, f"importing {kind} traces") as advance, \
            read_in_workers(read, files, vocab, machine, workers=workers) as (read_, encode):
        episodes, steps, crashes = write_run(output, header, _counted(read_, advance),
                                             force=force, inputs=inputs, encode=encode)
    out.print(f"imported {episodes} episode(s), {steps} step(s), {crashes} crash(es) "
              f"-> {output}", markup=False)


@contextmanager
def _writing(output: Path, label: str, total: Optional[int] = None):
    """A progress bar while ``output`` is written (all or nothing, by ``write_run``); yields
    its ``advance``. Ctrl-C says that the output was not written or changed (exit 130)."""
    existed = output.exists()
    try:
        with progress(label, total) as advance:
            yield advance
    except KeyboardInterrupt:
        err.print(f"interrupted: {output} was not " + ("changed" if existed else "written"))
        raise typer.Exit(130) from None


def _counted(episodes, advance):
    """``episodes``, calling ``advance()`` after each (for a progress bar)."""
    for episode in episodes:
        yield episode
        advance()


_OUTPUT = typer.Option(..., "--output", "-o", help="The MCAP file to write.")
_MODEL = typer.Option(None, "--model", "-m",
                      help="Check names and types against this machine (default: the "
                           "vocabulary of the installed environment that claims the traces' "
                           "variables as its own, see `tracecheck envs`).")
_IMPORT_ENV = typer.Option(None, "--env", help="Read the states in this installed "
                           "environment's vocabulary (its variables and actions).")


@import_app.command("simb")
def import_simb_cmd(
    paths: list[Path] = typer.Argument(..., help="Timed_Simulation_N.json files or folders."),
    output: Path = _OUTPUT,
    model: Optional[Path] = _MODEL,
    env: Optional[str] = _IMPORT_ENV,
    force: bool = FORCE,
    workers: int = WORKERS,
) -> None:
    """Import SimB timed-simulation traces (with --workers, read and encoded in that many
    processes: the same file)."""
    _import("simb", paths, output, model, force, env, workers)


@import_app.command("prob2trace")
def import_prob2trace_cmd(
    paths: list[Path] = typer.Argument(..., help=".prob2trace files or folders."),
    output: Path = _OUTPUT,
    model: Optional[Path] = _MODEL,
    env: Optional[str] = _IMPORT_ENV,
    force: bool = FORCE,
    workers: int = WORKERS,
) -> None:
    """Import ProB2 trace files (one episode each; 1 s between steps; with --workers, read
    and encoded in that many processes: the same file)."""
    _import("prob2trace", paths, output, model, force, env, workers)


@import_app.command("minari")
def import_minari_cmd(
    dataset: str = typer.Argument(..., help="A local Minari dataset id, e.g. "
                                            "tracecheck/corridor/base-v0."),
    env: str = typer.Option(..., "--env", help="The adapter that makes the dataset's "
                            "observations B states: an installed one (see `tracecheck envs`) "
                            "or package.module:Class (importing it runs its code)."),
    output: Path = _OUTPUT,
    force: bool = FORCE,
) -> None:
    """Import a Minari dataset, so that replay, diff and stats can check it against a shield."""
    from ..episodes.files import check_run_output, write_run
    from ..interop.minari import dataset_folder
    from ..interop.minari_import import import_minari

    inputs = [dataset_folder(dataset)]  # its metadata.json, main_data.hdf5: never an output
    check_run_output(output, inputs, force=force)
    with _writing(output, f"importing {dataset}") as advance:
        header, episodes = import_minari(dataset, env, progress=advance)
        n, steps, crashes = write_run(output, header, episodes, force=force, inputs=inputs)
    say(f"imported {n} episode(s), {steps} step(s), {crashes} crash(es) -> {output}")


@export_app.command("minari")
def export_minari_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file recorded by tracecheck (with "
                                         "observations)."),
    salvage: bool = SALVAGE,
    dataset_id: str = typer.Option(..., "--dataset-id", help="NAMESPACE/ENV/NAME-v0: the "
                                   "local Minari dataset to create (MINARI_DATASETS_PATH, "
                                   "default ~/.minari/datasets)."),
    env: Optional[str] = typer.Option(None, "--env", help="The environment's adapter "
                                      "(default: the installed one the file names); "
                                      "package.module:Class imports it, which runs its code."),
) -> None:
    """Export a run as a Minari dataset.

    Observations, actions, rewards, terminations, truncations, seeds, and per step the
    shield's mask, interventions, deadlocks and B states (see docs/ecosystem.md)."""
    from ..interop.minari import export_minari

    with progress("exporting to Minari") as advance:
        dataset = export_minari(run, dataset_id, env=env, progress=advance, salvage=salvage)
    say(f"wrote {dataset.total_episodes} episode(s), {dataset.total_steps} step(s) -> Minari "
          f"dataset {dataset_id}")


def _episodes(run: Path, salvage: bool) -> list:
    from ..episodes.reader import read_run

    result = read_run(run, salvage=salvage)
    warn(result.warnings)
    if not result.episodes:
        raise InputError(f"{run} holds no complete episode")
    return result.episodes, result.header


#: ``--lossy`` of the trace exports (ProB, SimB): states and actions only
LOSSY = typer.Option(False, "--lossy", help="Export the states and actions even where the "
                     "trace format has no place for the run's crashes, rewards or proposals "
                     "(refused without it); what is left out is said on stderr.")


def _say_lossy(episodes, fmt: str, lossy: bool) -> None:
    from ..interop.common import lossy as dropped

    if lossy:
        for line in dropped(episodes, fmt):
            err.print(f"note: {line}: left out (--lossy)", markup=False, highlight=False)


@export_app.command("prob2trace")
def export_prob2trace_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    salvage: bool = SALVAGE,
    episode: int = typer.Option(..., "--episode", "-e", help="The episode number."),
    output: Path = typer.Option(..., "--output", "-o", help="The .prob2trace file to write."),
    force: bool = FORCE,
    lossy: bool = LOSSY,
) -> None:
    """Export one episode as a ProB2 trace (opens in ProB2-UI)."""
    from ..episodes.reader import find_episode, read_run
    from ..interop import export_prob2trace
    from ..outputs import check_output

    check_output(output, [run], force=force, example="episode.prob2trace")
    result = read_run(run, {episode}, salvage=salvage)
    chosen = find_episode(run, result, episode, salvage)
    warn(result.warnings)
    header = result.header
    vocab = _run_vocabulary(header)
    export_prob2trace(chosen, output, vocab, force=force, inputs=[run], lossy=lossy)
    _say_lossy([chosen], "a ProB2 trace", lossy)
    out.print(f"wrote episode {episode} ({chosen.end.steps} steps) -> {output}",
              markup=False)


def _run_vocabulary(header):
    """A run's vocabulary for its traces: its header's variables, actions and machine, and
    the set of elements its environment's traces list (where that is installed)."""
    from ..episodes.vocabulary import Vocabulary
    from ..live.adapter import run_adapter

    adapter = run_adapter(header.environment, tuple(header.variables or ())) \
        if header is not None else None
    own = adapter.vocabulary() if adapter is not None else None
    name = (header.model_name if header is not None and header.model_name
            else own.name if own is not None else "unnamed")
    return Vocabulary(tuple(header.variables or ()) if header is not None else (),
                      tuple(header.actions or ()) if header is not None else (), name,
                      own.set_name if own is not None else "")


@export_app.command("simb")
def export_simb_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    salvage: bool = SALVAGE,
    output: Path = typer.Option(..., "--output", "-o", help="The folder to write into (a new "
                                "or empty one, or --force)."),
    force: bool = typer.Option(False, "--force", help="Replace a folder of SimB traces: the "
                               "old traces are removed only once the new ones are all "
                               "written (a folder that holds other files is refused)."),
    lossy: bool = LOSSY,
) -> None:
    """Export every episode as a SimB timed trace (Timed_Simulation_N.json)."""
    from ..interop import export_simb
    from ..interop.simb import check_simb_folder

    check_simb_folder(output, [run], force=force)
    episodes, header = _episodes(run, salvage)
    written = export_simb(episodes, output, (header.model_name if header and header.model_name
                                             else _run_vocabulary(header).name), force=force,
                          inputs=[run], lossy=lossy)
    _say_lossy(episodes, "a SimB timed trace", lossy)
    out.print(f"wrote {len(written)} SimB trace(s) -> {output}", markup=False)


@export_app.command("foxglove")
def export_foxglove_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file (recorded before Foxglove's "
                                         "channels were written, or imported)."),
    salvage: bool = SALVAGE,
    output: Path = typer.Option(..., "--output", "-o", help="The MCAP file to write."),
    force: bool = FORCE,
    env: Optional[str] = RUN_ENV,
) -> None:
    """Copy a run with Foxglove's own channels added.

    A 3D scene (foxglove.SceneUpdate) drawn by the run's environment adapter, a log of
    interventions, deadlocks and crashes (foxglove.Log) and scalars to plot (see
    docs/ecosystem.md)."""
    from ..episodes.files import check_run_output, write_run
    from ..interop.foxglove import FoxgloveChannels
    from ..render.scene import scene_adapter

    check_run_output(output, [run], force=force)
    run_adapter(env)  # a wrong --env said before anything is read
    read, header = _episodes(run, salvage)
    if env is None and header is not None and header.environment and \
            scene_adapter(header.environment, tuple(header.variables or ())) is None:
        warn([f"the environment {header.environment} of {run} is not installed here: the "
              "copy has no 3D scene (give its adapter with --env package.module:Class)"])
    channels = FoxgloveChannels.drawn_by(env) if env is not None else FoxgloveChannels
    with _writing(output, "adding Foxglove channels", len(read)) as advance:
        episodes, steps, _ = write_run(output, header, _counted(read, advance),
                                       channels=channels, force=force, inputs=[run])
    say(f"wrote {episodes} episode(s), {steps} step(s) with Foxglove channels -> {output}")


@app.command("info")
def info(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    salvage: bool = SALVAGE,
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Summarise run files: episodes, steps, crashes, sources, agents and shields."""
    from ..episodes.summary import summarise
    from ..render.emit import emit
    from ..render.listing_text import InfoOutput

    fmt = output_format(fmt, as_json)
    summary = summarise(runs, salvage=salvage)
    warn(summary["warnings"])
    emit(InfoOutput(summary), fmt.value, out)
