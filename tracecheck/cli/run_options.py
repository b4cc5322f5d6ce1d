"""The options of the commands that run episodes (``record``, ``simulate``), declared once.

Each option is declared here with the ways of running it applies to — an agent tracecheck
runs (``--agent``), or an agent script that speaks SimB's external-simulation protocol
(``--external``) — and :func:`run_options` adds every one of them to a command, which gets
them as one :class:`RunOptions`. An option given where it does not apply is refused the same
way in every command, from its declaration (never silently ignored).
"""

from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Callable, Optional

import typer

from ..errors import InputError
from .common import (AGENT, CRASH, CWD, DURATION, ENDING_TIME, ENV, ENV_CONFIG, EPISODE_EXECUTOR,
                     EXTERNAL, FORCE, PROFILE, RAY_ADDRESS, RUN_SHIELD, SCALE, SEED, SHIELD_MODE,
                     STEP_TIMEOUT, WORKERS, Executor)

__all__ = ["RunOptions", "run_options", "AGENT_MODE", "EXTERNAL_MODE"]

AGENT_MODE, EXTERNAL_MODE = "agent", "external"
BOTH = frozenset({AGENT_MODE, EXTERNAL_MODE})
AGENT_ONLY = frozenset({AGENT_MODE})
EXTERNAL_ONLY = frozenset({EXTERNAL_MODE})

FALLBACK = typer.Option(None, "--fallback", help="Action taken when the shield allows nothing "
                        "(default: the environment's fallback, `tracecheck envs`).")
OUTPUT = typer.Option(..., "--output", "-o", help="The MCAP file to write.")


@dataclass(frozen=True)
class RunOptions:
    """What a command that runs episodes was given (see the module docstring)."""

    agent: Optional[Path]
    external: Optional[str]
    cwd: Optional[Path]
    step_timeout: float
    crash: Optional[str]
    ending_time: Optional[int]
    shield: str
    seed: Optional[int]
    env: Optional[str]
    env_config: list[str]
    duration: Optional[int]
    workers: int
    executor: Executor
    ray_address: Optional[str]
    profile: Optional[str]
    fallback: Optional[str]
    shield_mode: Optional[str]
    scale: Optional[str]
    output: Path
    force: bool

    @classmethod
    def given(cls, **values: Any) -> "RunOptions":
        """The options as a command gets them when only ``values`` are given on its command
        line (each other option its declared default).

        >>> RunOptions.given(external="python3 agent.py", shield="m.mch").step_timeout
        30.0
        """
        defaults = {name: (None if option.default is ... else option.default)
                    for name, (_, option, _) in DECLARED.items()}
        return cls(**{**defaults, **values})

    @property
    def mode(self) -> str:
        """``external`` with ``--external``, else ``agent``."""
        return EXTERNAL_MODE if self.external is not None else AGENT_MODE

    def check(self) -> None:
        """Refuse each option given that does not apply to :attr:`mode`, by its declaration.

        Raises:
            InputError: naming the options and why.
        """
        given = [flag for name, (_, option, modes) in DECLARED.items()
                 if self.mode not in modes and _given(getattr(self, name), option)
                 for flag in option.param_decls[:1]]
        if not given:
            return
        if self.mode == EXTERNAL_MODE:
            raise InputError(f"--external runs the agent script's own environment: "
                             f"{', '.join(given)} cannot be used with it",
                             hint="the script decides the agent, the environment and its "
                                  "seeds")
        raise InputError(f"{', '.join(given)} only appl{'y' if len(given) > 1 else 'ies'} to "
                         "--external 'CMD' (an agent script that speaks SimB's "
                         "external-simulation protocol)")


def _given(value: Any, option) -> bool:
    """Whether an option's value is other than its default (what the user left out)."""
    return value != option.default and value not in (None, [])


#: every option: its annotation, its declaration, the modes it applies to
DECLARED: dict[str, tuple[Any, Any, frozenset[str]]] = {
    "agent": (Optional[Path], AGENT, AGENT_ONLY),
    "external": (Optional[str], EXTERNAL, BOTH),
    "cwd": (Optional[Path], CWD, EXTERNAL_ONLY),
    "step_timeout": (float, STEP_TIMEOUT, EXTERNAL_ONLY),
    "crash": (Optional[str], CRASH, EXTERNAL_ONLY),
    "ending_time": (Optional[int], ENDING_TIME, EXTERNAL_ONLY),
    "shield": (str, RUN_SHIELD, BOTH),
    "seed": (Optional[int], SEED, AGENT_ONLY),
    "env": (Optional[str], ENV, AGENT_ONLY),
    "env_config": (list[str], ENV_CONFIG, AGENT_ONLY),
    "duration": (Optional[int], DURATION, BOTH),
    "workers": (int, WORKERS, AGENT_ONLY),
    "executor": (Executor, EPISODE_EXECUTOR, AGENT_ONLY),
    "ray_address": (Optional[str], RAY_ADDRESS, AGENT_ONLY),
    "profile": (Optional[str], PROFILE, AGENT_ONLY),
    "fallback": (Optional[str], FALLBACK, AGENT_ONLY),
    "shield_mode": (Optional[str], SHIELD_MODE, AGENT_ONLY),
    "scale": (Optional[str], SCALE, AGENT_ONLY),
    "output": (Path, OUTPUT, BOTH),
    "force": (bool, FORCE, BOTH),
}
assert set(DECLARED) == {f.name for f in fields(RunOptions)}


def run_options(command: Callable) -> Callable:
    """Give ``command`` every option of :data:`DECLARED` as one ``run: RunOptions`` argument
    (checked against the mode before the command runs).

    Args:
        command: a command function whose first parameter is ``run``.

    Returns:
        The function Typer registers: the declared options, then the command's own.
    """
    own = [p for p in inspect.signature(command).parameters.values() if p.name != "run"]
    shared = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=option,
                                annotation=annotation)
              for name, (annotation, option, _) in DECLARED.items()]

    @functools.wraps(command)
    def wrapper(**kwargs):
        run = RunOptions(**{name: kwargs.pop(name) for name in DECLARED})
        run.check()
        return command(run, **kwargs)

    wrapper.__signature__ = inspect.Signature(
        shared + [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in own])
    wrapper.__annotations__ = {**getattr(command, "__annotations__", {}),
                               **{name: annotation for name, (annotation, _, _) in
                                  DECLARED.items()}}
    return wrapper
