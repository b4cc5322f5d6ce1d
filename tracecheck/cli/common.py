"""What the commands share: the Typer app, the consoles, the options several commands take,
and small helpers. A thin layer: each command calls the library and prints.
"""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.markup import escape

from .. import __version__

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


def salvage(value: bool) -> bool:
    """The ``--salvage`` option: damaged episodes are left out with a warning."""
    if value:
        from ..episodes.salvage import SALVAGE

        SALVAGE.set(True)
    return value


SALVAGE = typer.Option(False, "--salvage", callback=salvage,
                       help="Leave out episodes whose parts disagree (damaged or edited "
                            "files), with a warning, instead of stopping with exit 2.")


def load_model(path: Path):
    """A machine from a path, or a built-in shield by name (none, paper, strict)."""
    from ..b.machine import load_machine
    from ..checking.shield import BUILTIN_SHIELDS, load_shield

    if str(path) in BUILTIN_SHIELDS:
        return load_shield(str(path)).machine
    return load_machine(path)


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


class FailOn(str, Enum):
    infeasible = "infeasible"
    deadlock = "deadlock"
    postcondition = "postcondition"
    invariant = "invariant"


SHIELD_HELP = ("A built-in shield (none, paper, strict, frozenlake, cliffwalking) or the path of "
               "a .mch file.")
ROWS = 40

# the options of the commands that run episodes (record, simulate)
RUN_SHIELD = typer.Option("none", "--shield", "-s", help=SHIELD_HELP)
SEED = typer.Option(0, "--seed", help="Episode i uses seed SEED + i.")
WORKERS = typer.Option(1, "--workers", "-w", min=1, help="Worker processes.")


def run_shield(spec: str, runs: list[Path]):
    """The shield ``spec`` for these runs: ``none`` is made from their actions."""
    from ..episodes.reader import read_header
    from ..checking.shield import load_shield

    if spec != "none" or not runs:
        return load_shield(spec)
    header = read_header(runs[0])
    return load_shield(spec, actions=tuple(header.actions) or None)


class StatsFormat(str, Enum):
    text = "text"
    md = "md"
    csv = "csv"


class Interval(str, Enum):
    wilson = "wilson"
    clopper_pearson = "clopper-pearson"


class Profile(str, Enum):
    base = "base"
    higher_penalty = "higher-penalty"


ENV = typer.Option(None, "--env", help="The environment: an installed adapter (highway, "
                    "frozenlake, cliffwalking; see `tracecheck envs`) or package.module:Class "
                    "(importing it runs its code). Default: highway.")
ENV_CONFIG = typer.Option([], "--env-config", help="key=value on top of the environment's "
                           "configuration, e.g. is_slippery=true (repeatable).")
PROFILE = typer.Option(None, "--profile", help="A named configuration of the environment "
                        "(highway: base, higher-penalty).")
DURATION = typer.Option(None, "--duration", min=1, help="Agent steps per episode (default: "
                         "the environment's: highway 60, frozenlake and cliffwalking 100).")
AGENT = typer.Option(..., "--agent", help="A stable-baselines3 agent (.zip; loading it runs "
                      "code from the file: only use files you trust) or a Q-table (.npy).")


def record_settings(env: Optional[str], env_config: list[str], **fields):
    from ..live.adapter import parse_config
    from ..live.record import RecordSettings

    return RecordSettings(env=env or "highway", env_config=parse_config(env_config) or None,
                          **fields)


class Algorithm(str, Enum):
    dqn = "dqn"
    q_learning = "q-learning"


def warn(messages) -> None:
    """Print each warning of a library result (damaged files and the like)."""
    for warning in messages:
        err.print(f"[yellow]warning[/yellow]: {escape(warning)}")


FORCE = typer.Option(False, "--force", help="Replace an existing output (a recording only once "
                     "a new episode is complete).")
