"""Counterfactual re-simulation: would the shield's intervention have saved the episode?

For each episode with an infeasible step, the environment is reset with the recorded seed and
the recorded actions are re-applied up to the first infeasible step — each reproduced state is
compared with the recording, and a mismatch is reported rather than trusted. From there the
recorded agent continues under the shield up to the original horizon. For continuous actions
the recorded action vectors (the executed parameters) are re-applied, and from the first
infeasible step on the shield projects the agent's actions onto the allowed set (or replaces
them, in the run's ``--shield-mode``), in the recorded ``--scale``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ..checking.replaying import (MISMATCH, NEW_CRASH, NO_CRASH, NO_SEED, NOT_PREVENTED, OUTCOMES,
                               PREVENTED, ReplayReport)
from ..checking.shield import SHIELD_DIR, Shield
from ..episodes.columns import RunColumns, read_columns
from ..episodes.model import Episode
from ..episodes.reader import read_header
from ..errors import InputError, printable
from .agents import file_sha256
from ..jsontext import plain

__all__ = ["resimulate", "Resimulation", "summary", "with_resimulation", "same_state", "rerun",
           "rerun_settings"]

AGENT_DIR = SHIELD_DIR.parent / "agents"
TOLERANCE = 1e-6


@dataclass(frozen=True)
class Resimulation:
    file: str
    episode: int
    seed: Optional[int]
    first_infeasible: int
    outcome: str
    original_crash_step: Optional[int]
    new_crash_step: Optional[int]
    steps: int
    detail: str = ""


def _continuous_settings(adapter, header) -> dict:
    """The recording's shield mode and scale, for an environment with continuous actions."""
    if not adapter.parameters:
        return {}
    return {"shield_mode": header.shield_mode,
            "scale": tuple(header.projection_scale) if header.projection_scale else None}


def _agent_path(header, agent: Optional[str | Path]) -> str:
    """The agent that recorded a file: the one given with ``--agent``, else a bundled agent
    whose file name *and* sha256 match the header, else (a Q-table only: loading one runs no
    code) the table the header names, if its sha256 matches. A run file is data: no path in
    it is followed to a stable-baselines3 file, which would run code when loaded."""
    if agent is not None:
        return str(agent)
    wanted = header.agent_sha256
    if header.agent_id and wanted:
        for candidate in sorted(AGENT_DIR.glob("*")):
            if candidate.suffix in (".zip", ".npy") and candidate.stem == header.agent_id \
                    and file_sha256(candidate) == wanted:
                return str(candidate)
    table = Path(header.agent_file) if header.agent_file else None
    if table is not None and wanted and table.suffix == ".npy" and table.is_file() and (
            file_sha256(table) == wanted):
        return str(table)
    raise InputError(f"cannot tell which agent recorded these episodes (agent {header.agent_id!r}"
                     "); give it with --agent PATH",
                     hint="tracecheck uses a bundled agent only when its name and sha256 match "
                          "the file's header, and never follows a path from a run file to a "
                          "stable-baselines3 agent")


def _close(a, b) -> bool:
    if type(a) is float or type(b) is float:
        return type(b) in (int, float) and type(a) in (int, float) and abs(a - b) <= TOLERANCE
    return a == b


def same_state(recorded: dict, state: dict) -> Optional[str]:
    """What differs between a recorded state and a reproduced one (None: nothing; numbers
    within the recording's rounding)."""
    for name, value in recorded.items():
        got = state.get(name)
        if hasattr(value, "map") and hasattr(got, "map"):
            for key, x in value.map.items():
                if key not in got.map or not _close(x, got.map[key]):
                    return f"{name}({key}) is {got.map.get(key)} instead of {x}"
            if len(got.map) != len(value.map):
                return f"{name} has other arguments"
        elif not _close(value, got):
            return f"{name} is {got} instead of {value}"
    return None


