"""What the commands share: the Typer app, the consoles, the options several commands take,
and small helpers. A thin layer: each command calls the library and prints.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from enum import Enum
from pathlib import Path
from typing import Optional

import typer
from typer.core import TyperGroup

from .. import __version__
from ..errors import InputError, printable
from ..render.tables import plain, say  # noqa: F401 - the commands print with them

class _Group(TyperGroup):
    """The command group: a command's help is completed with what is installed (the
    ``{environments}``, ``{shields}`` and ``{property_sets}`` of its options' help texts) when
    it is asked for — only then, since that imports every environment's adapter."""

    def resolve_command(self, ctx, args):
        name, command, rest = super().resolve_command(ctx, args)
        if command is not None and any(a in ("--help",) for a in rest):
            fill_help(command)
        return name, command, rest


#: the placeholders of help texts that :func:`fill_help` completes
PLACEHOLDERS = ("environments", "shields", "property_sets")


def installed_names() -> dict[str, str]:
    """What the help texts' placeholders stand for: the installed environments, the shields
    and the property sets they bring."""
    from .. import registry
    from ..checking.shield import shield_names
    from ..stats.properties import builtin_sets

    return {"environments": ", ".join(registry.names()), "shields": ", ".join(shield_names()),
            "property_sets": ", ".join(builtin_sets())}


def fill_help(command) -> None:
    """Complete the help texts of ``command``'s options and arguments with
    :func:`installed_names`."""
    names = None
    for param in getattr(command, "params", ()):
        text = getattr(param, "help", None)
        if text and any("{" + key + "}" in text for key in PLACEHOLDERS):
            names = names or installed_names()
            for key, value in names.items():
                text = text.replace("{" + key + "}", value)
            param.help = text


app = typer.Typer(
    name="tracecheck",
    cls=_Group,
    help="Validate reinforcement-learning agents and their B safety shields.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


class _Console:
    """A rich console made on first use, so commands that print plain lines (``eval``) do not
    import rich. Markup and emoji codes are off unless a call asks for markup (and escapes
    what it interpolates): a file named ``run[bold].mcap`` or a B string with ``:smile:`` in
    it is data."""

    def __init__(self, **options) -> None:
        self._options = options
        self._console = None

    @property
    def console(self):
        """The rich ``Console`` itself (for progress bars and the like)."""
        if self._console is None:
            from rich.console import Console

            self._console = Console(highlight=False, soft_wrap=True, emoji=False,
                                    markup=False, **self._options)
        return self._console

    def print(self, *objects, **options) -> None:
        """rich's print, every string first with its control characters shown as escapes:
        a name or a B string from an input never drives the terminal."""
        self.console.print(*(printable(o) if isinstance(o, str) else o for o in objects),
                           **options)

    def __getattr__(self, name: str):
        return getattr(self.console, name)


def escape(text: str) -> str:
    """``text`` with rich markup escaped (rich imported only when something is printed)."""
    from rich.markup import escape as rich_escape

    return rich_escape(text)


out = _Console()
err = _Console(stderr=True)


def _version(value: bool) -> None:
    if value:
        out.print(f"tracecheck {__version__}")
        raise typer.Exit()


#: ``--debug``: on an error, also print the traceback of what caused it (set per command)
DEBUG = {"on": False}


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the version and exit."),
    debug: bool = typer.Option(False, "--debug", help="On an error from your own code (an "
                               "environment adapter), also print its Python traceback."),
) -> None:
    """Validate reinforcement-learning agents and their B safety shields."""
    DEBUG["on"] = debug


#: the ``--salvage`` option: each command passes its ``salvage`` to what reads the files
SALVAGE = typer.Option(False, "--salvage",
                       help="Leave out episodes whose parts disagree (damaged or edited "
                            "files), with a warning, instead of stopping with exit 2.")


