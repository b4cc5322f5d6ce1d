"""Recording: run an agent under a shield for many episodes and write them to MCAP.

Any environment with an adapter (:mod:`tracecheck.live.adapter`; the highway by default).
Episode i uses seed ``seed + i``, so runs with different shields face the same scenarios.
Episodes run in worker processes and come back in order, so the same seed gives the same
file whatever the number of workers; each finished episode is written (and flushed) at once,
so an interrupted run keeps every finished episode.
"""

from __future__ import annotations

import multiprocessing as mp
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Optional

import numpy as np

from .episodes.mcap_io import EpisodeWriter, new_header
from .episodes.model import Episode, StepRecord, make_end
from .errors import InputError

__all__ = ["RecordSettings", "run_episode", "record", "Session"]


@dataclass(frozen=True)
class RecordSettings:
    """What to record. ``env`` is an installed adapter's name or ``package.module:Class``;
    ``duration`` the most agent steps per episode (None: the environment's horizon);
    ``env_config`` settings on top of the environment's configuration (and ``profile``)."""

    agent: str
    shield: str
    episodes: int
    seed: int = 0
    duration: Optional[int] = None
    profile: Optional[str] = None
    fallback: Optional[str] = None
    workers: int = 1
    executor: str = "local"
    ray_address: Optional[str] = None
    env: str = "highway"
    env_config: Optional[dict] = None


def resolve(settings: RecordSettings):
    """(adapter, environment configuration, horizon) of ``settings``."""
    from .live.adapter import load_adapter

    adapter = load_adapter(settings.env)
    horizon = settings.duration or adapter.horizon
    if horizon < 1:
        raise InputError("--duration must be at least 1")
    config = adapter.config(settings.env_config, profile=settings.profile, horizon=horizon)
    return adapter, config, horizon


class Session:
    """What one process needs to run episodes: environment, agent, shield (built once).

    ``config`` overrides the environment configuration (re-simulation uses the recorded one).
    """

    def __init__(self, settings: RecordSettings, config: Optional[dict] = None) -> None:
        from .agents import load_agent
        from .shield import load_shield
        from .shielding import ShieldWrapper

        self.settings = settings
        self.adapter, default, self.horizon = resolve(settings)
        env = self.adapter.make_env(config or default)
        self.agent = load_agent(settings.agent, adapter=self.adapter, env=env)
        self.shield = load_shield(settings.shield, actions=self.adapter.actions)
        self.env = ShieldWrapper(env, self.shield, settings.fallback, self.adapter)

    def episode(self, index: int) -> Episode:
        return run_episode(self, index)


def run_episode(session: Session, index: int, *, prefix: Optional[list[str]] = None,
                start_seed: Optional[int] = None) -> Episode:
    """Episode ``index``: seed ``seed + index``, shielded choices, up to ``duration`` steps.

    With ``prefix``, the first actions are taken as given (for re-simulation) instead of
    chosen by the agent.
    """
    from .shielding import choose

    s = session.settings
    seed = s.seed + index if start_seed is None else start_seed
    env, agent = session.env, session.agent
    actions, dt = env.actions, session.adapter.seconds_per_step
    obs, info = env.reset(seed=seed)
    steps = [StepRecord(0, 0.0, None, info["b_state"], 0.0, False,
                        observation=_rows(obs))]
    reason = "time-limit"
    for k in range(1, session.horizon + 1):
        values = agent.values(obs)
        allowed = env.action_masks()
        decision_us = info["shield"]["decision_us"]
        if prefix is not None and k <= len(prefix):
            action, deadlock = actions.index(prefix[k - 1]), False
        else:
            action, deadlock = choose(values, allowed, env.fallback)
        obs, reward, terminated, truncated, info = env.step(action)
        crashed = bool(info["crashed"])
        steps.append(StepRecord(
            step=k, time=float(k * dt), action=actions[action], state=info["b_state"],
            reward=float(reward), crashed=crashed, observation=_rows(obs),
            action_values={a: float(v) for a, v in zip(actions, values)},
            preferred_action=actions[int(np.argmax(values))],
            allowed_actions=tuple(a for a, ok in zip(actions, allowed) if ok),
            shield_time_us=round(decision_us, 3), deadlock=deadlock or None))
        if crashed:
            reason = "crashed"
            break
        if terminated or truncated:
            reason = "end-of-trace"
            break
    steps_t = tuple(steps)
    return Episode(id=index, steps=steps_t, end=make_end(steps_t, reason), seed=seed)