def resimulate(path: str | Path, shield: Shield, report: ReplayReport, *,
               agent: Optional[str | Path] = None, env: Optional[str] = None,
               progress: Optional[Callable[[Resimulation], None]] = None,
               salvage: bool = False, cols: Optional[RunColumns] = None
               ) -> list[Resimulation]:
    """Re-simulate the episodes of ``path`` that ``report`` found infeasible under ``shield``.

    The environment is the adapter the file names, looked up among the installed ones only
    (a file never makes tracecheck import a module); ``env`` (from ``--env``) overrides it;
    ``salvage``: as :func:`~tracecheck.episodes.reader.read_run`; ``cols``: the file's
    columns when they were read already (else read here, with ``salvage``).
    """
    from .adapter import MakeError
    from .rollout import Session

    path = str(path)
    header = read_header(path)
    todo = [e for e in report.per_episode if e.file == path and e.first_infeasible is not None]
    if not todo:
        return []
    adapter, config, horizon, settings = rerun_settings(path, shield, header, agent=agent,
                                                        env=env)
    cols = cols if cols is not None else read_columns(path, salvage=salvage)
    index = {int(e): i for i, e in enumerate(cols.episode_ids)}
    results = []
    try:
        try:
            session = Session(settings, config=config, shield=shield)
        except MakeError as exc:
            raise InputError(f"{path}: the {adapter.name} environment rejects the run header's "
                             f"environment_config {printable(repr(config))[:200]}: "
                             f"{exc.reason}") from exc.__cause__
        own = _episode_configs(path, {item.episode for item in todo}, salvage) \
            if header.search is not None else {}
        for item in todo:
            i = index[item.episode]
            own_config, options = own.get(item.episode, (None, None))
            if own_config:  # a search's episode: its own settings on top
                session.reconfigure(adapter.config({**config, **own_config}))
            elif session.config != config:
                session.reconfigure(config)
            result = _one(session, cols, i, item, horizon, options)
            results.append(result)
            if progress is not None:
                progress(result)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
        # the configuration comes from the file: one the environment rejects is bad input
        raise InputError(f"{path}: the {adapter.name} environment rejects the run header's "
                         f"environment_config {printable(repr(config))[:200]}: "
                         f"{type(exc).__name__}: {exc}") from None
    return results


def rerun_settings(path: str, shield: Shield, header, *, agent: Optional[str | Path] = None,
                   env: Optional[str] = None) -> tuple:
    """How the episodes of ``path`` (its ``header``) run again under ``shield``: (the
    adapter — the one the file names among the installed ones, ``env`` over it, else the one
    that claims its states —, the run's environment settings, the horizon, the
    :class:`~tracecheck.live.rollout.RecordSettings` of a session). A file recorded from an
    agent script, or imported, cannot be run again: an :class:`InputError` says so."""
    from .adapter import claiming_adapter, get_adapter, load_adapter
    from .rollout import RecordSettings

    if header.source == "external":
        import shlex

        raise InputError(f"{path} was recorded from the agent script "
                         f"{shlex.join(header.external_command or [])} (--external): it has no "
                         "seeds and no environment tracecheck runs, so it cannot be "
                         "re-simulated",
                         hint="record it again with the script, or replay without --resimulate")
    if header.environment_config is None:
        raise InputError(f"{path} was not recorded by tracecheck (source {header.source}): "
                         "it has no environment to re-simulate")
    adapter = load_adapter(env) if env is not None else (
        get_adapter(header.environment) if header.environment
        else claiming_adapter(header.variables or ()))
    if adapter is None:
        raise InputError(f"{path} names no environment, and no installed one has its states "
                         f"({', '.join(header.variables or ()) or 'none declared'})",
                         hint="give the environment with --env (env=... in Python)")
    if header.environment and adapter.name != header.environment:
        raise InputError(f"{path} was recorded in {header.environment}, not {adapter.name}")
    config = dict(header.environment_config)
    duration = config.get("duration", 61)
    if type(duration) is not int or not 1 < duration <= 1_000_000:
        raise InputError(f"{path}: the run header's environment_config has duration "
                         f"{duration!r}, not a number of steps")
    horizon = header.horizon or duration - 1
    continuous = _continuous_settings(adapter, header)
    settings = RecordSettings(agent=_agent_path(header, agent), shield=shield.path,
                              episodes=1, duration=horizon, env=env or adapter.name,
                              **continuous)
    return adapter, config, horizon, settings


def _episode_configs(path: str, ids: set, salvage: bool) -> dict:
    """(the environment settings, the reset options) each of the episodes ``ids`` has of
    its own (a search's points), from their episode headers."""
    from ..episodes.reader import read_run

    return {ep.id: (dict(ep.config or {}), dict(ep.reset_options or {}) or None)
            for ep in read_run(path, only=ids, salvage=salvage).episodes
            if ep.config or ep.reset_options}


def _one(session, cols: RunColumns, i: int, item, horizon: int,
         options: Optional[dict] = None) -> Resimulation:
    """The episode again from its seed: the recorded actions up to the first infeasible
    step (each state checked against the recording), then the agent under the shield."""
    from .rollout import Diverged, run_episode

    lo = int(cols.starts[i])
    seed = cols.seeds[i] if i < len(cols.seeds) else None
    first = item.first_infeasible

    def result(outcome: str, new_crash: Optional[int], steps: int, detail: str = ""):
        return Resimulation(cols.path, item.episode, seed, first, outcome, item.crash_step,
                            new_crash, steps, detail)

    if seed is None:
        return result(NO_SEED, None, 0, "the episode has no seed: it cannot be re-run")
    script = _script(session, cols, lo, first)
    try:
        episode = run_episode(session, item.episode, seed=int(seed), script=script,
                              check=lambda k, state: same_state(cols.states.row(lo + k), state),
                              options=options)
    except Diverged as exc:
        return result(MISMATCH, None, exc.step, str(exc))
    crash_step = next((s.step for s in episode.steps if s.crashed), None)
    if item.crashed:
        outcome = NOT_PREVENTED if crash_step is not None else PREVENTED
    else:
        outcome = NEW_CRASH if crash_step is not None else NO_CRASH
    return result(outcome, crash_step, episode.end.steps)