def load_model(path: Path, *, solving: bool = False):
    """A machine from a path, or an installed environment's shield by name (a shield's
    machine, :class:`~tracecheck.checking.shield.ShieldMachine`, also with ``solving``: its
    allowed sets beyond linear guards are the solver's)."""
    from ..b.machine import load_machine
    from ..checking.shield import ShieldMachine, builtin_shields, load_shield

    if str(path) in builtin_shields():
        return load_shield(str(path)).machine
    return load_machine(path, kind=ShieldMachine if solving else None)


class Executor(str, Enum):
    local = "local"
    ray = "ray"


# options several commands share
FILE_EXECUTOR = typer.Option(Executor.local, "--executor",
                              help="local, or ray: one Ray task per file.")
EPISODE_EXECUTOR = typer.Option(Executor.local, "--executor",
                                 help="local worker processes, or Ray tasks (one per episode).")
RAY_ADDRESS = typer.Option(None, "--ray-address",
                            help="A Ray cluster (default: start a local one).")


class OutputFormat(str, Enum):
    text = "text"
    md = "md"
    csv = "csv"
    json = "json"


# every command that prints a table takes these two
FORMAT = typer.Option(OutputFormat.text, "--format", help="text (for people, fitted to the "
                      "terminal), md (a Markdown table), csv (the table, every row) or json "
                      "(the full report).")
JSON = typer.Option(False, "--json", help="The same as --format json.")


def output_format(fmt: OutputFormat, as_json: bool) -> OutputFormat:
    """The format asked for: ``--json`` is ``--format json``."""
    if as_json and fmt not in (OutputFormat.text, OutputFormat.json):
        raise InputError(f"--json and --format {fmt.value} ask for two formats; give one")
    return OutputFormat.json if as_json else fmt


def print_json(data) -> None:
    """``data`` as indented, strict JSON on standard output: a number that is not finite is
    null with a ``KEY_note`` beside it (:mod:`tracecheck.jsontext`); a dict's values that are
    :class:`~tracecheck.jsontext.Rows` (a campaign's episodes) a few hundred items at a time."""
    from ..jsontext import json_text, write_json

    # straight to the stream, as rich's print_json would indent it but without its
    # highlighting pass (which took most of a large report's time)
    if isinstance(data, dict):
        write_json(data, sys.stdout)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(json_text(data, indent=2, ensure_ascii=False) + "\n")


class FailOn(str, Enum):
    infeasible = "infeasible"
    deadlock = "deadlock"
    postcondition = "postcondition"
    invariant = "invariant"
    mismatch = "mismatch"  # replay --resimulate: an episode did not reproduce the recording


SHIELD_HELP = ("A shield an installed environment brings ({shields}) or the path of a .mch "
               "file.")
#: --properties of the commands that compute statistics
PROPERTIES_HELP = ("A property set ({property_sets}) or a property file (TOML). Default: "
                   "generic (episode length, return, interventions, crashes, time limits) and "
                   "the environment's own.")
ROWS = 40

# the options of the commands that run episodes (record, simulate)
RUN_SHIELD = typer.Option("none", "--shield", "-s", help=SHIELD_HELP)
SEED = typer.Option(None, "--seed", help="Episode i uses seed SEED + i (default 0).")
WORKERS = typer.Option(1, "--workers", "-w", min=1, help="Worker processes.")


def run_shield(spec: str, runs: list[Path]):
    """The shield ``spec`` for these runs: ``none`` is made from their actions."""
    from ..episodes.reader import read_header
    from ..checking.shield import load_shield

    if spec != "none" or not runs:
        return load_shield(spec)
    header = read_header(runs[0])
    parameters = {op: tuple(p) for op, p in (header.action_parameters or {}).items()}
    return load_shield(spec, actions=tuple(header.actions) or None, parameters=parameters)


class Interval(str, Enum):
    wilson = "wilson"
    clopper_pearson = "clopper-pearson"