def _rows(obs) -> tuple[tuple[float, ...], ...]:
    """An observation as rows of numbers (a discrete one is one row of one number)."""
    arr = np.asarray(obs, dtype=np.float64)
    if arr.ndim < 2:
        arr = arr.reshape(1, -1)
    elif arr.ndim > 2:
        arr = arr.reshape(arr.shape[0], -1)
    return tuple(tuple(float(x) for x in row) for row in arr)


_SESSION: Optional[Session] = None


def _init_worker(settings: RecordSettings) -> None:
    global _SESSION
    _SESSION = Session(settings)


def _work(index: int) -> Episode:
    assert _SESSION is not None
    return _SESSION.episode(index)


def episodes(settings: RecordSettings) -> Iterator[Episode]:
    """The episodes of a recording, in order, from ``settings.workers`` processes (or from
    Ray tasks with ``executor="ray"``)."""
    if settings.executor == "ray":
        from .executors import ray_episodes

        yield from ray_episodes(settings, settings.ray_address)
        return
    if settings.workers <= 1:
        session = Session(settings)
        for i in range(settings.episodes):
            yield session.episode(i)
        return
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    with ctx.Pool(settings.workers, initializer=_init_worker, initargs=(settings,)) as pool:
        try:
            yield from pool.imap(_work, range(settings.episodes))
        finally:
            pool.terminate()


def check_settings(settings: RecordSettings, out: Path):
    """Everything that can be checked before an episode runs: environment, agent (its spaces
    against the environment's), shield (its operations and variables against the
    environment's actions and states), output."""
    from .agents import load_agent
    from .shield import check_vocabulary, load_shield

    if settings.episodes < 1:
        raise InputError("--episodes must be at least 1")
    if settings.executor not in ("local", "ray"):
        raise InputError(f"unknown executor {settings.executor!r}; the executors are local, ray")
    adapter, config, _ = resolve(settings)
    actions = adapter.actions
    if settings.fallback is not None and settings.fallback not in actions:
        raise InputError(f"unknown fallback action {settings.fallback!r}; the actions are "
                         f"{', '.join(actions)}")
    env = adapter.make_env(config)
    try:
        agent = load_agent(settings.agent, adapter=adapter, env=env)
        shield = load_shield(settings.shield, actions=actions)
        check_vocabulary(shield, adapter, env)
    finally:
        env.close()
    if out.is_dir():
        raise InputError(f"the output {out} is a folder; give a file name such as run.mcap")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "ab"):
            pass
    except OSError as exc:
        raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    return agent, shield


def recording_header(settings: RecordSettings, agent, shield):
    """The run header of a recording: environment (adapter, configuration, horizon), agent
    and shield with their hashes."""
    adapter, config, horizon = resolve(settings)
    return new_header(
        "recorded", environment=adapter.name, environment_id=adapter.env_id,
        environment_config=config, horizon=horizon,
        agent_id=agent.id, agent_sha256=agent.sha256,
        agent_file=str(Path(agent.path).resolve()), shield_name=shield.name,
        shield_sha256=shield.sha256, base_seed=settings.seed, model_name=adapter.model_name,
        variables=list(adapter.variables), actions=list(adapter.actions))


def record(settings: RecordSettings, out: str | Path,
           progress: Optional[Callable[[Episode], None]] = None) -> tuple[int, int, int]:
    """Record ``settings.episodes`` episodes into ``out``; (episodes, steps, crashes).

    Bad settings raise before any episode runs. Interrupted, the file keeps every
    finished episode (the exception is re-raised after the file is closed).
    """
    out = Path(out)
    agent, shield = check_settings(settings, out)
    header = recording_header(settings, agent, shield)
    counts = [0, 0, 0]
    with EpisodeWriter(out, header) as writer:
        for episode in episodes(settings):
            writer.write(episode)
            counts[0] += 1
            counts[1] += episode.end.steps
            counts[2] += episode.end.crashed
            if progress is not None:
                progress(episode)
    return counts[0], counts[1], counts[2]