def _script(session, cols: RunColumns, lo: int, first: int) -> list:
    """The recorded actions of steps 1 … ``first`` - 1 of the episode starting at row ``lo``:
    operation names, or for continuous actions the executed vectors (a hybrid space's:
    (operation, its values) pairs)."""
    rows = range(lo + 1, lo + first)
    shield = session.env.continuous
    if shield is None:
        return [cols.action_names[cols.action[r]] for r in rows]
    script = []
    for r in rows:
        op = cols.action_names[cols.action[r]]
        params = shield.ops[op].part.params if op in shield.ops else ()
        missing = [p for p in params if p not in cols.parameters or
                   not np.isfinite(cols.parameters[p][r])]
        if missing:
            raise InputError(f"{cols.path}: step {r - lo} has no recorded value of "
                             f"{missing[0]}, which the environment's action {op} takes: it "
                             "cannot be re-applied")
        values = [float(cols.parameters[p][r]) for p in params]
        script.append((op, values) if shield.hybrid else values)
    return script


def summary(results: list[Resimulation]) -> dict:
    """The counts of each outcome (``mismatches``: episodes that did not reproduce the
    recording) and every result, as the JSON report's ``resimulation``."""
    counts = {o: sum(r.outcome == o for r in results) for o in OUTCOMES}
    return {
        "resimulated": len(results),
        "crashes_prevented": counts[PREVENTED],
        "crashes_not_prevented": counts[NOT_PREVENTED],
        "new_crashes": counts[NEW_CRASH],
        "no_crash_either_way": counts[NO_CRASH],
        "mismatches": counts[MISMATCH],
        "without_seed": counts[NO_SEED],
        "per_episode": [plain(r) for r in results],
    }



def with_resimulation(report, runs, shield, *, agent=None, env: Optional[str] = None,
                      salvage: bool = False, progress=None):
    """``report`` (a :class:`~tracecheck.checking.replaying.ReplayReport` of ``runs``) with
    what re-simulating its infeasible episodes under ``shield`` found: a new report, the
    given one unchanged.

    Args:
        report: the replay of ``runs`` against ``shield``.
        runs: the run files.
        shield: the shield to re-simulate under.
        agent: the agent (None: the one each run names).
        env: the environment (None: the one each run names).
        salvage: as :func:`~tracecheck.episodes.reader.read_run`.
        progress: called with each episode's result as it is re-simulated.

    Returns:
        The report with ``resimulation`` set (:func:`summary` of every episode's result).
    """
    import dataclasses

    results = []
    for run in runs:
        results += resimulate(run, shield, report, agent=agent, env=env, progress=progress,
                              salvage=salvage)
    return dataclasses.replace(report, resimulation=summary(results))


def rerun(path: str | Path, episode_id: int, shield: Shield | str, *,
          agent: Optional[str | Path] = None, env: Optional[str] = None) -> Episode:
    """Episode ``episode_id`` of ``path`` run again from the file alone: its seed, the run's
    environment settings with the episode's own on top (a search's point), the agent the
    header names (as :func:`resimulate` finds it, or ``agent``) under ``shield`` (a shield,
    or its name or path), from what it started from (its reset options) — the same
    episode, where the environment and the agent are deterministic given the seed. ``env``
    (``package.module:Class``, or an installed name) is the adapter where the file's
    environment is not installed."""
    from ..checking.shield import load_shield
    from ..episodes.reader import read_run
    from .adapter import get_adapter, load_adapter
    from .rollout import RecordSettings, Session, run_episode

    if isinstance(shield, str):
        shield = load_shield(shield)

    run = read_run(path, only={episode_id})
    if not run.episodes:
        raise InputError(f"{path} has no episode {episode_id}")
    episode, header = run.episodes[0], run.header
    if header.environment_config is None or header.environment is None:
        raise InputError(f"{path} was not recorded by tracecheck: it has no environment to "
                         "run the episode in again")
    if episode.seed is None:
        raise InputError(f"{path}, episode {episode_id}: it has no seed")
    adapter = load_adapter(env) if env is not None else get_adapter(header.environment)
    if adapter.name != header.environment:
        raise InputError(f"{path} was recorded in {header.environment}, not {adapter.name}")
    config = adapter.config({**header.environment_config, **dict(episode.config or {})})
    continuous = _continuous_settings(adapter, header)
    settings = RecordSettings(agent=_agent_path(header, agent), shield=shield.path,
                              episodes=1, duration=header.horizon, env=env or adapter.name,
                              **continuous)
    session = Session(settings, config=config, shield=shield)
    try:
        return run_episode(session, episode.id, seed=int(episode.seed),
                           options=dict(episode.reset_options or {}) or None)
    finally:
        session.env.close()