ENV = typer.Option(None, "--env", help="The environment: an installed adapter ({environments}; "
                   "see `tracecheck envs`) or package.module:Class (importing it runs its "
                   "code). Default: the one the agent's model card names.")
ENV_CONFIG = typer.Option([], "--env-config", help="key=value on top of the environment's "
                           "configuration, e.g. is_slippery=true (repeatable).")
PROFILE = typer.Option(None, "--profile", help="A named configuration of the environment "
                        "(`tracecheck envs` lists them).")
DURATION = typer.Option(None, "--duration", min=1, help="Agent steps per episode (default: "
                         "the environment's horizon, `tracecheck envs`).")
AGENT = typer.Option(None, "--agent", help="A stable-baselines3 agent (.zip; loading it runs "
                      "code from the file: only use files you trust) or a Q-table (.npy). "
                      "Required unless --external.")


def record_settings(run, episodes: int):
    """The ``RecordSettings`` of a command that runs an agent (``run``: its
    :class:`~tracecheck.cli.run_options.RunOptions`); without ``--env``, the environment the
    agent's model card names (said on stderr)."""
    from ..live.record import RecordSettings
    from ..live.settings import parse_config

    if run.agent is None:
        raise InputError("--agent is required (or --external 'CMD' to run an agent script "
                         "that speaks SimB's external-simulation protocol)")
    env = run.env
    if env is None:
        from ..live.agents import card_environment

        env, source = card_environment(run.agent)
        err.print(f"environment {env}, as {source} says (--env chooses another)",
                  markup=False, highlight=False)
    config = parse_config(run.env_config) or None
    if config is None:  # the agent trained in another world than the default's: say so
        from ..live.adapter import load_adapter
        from ..live.agents import card_config_note

        note = card_config_note(run.agent, load_adapter(env))
        if note:
            err.print(note, markup=False, highlight=False)
    return RecordSettings(agent=str(run.agent), shield=run.shield, episodes=episodes,
                          seed=0 if run.seed is None else run.seed, duration=run.duration,
                          profile=run.profile, fallback=run.fallback, workers=run.workers,
                          executor=run.executor.value, ray_address=run.ray_address, env=env,
                          env_config=config,
                          **continuous_options(run.shield_mode, run.scale))


# the options of continuous actions (record, simulate)
SHIELD_MODE = typer.Option(None, "--shield-mode", help="Continuous actions: how the shield "
                           "makes the agent's action allowed — project (the default for a "
                           "Box: the nearest allowed action), replace (the environment's "
                           "fallback action) or mask (the default for a hybrid space: the "
                           "best-scored enabled operation, its values projected). See "
                           "docs/continuous.md.")
SCALE = typer.Option(None, "--scale", help="Continuous actions: the unit of each component in "
                     "projection distances, comma-separated (e.g. 4,0.5; default 1 each).")


def continuous_options(shield_mode: Optional[str], scale: Optional[str]) -> dict:
    """``RecordSettings`` fields of --shield-mode and --scale (checked against the
    environment when the recording is checked)."""
    if shield_mode is not None:  # (the continuous module imported only where it is asked)
        from ..live.continuous import MODES

        if shield_mode not in MODES:
            raise InputError(f"--shield-mode {shield_mode!r}: give one of {', '.join(MODES)}")
    out: dict = {"shield_mode": shield_mode}
    if scale is not None:
        try:
            out["scale"] = tuple(float(x) for x in scale.split(","))
        except ValueError:
            raise InputError(f"--scale {scale!r}: give numbers separated by commas, one per "
                             "component of the action, e.g. 4,0.5") from None
    return out


# the options of an external simulation (record and simulate with --external)
EXTERNAL = typer.Option(None, "--external", help="Run this agent script instead of --agent: "
                        "a command line (split as a shell would, run without one, the port "
                        "appended) that speaks SimB's external-simulation protocol, e.g. "
                        "'python3 agent.py'; --shield names the machine that answers it "
                        "(docs/simb-external.md). It runs code: only scripts you trust.")
