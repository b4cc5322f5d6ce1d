"""Recording: run an agent under a shield for many episodes and write them to MCAP.

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
from .episodes.model import HIGHWAY, Episode, StepRecord, make_end
from .errors import InputError
from .highway import ACTIONS, ENV_ID, env_config

__all__ = ["RecordSettings", "run_episode", "record", "Session"]


@dataclass(frozen=True)
class RecordSettings:
    agent: str
    shield: str
    episodes: int
    seed: int = 0
    duration: int = 60
    profile: str = "base"
    fallback: str = "SLOWER"
    workers: int = 1
    executor: str = "local"
    ray_address: Optional[str] = None


class Session:
    """What one process needs to run episodes: environment, agent, shield (built once).

    ``config`` overrides the environment configuration (re-simulation uses the recorded one).
    """

    def __init__(self, settings: RecordSettings, config: Optional[dict] = None) -> None:
        import gymnasium as gym
        import highway_env  # noqa: F401 - registers the environments
        import torch

        from .agents import load_agent
        from .shield import load_shield
        from .shielding import ShieldWrapper

        torch.set_num_threads(1)
        self.settings = settings
        self.agent = load_agent(settings.agent)
        self.shield = load_shield(settings.shield, actions=ACTIONS)
        config = config or env_config(settings.profile, settings.duration)
        self.env = ShieldWrapper(gym.make(ENV_ID, config=config), self.shield,
                                 settings.fallback)

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
    obs, info = env.reset(seed=seed)
    steps = [StepRecord(0, 0.0, None, info["b_state"], 0.0, False,
                        observation=_rows(obs))]
    reason = "time-limit"
    for k in range(1, s.duration + 1):
        values = agent.values(obs)
        allowed = env.action_masks()
        decision_us = info["shield"]["decision_us"]
        if prefix is not None and k <= len(prefix):
            action, deadlock = ACTIONS.index(prefix[k - 1]), False
        else:
            action, deadlock = choose(values, allowed, env.fallback)
        obs, reward, terminated, truncated, info = env.step(action)
        crashed = bool(info.get("crashed", False))
        steps.append(StepRecord(
            step=k, time=float(k), action=ACTIONS[action], state=info["b_state"],
            reward=float(reward), crashed=crashed, observation=_rows(obs),
            action_values={a: float(v) for a, v in zip(ACTIONS, values)},
            preferred_action=ACTIONS[int(np.argmax(values))],
            allowed_actions=tuple(a for a, ok in zip(ACTIONS, allowed) if ok),
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
    return tuple(tuple(float(x) for x in row) for row in np.asarray(obs))


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
    """Everything that can be checked before an episode runs: agent, shield, output."""
    from .agents import load_agent
    from .shield import load_shield

    if settings.episodes < 1:
        raise InputError("--episodes must be at least 1")
    if settings.executor not in ("local", "ray"):
        raise InputError(f"unknown executor {settings.executor!r}; the executors are local, ray")
    if settings.fallback not in ACTIONS:
        raise InputError(f"unknown fallback action {settings.fallback!r}; the actions are "
                         f"{', '.join(ACTIONS)}")
    env_config(settings.profile, settings.duration)
    agent = load_agent(settings.agent)
    shield = load_shield(settings.shield, actions=ACTIONS)
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
    """The run header of a recording: environment, agent and shield with their hashes."""
    return new_header(
        "recorded", environment_id=ENV_ID,
        environment_config=env_config(settings.profile, settings.duration),
        agent_id=agent.id, agent_sha256=agent.sha256, shield_name=shield.name,
        shield_sha256=shield.sha256, base_seed=settings.seed, model_name=HIGHWAY.name,
        variables=list(HIGHWAY.variables), actions=list(ACTIONS))


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
