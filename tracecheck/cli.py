"""The ``tracecheck`` command: a thin Typer layer over the library.

Exit codes: 0 ok, 1 a check found problems when asked to fail, 2 bad input.
"""

from __future__ import annotations

import json
import sys
import warnings
from enum import Enum
from pathlib import Path
from typing import Any, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from . import __version__
from .errors import InputError, TracecheckError

app = typer.Typer(
    name="tracecheck",
    help="Validate reinforcement-learning agents and their B safety shields.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)


def _version(value: bool) -> None:
    if value:
        out.print(f"tracecheck {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    """Validate reinforcement-learning agents and their B safety shields."""


def _model(path: Path):
    """A machine from a path, or a built-in shield by name (none, paper, strict)."""
    from .b.machine import load_machine
    from .shield import BUILTIN_SHIELDS, load_shield

    if str(path) in BUILTIN_SHIELDS:
        return load_shield(str(path)).machine
    return load_machine(path)


@app.command("check-model")
def check_model(
    model: Path = typer.Argument(..., help="A classical B machine (.mch), or none, paper, "
                                           "strict."),
    as_json: bool = typer.Option(False, "--json", help="Print a JSON summary."),
) -> None:
    """Parse and check a B machine; list its sets, constants, variables and operations."""
    from .b.values import format_value

    machine = _model(model)
    types = machine.types
    summary = {
        "machine": machine.name,
        "file": str(model),
        "sha256": machine.sha256,
        "sets": {n: [str(e) for e in elems] for n, elems in machine.sets.items()},
        "constants": {n: format_value(v) for n, v in machine.constants.items()},
        "variables": {v: {"type": types.get(v), "description": machine.descriptions.get(v)}
                      for v in machine.variables},
        "operations": {
            name: {"guard": op.guard_source, "parameters": list(op.params)}
            for name, op in machine.operations.items()
        },
    }
    if as_json:
        out.print_json(json.dumps(summary))
        return
    out.print(f"[bold]MACHINE {machine.name}[/bold]  ({model}, sha256 {machine.sha256[:12]}…)")
    for name, elems in summary["sets"].items():
        out.print(f"  set {name} = {{{', '.join(elems)}}}", markup=False)
    for name, value in summary["constants"].items():
        out.print(f"  constant {name} = {value}", markup=False)
    table = Table("variable", "type", "description", box=None, pad_edge=False)
    for name, info in summary["variables"].items():
        table.add_row(name, info["type"] or "?", info["description"] or "")
    if machine.variables:
        out.print(table)
    for name, info in summary["operations"].items():
        guard = info["guard"] or "TRUE"
        params = f"({', '.join(info['parameters'])})" if info["parameters"] else ""
        out.print(f"  operation {name}{params}: guard {_clip(guard)}", markup=False)
    out.print(f"[green]ok[/green]: {len(machine.operations)} operation(s), "
              f"{len(machine.variables)} variable(s)")


def _clip(text: str, width: int = 100) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


@app.command("eval", context_settings={"ignore_unknown_options": True})
def eval_(
    expr: str = typer.Argument(..., help="A B predicate or expression."),
    model: Optional[Path] = typer.Option(None, "--model", "-m",
                                         help="Evaluate in this machine's scope."),
    state: Optional[Path] = typer.Option(None, "--state", "-s",
                                         help="JSON file: variable name -> B literal."),
    as_json: bool = typer.Option(False, "--json", help="Print the value as JSON."),
) -> None:
    """Evaluate a predicate or expression and print its value in B notation."""
    from .b.evaluate import Compiler
    from .b.parser import parse_formula
    from .b.scope import check_kind, expand, kind_of
    from .b.state import read_state_file
    from .b.typecheck import type_of_value, typecheck_formula
    from .b.values import format_value, to_json

    machine = _model(model) if model is not None else None
    values = read_state_file(state) if state is not None else {}
    if machine is not None:
        machine.check_state(values, where=str(state))
    try:
        node = parse_formula(expr, file="<expr>")
        if machine is not None:
            node = expand(node, machine.definitions)
        kind = kind_of(node)
        check_kind(node, kind, source=expr, context="the formula")
        names = dict(machine.type_objects) if machine is not None else {}
        owners = machine.element_sets() if machine is not None else {}
        for name, value in values.items():
            names.setdefault(name, type_of_value(value, owners))
        typecheck_formula(node, names, kind=kind, source=expr, file="<expr>")
        env = machine.env(values) if machine is not None else dict(values)
        value = Compiler(source=expr, file="<expr>").compile(node)(env)
    except TracecheckError as exc:
        raise exc.located(file="<expr>", source=expr) from None
    if as_json:
        out.print_json(json.dumps({"expression": expr, "value": format_value(value),
                                   "json": to_json(value)}))
    else:
        out.print(format_value(value), markup=False)


@app.command("guards")
def guards(
    model: Path = typer.Argument(..., help="A classical B machine (.mch)."),
    state: Path = typer.Option(..., "--state", "-s", help="JSON file: variable -> B literal."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """List the operations whose guard holds in a state."""
    from .b.state import read_state_file

    machine = _model(model)
    values = read_state_file(state)
    machine.check_state(values, where=str(state))
    missing = [v for v in machine.variables if v not in values]
    enabled = machine.enabled(values)
    ordered = [op for op in machine.operations if op in enabled]
    blocked = [op for op in machine.operations if op not in enabled]
    if as_json:
        out.print_json(json.dumps({"machine": machine.name, "enabled": ordered,
                                   "disabled": blocked, "missing_variables": missing}))
        return
    out.print(f"enabled: {', '.join(ordered) or '(none: deadlock)'}")
    out.print(f"disabled: {', '.join(blocked) or '(none)'}")


# ------------------------------------------------------------------ episodes

import_app = typer.Typer(help="Import ProB/SimB traces into an MCAP run file.",
                         no_args_is_help=True)
export_app = typer.Typer(help="Export episodes as ProB/SimB traces.", no_args_is_help=True)
app.add_typer(import_app, name="import")
app.add_typer(export_app, name="export")


def _vocabulary(model: Optional[Path]):
    from .episodes.model import HIGHWAY
    from .interop.common import vocabulary_of

    if model is None:
        return HIGHWAY, None
    machine = _model(model)
    return vocabulary_of(machine), machine


def _import(kind: str, paths: list[Path], output: Path, model: Optional[Path]) -> None:
    from .episodes.files import write_run
    from .episodes.mcap_io import new_header
    from .interop import import_prob2trace, import_simb

    vocab, machine = _vocabulary(model)
    reader = import_simb if kind == "simb" else import_prob2trace
    header = new_header(f"imported-{kind}", model_name=vocab.name,
                        variables=list(vocab.variables), actions=list(vocab.actions),
                        shield_name=machine.name if machine is not None else None,
                        shield_sha256=machine.sha256 if machine is not None else None)
    episodes, steps, crashes = write_run(output, header,
                                         reader(paths, vocab=vocab, machine=machine))
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
    from .episodes.mcap_io import read_run

    result = read_run(run, only)
    for warning in result.warnings:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")
    if not result.episodes:
        raise InputError(f"{run} holds no complete episode")
    return result.episodes, result.header


@export_app.command("prob2trace")
def export_prob2trace_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    episode: int = typer.Option(..., "--episode", "-e", help="The episode number."),
    output: Path = typer.Option(..., "--output", "-o", help="The .prob2trace file to write."),
) -> None:
    """Export one episode as a ProB2 trace (opens in ProB2-UI)."""
    from .episodes.model import HIGHWAY, Vocabulary
    from .interop import export_prob2trace

    from .episodes.mcap_io import read_columns, read_run

    result = read_run(run, {episode})
    chosen = result.episodes
    if not chosen:
        ids = [int(i) for i in read_columns(run).episode_ids]
        if not ids:
            raise InputError(f"{run} holds no complete episode")
        raise InputError(f"{run} has no episode {episode}; it has {_ranges(ids)}")
    for warning in result.warnings:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")
    header = result.header
    vocab = HIGHWAY if header is None or not header.model_name else Vocabulary(
        HIGHWAY.variables, HIGHWAY.actions, header.model_name)
    export_prob2trace(chosen[0], output, vocab)
    out.print(f"wrote episode {episode} ({chosen[0].end.steps} steps) -> {output}",
              markup=False)


@export_app.command("simb")
def export_simb_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    output: Path = typer.Option(..., "--output", "-o", help="The folder to write into."),
) -> None:
    """Export every episode as a SimB timed trace (Timed_Simulation_N.json)."""
    from .interop import export_simb

    episodes, header = _episodes(run)
    if output.exists() and not output.is_dir():
        raise InputError(f"the output {output} is a file; give a folder")
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
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Summarise run files: episodes, steps, crashes, sources, agents and shields."""
    from .episodes.summary import summarise

    summary = summarise(runs)
    for warning in summary["warnings"]:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")
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


# ------------------------------------------------------------------ replay and diff


class Executor(str, Enum):
    local = "local"
    ray = "ray"


# options several commands share
_FILE_EXECUTOR = typer.Option(Executor.local, "--executor",
                              help="local, or ray: one Ray task per file.")
_EPISODE_EXECUTOR = typer.Option(Executor.local, "--executor",
                                 help="local worker processes, or Ray tasks (one per episode).")
_RAY_ADDRESS = typer.Option(None, "--ray-address",
                            help="A Ray cluster (default: start a local one).")


class OutputFormat(str, Enum):
    text = "text"
    md = "md"


class FailOn(str, Enum):
    infeasible = "infeasible"
    deadlock = "deadlock"
    postcondition = "postcondition"
    invariant = "invariant"


_SHIELD_HELP = "A built-in shield (none, paper, strict) or the path of a .mch file."
_ROWS = 40


@app.command("replay")
def replay_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    shield: str = typer.Option(..., "--shield", "-s", help=_SHIELD_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print the full report as JSON."),
    fmt: OutputFormat = typer.Option(OutputFormat.text, "--format", help="text or md."),
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
    executor: Executor = _FILE_EXECUTOR,
    ray_address: Optional[str] = _RAY_ADDRESS,
) -> None:
    """Replay episodes against a shield: where would it have blocked the recorded action?"""
    from .replay import replay
    from .report_text import replay_markdown, replay_text

    loaded = _run_shield(shield, runs)
    report = replay(runs, loaded, executor=executor.value, ray_address=ray_address)
    for warning in report.warnings:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")
    if resimulate:
        report.resimulation = _resimulate(runs, loaded, report, agent, env)
    if as_json:
        out.print_json(json.dumps(report.to_json()))
    elif fmt == OutputFormat.md:
        out.print(replay_markdown(report, _ROWS), markup=False)
    else:
        replay_text(out, report, _ROWS)
    counts = {FailOn.infeasible: report.infeasible_steps,
              FailOn.deadlock: report.deadlock_states,
              FailOn.postcondition: report.postcondition_violations,
              FailOn.invariant: report.invariant_violations}
    failed = [f.value for f in fail_on if counts[f]]
    if failed:
        err.print(f"failing: {', '.join(failed)} found (--fail-on)")
        raise typer.Exit(1)


def _run_shield(spec: str, runs: list[Path]):
    """The shield ``spec`` for these runs: ``none`` is made from their actions."""
    from .episodes.mcap_io import read_header
    from .shield import load_shield

    if spec != "none" or not runs:
        return load_shield(spec)
    header = read_header(runs[0])
    return load_shield(spec, actions=tuple(header.actions) or None)


def _resimulate(runs: list[Path], shield, report, agent: Optional[Path],
                env: Optional[str] = None) -> dict:
    from rich.progress import BarColumn, Progress, TextColumn

    from .resimulate import resimulate, summary

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
    shield: str = typer.Option(..., "--shield", "-s", help="The new shield. " + _SHIELD_HELP),
    against: str = typer.Option(..., "--against", "-a",
                                help="The shield to compare with (old version, baseline)."),
    as_json: bool = typer.Option(False, "--json", help="Print the full report as JSON."),
    fail_on_change: bool = typer.Option(False, "--fail-on-change",
                                        help="Exit 1 when anything changed."),
    executor: Executor = _FILE_EXECUTOR,
    ray_address: Optional[str] = _RAY_ADDRESS,
) -> None:
    """Compare two shields on every recorded state: which steps does the change block or allow?"""
    from .replay import diff
    from .report_text import diff_text

    report = diff(runs, _run_shield(shield, runs), _run_shield(against, runs),
                  executor=executor.value, ray_address=ray_address)
    for warning in report.warnings:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")
    if as_json:
        out.print_json(json.dumps(report.to_json()))
    else:
        diff_text(out, report, _ROWS)
    if fail_on_change and report.anything_changed:
        err.print("failing: the shields differ on these episodes (--fail-on-change)")
        raise typer.Exit(1)


# ------------------------------------------------------------------ statistics


class StatsFormat(str, Enum):
    text = "text"
    md = "md"
    csv = "csv"


class Interval(str, Enum):
    wilson = "wilson"
    clopper_pearson = "clopper-pearson"


def _print_stats(result: dict, as_json: bool, fmt: "StatsFormat", plot: Optional[Path]) -> None:
    from .stats_report import stats_csv, stats_markdown, stats_plots, stats_text

    for warning in result["warnings"]:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")
    if plot is not None:
        try:
            written = stats_plots(result, plot)
        except OSError as exc:
            raise InputError(f"cannot write the plots into {plot}: {exc}") from None
        err.print(f"wrote {len(written)} plot file(s) into {plot}")
    values = result.pop("_values")
    if as_json:
        out.print_json(json.dumps(result))
    elif fmt == StatsFormat.md:
        out.print(stats_markdown(result), markup=False)
    elif fmt == StatsFormat.csv:
        sys.stdout.write(stats_csv(result))
    else:
        stats_text(out, result)
    result["_values"] = values


@app.command("stats")
def stats_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files: one column each."),
    properties: Optional[str] = typer.Option(
        None, "--properties", "-p", help="A built-in set (highway: the paper's; frozenlake; "
        "cliffwalking) or a property file (TOML). Default: the runs' environment's."),
    names: Optional[list[str]] = typer.Option(None, "--names",
                                              help="Only these metrics and properties."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    fmt: StatsFormat = typer.Option(StatsFormat.text, "--format", help="text, md or csv."),
    interval: Interval = typer.Option(Interval.wilson, "--interval",
                                      help="Interval for property shares."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write PNG and SVG plots here."),
    executor: Executor = _FILE_EXECUTOR,
    ray_address: Optional[str] = _RAY_ADDRESS,
) -> None:
    """Estimate metrics and property shares per run, side by side like the paper's tables."""
    from .properties import load_properties
    from .stats import default_properties, statistics

    pset = load_properties(properties or default_properties(runs)).select(names)
    result = statistics(runs, pset, interval=interval.value, executor=executor.value,
                        ray_address=ray_address)
    _print_stats(result, as_json, fmt, plot)


# ------------------------------------------------------------------ agents


class Profile(str, Enum):
    base = "base"
    higher_penalty = "higher-penalty"


_ENV = typer.Option(None, "--env", help="The environment: an installed adapter (highway, "
                    "frozenlake, cliffwalking; see `tracecheck envs`) or package.module:Class "
                    "(importing it runs its code). Default: highway.")
_ENV_CONFIG = typer.Option([], "--env-config", help="key=value on top of the environment's "
                           "configuration, e.g. is_slippery=true (repeatable).")
_PROFILE = typer.Option(None, "--profile", help="A named configuration of the environment "
                        "(highway: base, higher-penalty).")
_DURATION = typer.Option(None, "--duration", min=1, help="Agent steps per episode (default: "
                         "the environment's: highway 60, frozenlake and cliffwalking 100).")
_AGENT = typer.Option(..., "--agent", help="A stable-baselines3 agent (.zip; loading it runs "
                      "code from the file: only use files you trust) or a Q-table (.npy).")


def _settings(env: Optional[str], env_config: list[str], **fields):
    from .live.adapter import parse_config
    from .record import RecordSettings

    return RecordSettings(env=env or "highway", env_config=parse_config(env_config) or None,
                          **fields)


class Algorithm(str, Enum):
    dqn = "dqn"
    q_learning = "q-learning"


@app.command("train")
def train_cmd(
    env: Optional[str] = _ENV,
    env_config: list[str] = _ENV_CONFIG,
    algorithm: Algorithm = typer.Option(Algorithm.dqn, "--algorithm", help="dqn (the paper's "
                                        "settings, highway) or q-learning (a Q-table, for "
                                        "environments with discrete observations)."),
    profile: Profile = typer.Option(Profile.base, "--profile", help="Reward profile."),
    steps: Optional[int] = typer.Option(None, "--steps", min=1, help="Environment steps "
                                        "(default: 20000 for dqn, 200000 for q-learning)."),
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    duration: Optional[int] = _DURATION,
    output: Path = typer.Option(..., "--output", "-o", help="The agent file to write (.zip "
                                "for dqn, .npy for q-learning)."),
) -> None:
    """Train an agent: a DQN with the paper's settings on the highway, or a Q-table."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from .agents import train
    from .live.adapter import load_adapter, parse_config

    adapter = load_adapter(env)
    if algorithm == Algorithm.q_learning:
        from .agents import train_q_table

        card = train_q_table(adapter, adapter.config(parse_config(env_config)), output,
                             steps=steps or 200_000, seed=seed,
                             horizon=duration or adapter.horizon)
        out.print(f"trained {card['agent']} (Q-learning on {adapter.name}, {card['steps']} "
                  f"steps, seed {seed}) in {card['wall_time_s']:.1f} s -> {output}; model "
                  f"card {Path(output).with_suffix('.json')}", markup=False)
        return
    if adapter.name != "highway":
        raise InputError(f"--algorithm dqn trains the paper's highway agent; for {adapter.name} "
                         "use --algorithm q-learning")
    steps = steps or 20_000

    with Progress(TextColumn("training {task.fields[profile]}"), BarColumn(),
                  TextColumn("{task.completed}/{task.total} steps"), TimeRemainingColumn(),
                  console=err, transient=True) as bar:
        task = bar.add_task("train", total=steps, profile=profile.value)
        card = train(profile.value, output, steps=steps, seed=seed, duration=duration or 60,
                     progress=lambda done, total: bar.update(task, completed=done))
    out.print(f"trained {card['agent']} ({profile.value}, {steps} steps, seed {seed}) in "
              f"{card['wall_time_s']:.0f} s -> {output}; model card "
              f"{Path(output).with_suffix('.json')}", markup=False)


@app.command("record")
def record_cmd(
    agent: Path = _AGENT,
    shield: str = typer.Option("none", "--shield", "-s", help=_SHIELD_HELP),
    episodes: int = typer.Option(..., "--episodes", "-n", min=1, help="How many episodes."),
    seed: int = typer.Option(0, "--seed", help="Episode i uses seed SEED + i."),
    env: Optional[str] = _ENV,
    env_config: list[str] = _ENV_CONFIG,
    duration: Optional[int] = _DURATION,
    workers: int = typer.Option(1, "--workers", "-w", min=1, help="Worker processes."),
    executor: Executor = _EPISODE_EXECUTOR,
    ray_address: Optional[str] = _RAY_ADDRESS,
    profile: Optional[str] = _PROFILE,
    fallback: Optional[str] = typer.Option(None, "--fallback",
                                           help="Action taken when the shield allows nothing "
                                                "(default: the environment's; highway SLOWER)."),
    output: Path = typer.Option(..., "--output", "-o", help="The MCAP file to write."),
) -> None:
    """Run an agent under a shield (pre-shielding) and record every episode to MCAP."""
    import time as _time

    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from .record import record

    settings = _settings(env, env_config, agent=str(agent), shield=shield, episodes=episodes,
                         seed=seed, duration=duration, profile=profile, fallback=fallback,
                         workers=workers, executor=executor.value, ray_address=ray_address)
    stats = {"crashes": 0, "steps": 0}
    start = _time.perf_counter()
    with Progress(TextColumn("recording"), BarColumn(),
                  TextColumn("{task.completed}/{task.total} episodes, {task.fields[crashes]} "
                             "crash(es), {task.fields[rate]} steps/s"),
                  TimeRemainingColumn(), console=err, transient=True) as bar:
        task = bar.add_task("record", total=episodes, crashes=0, rate="-")

        def progress(ep) -> None:
            stats["crashes"] += ep.end.crashed
            stats["steps"] += ep.end.steps
            rate = stats["steps"] / max(_time.perf_counter() - start, 1e-9)
            bar.update(task, advance=1, crashes=stats["crashes"], rate=f"{rate:.0f}")

        try:
            n, steps, crashes = record(settings, output, progress)
        except KeyboardInterrupt:
            err.print(f"interrupted: {output} keeps every finished episode")
            raise typer.Exit(130) from None
    took = _time.perf_counter() - start
    out.print(f"recorded {n} episode(s), {steps} step(s), {crashes} crash(es) with shield "
              f"{shield} in {took:.1f} s ({steps / took:.0f} steps/s) -> {output}",
              markup=False)


@app.command("simulate")
def simulate_cmd(
    agent: Path = _AGENT,
    shield: str = typer.Option("none", "--shield", "-s", help=_SHIELD_HELP),
    episodes: int = typer.Option(..., "--episodes", "-n", min=1,
                                 help="Episodes (at most, with --until-ci-width)."),
    seed: int = typer.Option(0, "--seed", help="Episode i uses seed SEED + i."),
    env: Optional[str] = _ENV,
    env_config: list[str] = _ENV_CONFIG,
    duration: Optional[int] = _DURATION,
    workers: int = typer.Option(1, "--workers", "-w", min=1, help="Worker processes."),
    executor: Executor = _EPISODE_EXECUTOR,
    ray_address: Optional[str] = _RAY_ADDRESS,
    profile: Optional[str] = _PROFILE,
    properties: Optional[str] = typer.Option(
        None, "--properties", "-p", help="A built-in set (highway, frozenlake, cliffwalking) "
        "or a property file (TOML). Default: the environment's."),
    until_ci_width: Optional[float] = typer.Option(
        None, "--until-ci-width", help="Stop once every property's 95 % interval is narrower "
                                       "than this (a share, e.g. 0.1)."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    fmt: StatsFormat = typer.Option(StatsFormat.text, "--format", help="text, md or csv."),
    output: Path = typer.Option(..., "--output", "-o", help="The MCAP file to write."),
) -> None:
    """Monte Carlo: record episodes and validate them in one go (SimB-style)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from .properties import load_properties
    from .record import resolve
    from .simulate import simulate

    settings = _settings(env, env_config, agent=str(agent), shield=shield, episodes=episodes,
                         seed=seed, duration=duration, profile=profile, workers=workers,
                         executor=executor.value, ray_address=ray_address)
    pset = load_properties(properties or resolve(settings)[0].properties or "highway")
    with Progress(TextColumn("simulating"), BarColumn(),
                  TextColumn("{task.completed}/{task.total} episodes"), TimeRemainingColumn(),
                  console=err, transient=True) as bar:
        task = bar.add_task("simulate", total=episodes)
        result = simulate(settings, output, pset, until_width=until_ci_width,
                          progress=lambda ep: bar.advance(task))
    seq = result.get("sequential")
    if seq is not None:
        widths = ", ".join(f"{k} {v:.3f}" for k, v in seq["widths"].items())
        err.print(f"sequential rule: {seq['rule']}; {seq['looks']} look(s), "
                  f"{'stopped early' if seq['stopped_early'] else 'ran to the end'}; "
                  f"widths {widths}", highlight=False, markup=False)
    _print_stats(result, as_json, fmt, None)


@app.command("envs")
def envs_cmd(
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """List the environment adapters: actions, state variables, default shield, and whether
    the packages they need are installed."""
    import importlib.util

    from .live.adapter import adapters

    rows = []
    for info in adapters():
        a = info.adapter
        row = {"name": info.name, "adapter": info.target, "problem": info.problem}
        if a is not None:
            missing = [p for p in a.requires if importlib.util.find_spec(p) is None]
            row.update(environment=a.env_id, actions=list(a.actions),
                       variables=list(a.variables), default_shield=a.default_shield,
                       horizon=a.horizon, installed=not missing, missing=missing)
        rows.append(row)
    if as_json:
        out.print_json(json.dumps(rows))
        return
    table = Table(box=None, header_style="bold")
    for col in ("name", "environment", "actions", "variables", "shield", "installed"):
        table.add_column(col, overflow="fold")
    for r in rows:
        if r["problem"]:
            table.add_row(r["name"], r["adapter"], "", "", "", f"no: {r['problem']}")
            continue
        table.add_row(r["name"], r["environment"], ", ".join(r["actions"]),
                      ", ".join(r["variables"]), r["default_shield"] or "",
                      "yes" if r["installed"] else "no: needs " + ", ".join(r["missing"]))
    out.print(table)


# ------------------------------------------------------------------ pictures


@app.command("render")
def render_cmd(
    run: Path = typer.Argument(..., help="An MCAP run file."),
    episode: int = typer.Option(..., "--episode", "-e", help="The episode number."),
    shield: Optional[str] = typer.Option(None, "--shield", "-s", help=_SHIELD_HELP),
    output: Path = typer.Option(..., "--output", "-o", help="The HTML page to write."),
) -> None:
    """Write one episode as a self-contained HTML viewer (top view, shield zones, timeline)."""
    from .render.viewer import render_episode, write_page
    from .shield import load_shield

    loaded = load_shield(shield) if shield else None
    page = write_page(render_episode(run, episode, loaded), output)
    out.print(f"wrote episode {episode} -> {page} ({page.stat().st_size / 1000:.0f} kB)",
              markup=False)


@app.command("report")
def report_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    shield: Optional[str] = typer.Option(None, "--shield", "-s", help=_SHIELD_HELP),
    properties: Optional[str] = typer.Option(
        None, "--properties", "-p", help="A built-in set (highway, frozenlake, cliffwalking) "
        "or a property file (TOML). Default: the environment's."),
    output: Path = typer.Option(..., "--output", "-o", help="The HTML report to write."),
) -> None:
    """Write an HTML validation report: replay, statistics with plots, episode viewers."""
    from .properties import load_properties
    from .render.report import render_report
    from .shield import load_shield

    loaded = load_shield(shield) if shield else None
    from .stats import default_properties

    pset = load_properties(properties or default_properties(runs))
    page, pages = render_report(runs, output, shield=loaded, pset=pset)
    out.print(f"wrote {page} and {pages} episode page(s)", markup=False)


def main(argv: Optional[list[str]] = None) -> Any:
    """Entry point: run the app and turn tracecheck errors into exit code 2."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            return app(args=argv, standalone_mode=True)
    except TracecheckError as exc:
        err.print("[red]error[/red]: " + escape(exc.render()), markup=True, highlight=False)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        err.print("interrupted")
        sys.exit(130)
    except RecursionError:
        err.print("[red]error[/red]: the input is nested too deeply for tracecheck "
                  "(a formula or value with thousands of levels); split it up", markup=True)
        sys.exit(2)


if __name__ == "__main__":  # pragma: no cover
    main()