CWD = typer.Option(None, "--cwd", help="The folder --external's script runs in (default: the "
                   "current one).")
STEP_TIMEOUT = typer.Option(30.0, "--step-timeout", min=0.001, help="Seconds --external's "
                            "script may take to answer one step (and twice that, at least 60 "
                            "s, to connect: scripts load their agent first).")
CRASH = typer.Option(None, "--crash", help="With --external: a predicate over the machine's "
                     "state that marks a crash (default: its Crash variable, if it has one).")
ENDING_TIME = typer.Option(None, "--ending-time", min=1, help="With --external: SimB's "
                           "ENDING_TIME — end an episode once the script's clock (the sum of "
                           "its deltas) reaches this many milliseconds.")


def external_settings(run, episodes: int):
    """The settings and the machine of ``--external`` (``run``: the command's
    :class:`~tracecheck.cli.run_options.RunOptions`, whose options that apply only to an
    agent tracecheck runs were refused by their declaration)."""
    from ..checking.shield import load_shield
    from ..live.external import ExternalSettings, split_command

    if run.shield == "none":
        raise InputError("--external needs --shield naming the machine that answers the "
                         "script (a .mch file, or a built-in shield other than none)")
    if run.duration is None and run.ending_time is None:
        err.print("note: neither --duration nor --ending-time: each episode lasts until the "
                  "script says done", markup=False, highlight=False)
    settings = ExternalSettings(command=split_command(run.external), episodes=episodes,
                                cwd=run.cwd, ending_time_ms=run.ending_time,
                                max_steps=run.duration, step_timeout=run.step_timeout,
                                connect_timeout=max(60.0, 2 * run.step_timeout),
                                crash=run.crash)
    return settings, load_shield(run.shield)


class Algorithm(str, Enum):
    dqn = "dqn"
    ppo = "ppo"
    a2c = "a2c"
    maskable_ppo = "maskable-ppo"
    sac = "sac"
    td3 = "td3"
    q_learning = "q-learning"


@contextmanager
def progress(label: str, total: Optional[int] = None, unit: str = "episodes",
             detail: str = "", **fields):
    """A progress bar on standard error, drawn only on a terminal and gone when done (a pipe
    or log file gets nothing, not even a blank line); yields ``advance(n=1, **fields)``.
    ``detail`` is a rich column template over ``fields`` (their first values given here)."""
    if not err.console.is_terminal:
        yield lambda n=1, **changed: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    columns = [TextColumn(label), BarColumn(),
               TextColumn("{task.completed}" + ("/{task.total}" if total else "") + f" {unit}"
                          + detail)]
    if total:
        columns.append(TimeRemainingColumn())
    with Progress(*columns, console=err.console, transient=True) as bar:
        task = bar.add_task(label, total=total, **fields)
        yield lambda n=1, **changed: bar.update(task, advance=n, **changed)


def warn(messages) -> None:
    """Print each warning of a library result (damaged files and the like)."""
    for warning in messages:
        err.print(f"[yellow]warning[/yellow]: {escape(printable(warning))}", markup=True)


FORCE = typer.Option(False, "--force", help="Replace an existing output, only once the new "
                     "one is complete (a recording: once a new episode is). Never an input.")


#: ``--env`` of the commands that read runs (stats, report, render, replay, …): the same
#: lookup as ``ENV`` (:func:`tracecheck.live.adapter.load_adapter`), but optional there — a
#: run names its environment, and one whose adapter is not installed still works without it
RUN_ENV = typer.Option(None, "--env", help="The runs' environment adapter: an installed one "
                       "({environments}) or package.module:Class (importing it runs its "
                       "code). Default: "
                       "the one the files name, where it is installed; without it, what "
                       "needs no adapter still works.")


def run_adapter(env: Optional[str]):
    """The adapter ``--env`` names (None when not given)."""
    if env is None:
        return None
    from ..live.adapter import load_adapter

    return load_adapter(env)
