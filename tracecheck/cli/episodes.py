"""Commands on run files and traces: import, export, info."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from .common import app, out, err, warn, load_model, SALVAGE


import_app = typer.Typer(help="Import ProB/SimB traces into an MCAP run file.",
                         no_args_is_help=True)
export_app = typer.Typer(help="Export episodes as ProB/SimB traces.", no_args_is_help=True)
app.add_typer(import_app, name="import")
app.add_typer(export_app, name="export")


def _vocabulary(model: Optional[Path]):
    from ..episodes.model import HIGHWAY
    from ..interop.common import vocabulary_of

    if model is None:
        return HIGHWAY, None
    machine = load_model(model)
    return vocabulary_of(machine), machine


def _import(kind: str, paths: list[Path], output: Path, model: Optional[Path]) -> None:
    from ..episodes.files import write_run
    from ..episodes.writer import new_header
    from ..interop import import_prob2trace, import_simb

    vocab, machine = _vocabulary(model)
    reader = import_simb if kind == "simb" else import_prob2trace
    header = new_header(f"imported-{kind}", model_name=vocab.name,
                        variables=list(vocab.variables), actions=list(vocab.actions),
                        shield_name=machine.name if machine is not None else None,
                        shield_sha256=machine.sha256 if machine is not None else None)
    existed = output.exists()
    try:
        episodes, steps, crashes = write_run(output, header,
                                             reader(paths, vocab=vocab, machine=machine))
    except KeyboardInterrupt:
        err.print(f"interrupted: {output} was not " +
                  ("changed" if existed else "written"), markup=False)
        raise typer.Exit(130) from None
    out.print(f"imported {episodes} episode(s), {steps} step(s), {crashes} crash(es) "
              f"-> {output}", markup=False)


_OUTPUT = typer.Option(..., "--output", "-o", help="The MCAP file to write.")
_MODEL = typer.Option(None, "--model", "-m",
                      help="Check names and types against this machine instead of the "
                           "paper's highway vocabulary.")


@import_app.command("simb")
def import_simb_cmd(
    paths: list[Path] = typer.Argument(..., help="Timed_Simulation_N.json files or folders."),
    output: Path = _OUTPUT,
    model: Optional[Path] = _MODEL,
) -> None:
    """Import SimB timed-simulation traces."""
    _import("simb", paths, output, model)


@import_app.command("prob2trace")
def import_prob2trace_cmd(
    paths: list[Path] = typer.Argument(..., help=".prob2trace files or folders."),
    output: Path = _OUTPUT,
    model: Optional[Path] = _MODEL,
) -> None:
    """Import ProB2 trace files (one episode each; 1 s between steps)."""
    _import("prob2trace", paths, output, model)


def _episodes(run: Path, only: Optional[set[int]] = None) -> list:
    from ..episodes.reader import read_run

    result = read_run(run, only)
    warn(result.warnings)
    if not result.episodes:
        raise InputError(f"{run} holds no complete episode")
    return result.episodes, result.header


@export_app.command("prob2trace")
def export_prob2trace_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    salvage: bool = SALVAGE,
    episode: int = typer.Option(..., "--episode", "-e", help="The episode number."),
    output: Path = typer.Option(..., "--output", "-o", help="The .prob2trace file to write."),
) -> None:
    """Export one episode as a ProB2 trace (opens in ProB2-UI)."""
    from ..episodes.model import HIGHWAY, Vocabulary
    from ..interop import export_prob2trace

    from ..episodes.columns import read_columns

    from ..episodes.reader import read_run

    result = read_run(run, {episode})
    chosen = result.episodes
    if not chosen:
        ids = [int(i) for i in read_columns(run).episode_ids]
        if not ids:
            raise InputError(f"{run} holds no complete episode")
        raise InputError(f"{run} has no episode {episode}; it has {_ranges(ids)}")
    warn(result.warnings)
    header = result.header
    vocab = HIGHWAY if header is None or not header.model_name else Vocabulary(
        HIGHWAY.variables, HIGHWAY.actions, header.model_name)
    export_prob2trace(chosen[0], output, vocab)
    out.print(f"wrote episode {episode} ({chosen[0].end.steps} steps) -> {output}",
              markup=False)


@export_app.command("simb")
def export_simb_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    salvage: bool = SALVAGE,
    output: Path = typer.Option(..., "--output", "-o", help="The folder to write into."),
    force: bool = typer.Option(False, "--force", help="Write into a folder that is not empty: "
                               "its SimB traces are removed first."),
) -> None:
    """Export every episode as a SimB timed trace (Timed_Simulation_N.json)."""
    from ..interop import export_simb

    if output.exists() and not output.is_dir():
        raise InputError(f"the output {output} is a file; give a folder")
    if output.is_dir() and any(output.iterdir()):
        if not force:
            raise InputError(f"the folder {output} is not empty; a later import would mix its "
                             "files in", hint="give an empty or new folder, or --force to "
                                              "remove its SimB traces first")
        for old in output.glob("Timed_Simulation_*.json"):
            old.unlink()
    episodes, header = _episodes(run)
    written = export_simb(episodes, output, (header.model_name if header and header.model_name
                                             else "HighwayEnvironment"))
    out.print(f"wrote {len(written)} SimB trace(s) -> {output}", markup=False)


def _ranges(ids: list[int]) -> str:
    ids = sorted(ids)
    parts, start = [], ids[0]
    for a, b in zip(ids, ids[1:] + [None]):
        if b != a + 1:
            parts.append(str(start) if start == a else f"{start}-{a}")
            start = b
    return ", ".join(parts)


@app.command("info")
def info(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    salvage: bool = SALVAGE,
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Summarise run files: episodes, steps, crashes, sources, agents and shields."""
    from ..episodes.summary import summarise

    summary = summarise(runs)
    warn(summary["warnings"])
    if as_json:
        out.print_json(json.dumps(summary))
        return
    for f in summary["files"]:
        model = f", model {f['model_name']}" if f["model_name"] else ""
        out.print(f"{f['path']}: {f['source']}, {f['episodes']} episode(s), {f['steps']} "
                  f"step(s), {f['crashes']} crash(es){model}", markup=False)
    rate = summary["crashes"] / summary["episodes"] if summary["episodes"] else 0.0
    out.print(f"total: {summary['episodes']} episode(s), {summary['steps']} step(s), "
              f"{summary['crashes']} crash(es) ({rate:.1%})", markup=False)
    for key in ("agents", "shields"):
        if summary[key]:
            out.print(f"{key}: {', '.join(summary[key])}", markup=False)
