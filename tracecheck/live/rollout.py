"""One rollout loop: an agent in an environment under a shield, one episode at a time.

Recording runs it for fresh episodes; re-simulation runs it again from a recorded seed, with
the recorded actions first (each reproduced state checked against the recording) and the
agent under the shield after them. Both go through :func:`run_episode`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence

import numpy as np

from ..episodes.model import Episode, StepRecord, make_end
from ..errors import InputError, TracecheckError

__all__ = ["RecordSettings", "resolve", "Session", "run_episode", "Diverged", "end_reason"]


class Diverged(Exception):
    """A re-run state differs from the recorded one (raised by :func:`run_episode`'s check,
    caught by re-simulation, which reports the episode as not reproduced)."""

    def __init__(self, step: int, detail: str) -> None:
        super().__init__(f"step {step}: {detail}")
        self.step, self.detail = step, detail


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
    #: the environment (an installed one's name or package.module:Class)
    env: Optional[str] = None
    env_config: Optional[dict] = None
    #: continuous actions: how the shield makes an action allowed (project, replace, mask;
    #: None: project for a Box, mask for a hybrid space) and the unit of each component in
    #: projection distances (None: 1 each)
    shield_mode: Optional[str] = None
    scale: Optional[tuple[float, ...]] = None


def resolve(settings: RecordSettings):
    """(adapter, environment configuration, horizon) of ``settings``."""
    from .adapter import load_adapter

    adapter = load_adapter(settings.env)
    horizon = settings.duration or adapter.horizon
    if horizon < 1:
        raise InputError("--duration must be at least 1")
    config = adapter.config(settings.env_config, profile=settings.profile, horizon=horizon)
    return adapter, config, horizon


class Session:
    """What one process needs to run episodes: environment, agent, shield (built once).

    ``config`` overrides the environment configuration (re-simulation uses the recorded one).
    ``shield`` is the shield itself, loaded by the caller (a worker process or a Ray task gets
    it pickled as its text: the shield that was checked, never ``settings.shield`` looked up
    again).
    """

    def __init__(self, settings: RecordSettings, config: Optional[dict] = None, *,
                 shield) -> None:
        from .agents import load_agent
        from ..checking.shield import for_actions
        from .wrapper import ShieldWrapper

        self.settings = settings
        self.adapter, default, self.horizon = resolve(settings)
        self.config = config or default
        env = self.adapter.make_env(self.config)
        self.agent = load_agent(settings.agent, adapter=self.adapter, env=env)
        actions = tuple(self.adapter.actions)
        self.shield = for_actions(shield, actions)
        self.env = ShieldWrapper(env, self.shield, settings.fallback, self.adapter,
                                 mode=settings.shield_mode, scale=settings.scale)
        #: a Dict or Tuple observation as the numbers it is recorded as (None: as it is)
        self.flat = flattening(env.observation_space)
        self.step_reached = 0  # of the episode running: where an error happened

    def episode(self, index: int) -> Episode:
        return run_episode(self, index)

    def reconfigure(self, config: dict) -> None:
        """Run the next episodes in an environment made with ``config`` (the same agent
        and shield): a search's settings, one episode's own."""
        from .wrapper import ShieldWrapper

        if config == self.config:
            return
        env = self.adapter.make_env(config)
        self.env.close()
        self.config = config
        self.env = ShieldWrapper(env, self.shield, self.settings.fallback, self.adapter,
                                 mode=self.settings.shield_mode, scale=self.settings.scale)
        self.flat = flattening(env.observation_space)


def run_episode(session: Session, index: int, *, seed: Optional[int] = None,
                script: Sequence[str] = (),
                check: Optional[Callable[[int, dict[str, Any]], Optional[str]]] = None,
                options: Optional[dict[str, Any]] = None) -> Episode:
    """Episode ``index``: seed ``seed + index`` (or ``seed``), up to the horizon.

    The agent chooses its best action among those the shield allows; the first actions are
    ``script``'s instead, when given (re-simulation). ``check(step, state)`` sees each state
    of the scripted part, the initial one included, and returns what differs from the
    recording, if anything: that ends the rollout with :class:`Diverged`. ``options``: the
    values of the adapter's ``reset_parameters`` the episode starts with (a search's; kept
    in the episode as ``reset_options``).
    """
    seed = session.settings.seed + index if seed is None else seed
    try:
        if session.env.continuous is not None:
            episode = _continuous_episode(session, index, seed=seed, script=script,
                                          check=check, options=options)
        else:
            episode = _discrete_episode(session, index, seed=seed, script=script, check=check,
                                        options=options)
        return replace(episode, reset_options=dict(options)) if options else episode
    except TracecheckError as exc:  # a state or observation the step could not take: where
        if isinstance(exc, InputError) and not exc.message.startswith("episode "):
            step = session.step_reached
            raise InputError(f"episode {index} (seed {seed}), "
                             f"{'the reset' if not step else f'step {step}'}: {exc.message}",
                             hint=exc.hint) from exc
        raise


def _asked(agent, ask: Callable[[Any], Any], obs) -> Any:
    """``ask(obs)`` (the agent's values or action), an error of the agent's own code (a
    policy whose weights hold NaN: torch refuses its distribution) said as its."""
    try:
        return ask(obs)
    except TracecheckError:
        raise
    except Exception as exc:  # noqa: BLE001 - the agent's own code: said, with where
        raise InputError(f"the agent {Path(agent.path).name} raised {type(exc).__name__} "
                         f"for the observation: {str(exc).strip()[:300]}",
                         hint="check the agent's weights (a NaN?) and that it was trained "
                              "on this environment; tracecheck --debug … shows the "
                              "traceback") from exc


def _discrete_episode(session: Session, index: int, *, seed: int, script: Sequence[str],
                      check, options=None) -> Episode:
    """:func:`run_episode` for discrete actions."""
    from .wrapper import choose

    env, agent = session.env, session.agent
    actions, dt = env.actions, session.adapter.seconds_per_step
    obs, info, steps = _start(session, seed, check, options)
    reason = "time-limit"
    for k in range(1, session.horizon + 1):
        session.step_reached = k - 1  # the observation came from the step before
        _finite(obs, session.flat)
        session.step_reached = k
        values = _asked(agent, agent.values, obs)
        allowed = env.shield_mask()  # none in a deadlock: the fallback is taken, and said
        decision_us, problem = info["shield"]["decision_us"], info["shield"].get("problem")
        if k <= len(script):
            action, deadlock = actions.index(script[k - 1]), False
        else:
            action, deadlock = choose(values, allowed, env.fallback)
        obs, reward, terminated, truncated, info = env.step(action)
        if k <= len(script):
            _check(check, k, info["b_state"])
        crashed = bool(info["crashed"])
        steps.append(StepRecord(
            step=k, time=float(k * dt), action=actions[action], state=info["b_state"],
            reward=float(reward), crashed=crashed, observation=_rows(obs, session.flat),
            action_values={a: float(v) for a, v in zip(actions, values)},
            preferred_action=actions[int(np.asarray(values).argmax())],
            allowed_actions=tuple(a for a, ok in zip(actions, allowed) if ok),
            shield_time_us=round(decision_us, 3), deadlock=deadlock or None,
            shield_problem=problem))
        if crashed or terminated or truncated:
            reason = end_reason(crashed, terminated, truncated)
            break
    steps_t = tuple(steps)
    return Episode(id=index, steps=steps_t, end=make_end(steps_t, reason), seed=seed)


def _finite(obs, flat=None) -> None:
    """An observation the agent can act on: no NaN or infinity (a policy network turns one
    into NaN probabilities, and stable-baselines3 then fails with a traceback); ``flat``:
    a Dict or Tuple observation's numbers (see :func:`flattening`)."""
    if _one_number(obs):
        return
    arr = np.asarray(obs if flat is None else flat(obs))
    if arr.dtype.kind in "fc" and not np.isfinite(arr).all():
        value, where = _not_finite(obs if flat is not None else arr)
        raise InputError(f"the observation holds {value} (at {where}), which the agent "
                         "cannot act on",
                         hint="the environment gave a NaN or infinite observation: check it "
                              "at this seed and step, or replace such values in an "
                              "observation wrapper")


def _not_finite(obs, place: str = "") -> Optional[tuple[Any, str]]:
    """The first NaN or infinity in ``obs`` (an array, or a Dict or Tuple observation's
    parts, by key), and where: ``index [2]``, ``['pose'][1]``."""
    if isinstance(obs, (Mapping, tuple, list)):  # (a Tuple's observation as a list too)
        for key, part in (obs.items() if isinstance(obs, Mapping) else enumerate(obs)):
            found = _not_finite(part, f"{place}[{key!r}]")
            if found is not None:
                return found
        return None
    arr = np.asarray(obs)
    if arr.dtype.kind not in "fc" or np.isfinite(arr).all():
        return None
    index = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
    value = arr[index] if index else arr[()]
    return value, (place + "".join(f"[{i}]" for i in index) if place else f"index "
                   f"{list(index)}")


def _start(session, seed: int, check, options=None) -> tuple[Any, dict, list[StepRecord]]:
    """The environment reset with ``seed`` (and ``options``): (observation, info, [the
    initial state's record]), the initial state checked by ``check``."""
    session.step_reached = 0
    obs, info = session.env.reset(seed=seed, options=options or None)
    _check(check, 0, info["b_state"])
    return obs, info, [StepRecord(0, 0.0, None, info["b_state"], 0.0, False,
                                  observation=_rows(obs, session.flat))]


def _continuous_episode(session: Session, index: int, *, seed: int,
                        script: Sequence[Any], check, options=None) -> Episode:
    """:func:`run_episode` for continuous actions: the agent (or ``script``: action vectors)
    proposes, the shield's mode decides (:mod:`tracecheck.live.continuous`); each step keeps
    the proposal, the executed parameters, the distance and the allowed intervals."""
    env, agent = session.env, session.agent
    dt = session.adapter.seconds_per_step
    obs, info, steps = _start(session, seed, check, options)
    reason = "time-limit"
    for k in range(1, session.horizon + 1):
        session.step_reached = k - 1  # the observation came from the step before
        if k > len(script):
            _finite(obs, session.flat)
        session.step_reached = k
        proposal = script[k - 1] if k <= len(script) else _asked(agent, agent.act, obs)
        allowed = tuple(a for a, ok in zip(env.actions, env.allowed) if ok)  # decided in
        obs, reward, terminated, truncated, info = env.step(proposal)
        if k <= len(script):
            _check(check, k, info["b_state"])
        crashed, decided = bool(info["crashed"]), info["shield"]
        scores = decided["scores"]  # a hybrid space's: the agent's score of each operation
        steps.append(StepRecord(
            step=k, time=float(k * dt), action=decided["taken"], state=info["b_state"],
            reward=float(reward), crashed=crashed, observation=_rows(obs, session.flat),
            allowed_actions=allowed,
            shield_time_us=round(decided["step_decision_us"], 3),
            deadlock=decided["fallback_taken"] or None, shield_problem=decided["problem"],
            parameters=decided["executed"] or None, proposal=decided["proposal"] or None,
            projection_distance=decided["distance"],
            allowed_intervals=decided["intervals"],
            action_values=scores,
            preferred_action=decided["requested"] if scores is not None else None))
        if crashed or terminated or truncated:
            reason = end_reason(crashed, terminated, truncated)
            break
    steps_t = tuple(steps)
    return Episode(id=index, steps=steps_t, end=make_end(steps_t, reason), seed=seed)


def end_reason(crashed: bool, terminated: bool, truncated: bool) -> str:
    """Why an episode ended, from Gymnasium's own flags: a crash; ``time-limit`` where the
    environment truncated it (its own time limit, like ``--duration``'s); else
    ``end-of-trace`` (it terminated: a goal reached, a terminal state). Gymnasium's rule:
    a step both terminated and truncated ended in a terminal state."""
    if crashed:
        return "crashed"
    return "time-limit" if truncated and not terminated else "end-of-trace"


def _one_number(obs) -> bool:
    """Whether ``obs`` is a discrete observation: an integer (a grid world's cell)."""
    return type(obs) is int or isinstance(obs, np.integer)


def _rows(obs, flat=None) -> tuple[tuple[float, ...], ...]:
    """An observation as rows of numbers (a discrete one is one row of one number; a Dict
    or Tuple one, with ``flat``, one row of its flattened numbers: see :func:`flattening`)."""
    if _one_number(obs):  # one number, kept without numpy (a step of a grid world)
        return ((float(obs),),)
    arr = np.asarray(obs if flat is None else flat(obs), dtype=np.float64)
    if arr.ndim < 2:
        arr = arr.reshape(1, -1)
    elif arr.ndim > 2:
        arr = arr.reshape(arr.shape[0], -1)
    return tuple(tuple(float(x) for x in row) for row in arr)




def flattening(space) -> Optional[Callable[[Any], np.ndarray]]:
    """What a Dict or Tuple observation space's observations are checked and recorded as:
    gymnasium's ``flatten`` of them (what its ``FlattenObservation`` gives: a ``Discrete``
    part one-hot, the parts in the space's order); None for any other space (the
    observation as it is)."""
    from gymnasium import spaces

    if not isinstance(space, (spaces.Dict, spaces.Tuple)):
        return None

    def flat(obs) -> np.ndarray:
        try:
            return spaces.flatten(space, obs)
        except Exception as exc:  # noqa: BLE001 - gymnasium's, for a space or value it
            #                       cannot flatten (a Sequence or Graph part, a missing key)
            raise InputError(f"the observation {str(obs)[:120]} of the observation space "
                             f"{str(space)[:200]} cannot be recorded as numbers "
                             f"({type(exc).__name__}: {exc})",
                             hint="give the environment an observation gymnasium can flatten "
                                  "(wrap it in gymnasium's FlattenObservation in your "
                                  "adapter's make_env, say)") from None
    return flat


def _check(check, step: int, state: dict) -> None:
    if check is not None:
        problem = check(step, state)
        if problem:
            raise Diverged(step, problem)
