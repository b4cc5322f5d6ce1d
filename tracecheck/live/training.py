"""Training, for every environment with an adapter and every algorithm: one path.

:data:`LEARNERS` is the table: each stable-baselines3 algorithm ``train --algorithm`` takes,
its settings, and whether it learns from the shield's mask. Every learner runs on the
adapter's environment, its episodes cut at the horizon (``--duration``, else the adapter's:
the same length as ``record``), and with ``--shield`` wrapped in
:class:`~tracecheck.live.wrapper.ShieldWrapper`:

* ``maskable-ppo`` — sb3-contrib's MaskablePPO (``pip install 'tracecheck[maskable]'``): the
  policy's distribution is restricted to the allowed actions, in rollouts and updates alike
  (without ``--shield``, under ``none``: every action allowed).
* ``dqn`` — stable-baselines3's DQN; under a shield its action selection is masked:
  exploration draws uniformly among the allowed actions (also before learning starts) and the
  greedy choice is the best-valued allowed action. The TD target is left as DQN has it — the
  maximum over *all* actions of the next state — because the replay buffer does not keep the
  next state's mask: the values of actions the shield blocks are still learned from, and may
  be overestimated, but never chosen. An environment may set its own (its adapter's
  ``training_settings``).
* ``ppo``, ``a2c`` — stable-baselines3's PPO and A2C do not take a mask. Under a shield an
  action it blocks is *replaced* (the wrapper's rule: the fallback if the shield allows it,
  else the first allowed action): the learner learns in the shielded environment, crediting
  what happened to the action it asked for. The card says ``"shielding": "replaced"``.
* ``sac``, ``td3`` — stable-baselines3's SAC and TD3, for continuous actions (an adapter
  that declares ``parameters``; ``ppo`` and ``a2c`` take them too). Under a shield the
  wrapper *projects* each action onto the allowed set (:mod:`tracecheck.live.continuous`):
  the learner credits what happened to the action it proposed; with
  ``intervention_penalty`` k the reward of a step is lowered by k times the projection
  distance (off by default). The card says ``"shielding": "projected"``.
* ``q-learning`` — a table (:func:`train_q_table`), for discrete observations, no shield.

In a deadlock (the shield allows nothing) the mask holds the fallback action only, which is
what the wrapper takes: a masked learner never sees an empty mask. Beside the agent: its model
card (``NAME.json``: algorithm, settings, shield and its sha256, the episode returns) and its
learning curve (``NAME.curve.png``, drawn by the ``draw_curve`` the caller gives: the CLI's
is :func:`tracecheck.render.curves.learning_curve`; without one there is no curve), all by
the output rule.
"""

from __future__ import annotations

import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

import numpy as np

from ..errors import InputError
from .agents import Q_LEARNING, agent_outputs, file_sha256, save_model, write_card

__all__ = ["Training", "train_agent", "train_q_table", "shielding_text", "LEARNERS", "ALGORITHMS", "Learner", "Returns",
           "Progress", "CurveDrawer"]

#: ``progress(steps done, total, mean return of the last episodes or None)``
Progress = Callable[[int, int, Optional[float]], None]
#: ``draw_curve(end steps, returns, path, *, window, steps, title)``: writes the learning
#: curve to ``path`` (:func:`tracecheck.render.curves.learning_curve`)
CurveDrawer = Callable[..., Any]


def _dqn_settings(steps: int) -> dict[str, Any]:
    return {"learning_starts": min(1000, steps // 10), "exploration_fraction": 0.5,
            "learning_rate": 1e-3, "gamma": 0.99, "target_update_interval": 250}


def _ppo_settings(steps: int) -> dict[str, Any]:
    # rollouts of at most SB3's 2048 steps, as equal as whole batches of 64 make them, so
    # that the last one ends close to ``steps``
    rollouts = -(-steps // 2048)
    return {"n_steps": -(-steps // (rollouts * 64)) * 64, "batch_size": 64,
            "learning_rate": 3e-4, "gamma": 0.99}


def _a2c_settings(steps: int) -> dict[str, Any]:
    return {"n_steps": 5, "learning_rate": 7e-4, "gamma": 0.99}


def _off_policy_settings(steps: int) -> dict[str, Any]:
    """SAC's and TD3's: learning after a tenth of the steps (at most 1000)."""
    return {"learning_starts": min(1000, steps // 10), "learning_rate": 3e-4,
            "buffer_size": 100_000, "batch_size": 256, "gamma": 0.99}


@dataclass(frozen=True, kw_only=True)
class Learner:
    """One ``--algorithm``: its class, its settings, and how a shield reaches it."""

    name: str                       #: the class name, as the model card says it
    package: str                    #: where the class lives
    masks: bool                     #: chooses among ``action_masks()`` (else: replaced)
    settings: Callable[[int], dict[str, Any]]  #: steps -> the algorithm's own settings
    needs_mask: bool = False        #: cannot run without the wrapper (MaskablePPO)
    discrete: bool = True           #: takes discrete actions
    continuous: bool = False        #: takes continuous actions (a Box)


LEARNERS: dict[str, Learner] = {
    "dqn": Learner(name="DQN", package="stable_baselines3", masks=True,
                   settings=_dqn_settings),
    "ppo": Learner(name="PPO", package="stable_baselines3", masks=False,
                   settings=_ppo_settings, continuous=True),
    "a2c": Learner(name="A2C", package="stable_baselines3", masks=False,
                   settings=_a2c_settings, continuous=True),
    "maskable-ppo": Learner(name="MaskablePPO", package="sb3_contrib", masks=True,
                            settings=_ppo_settings, needs_mask=True),
    "sac": Learner(name="SAC", package="stable_baselines3", masks=False,
                   settings=_off_policy_settings, discrete=False, continuous=True),
    "td3": Learner(name="TD3", package="stable_baselines3", masks=False,
                   settings=_off_policy_settings, discrete=False, continuous=True),
}
ALGORITHMS = (*LEARNERS, "q-learning")


class Returns:
    """The returns of the finished episodes, with the environment step each ended at.

    >>> r = Returns(window=2); r.add(5, 1.0); r.add(9, 3.0); r.add(12, 5.0); r.mean()
    4.0
    """

    def __init__(self, window: int = 20) -> None:
        self.window = window
        self.steps: list[int] = []
        self.returns: list[float] = []

    def add(self, step: int, value: float) -> None:
        self.steps.append(int(step))
        self.returns.append(float(value))

    def mean(self) -> Optional[float]:
        """The mean return of the last ``window`` finished episodes (None before the first)."""
        return float(np.mean(self.returns[-self.window:])) if self.returns else None

    def summary(self, curve: Optional[Path], points: int = 1000) -> dict[str, Any]:
        """For the model card: every episode's (end step, return), or — past ``points``
        episodes — the mean return of each block of consecutive episodes at its last step."""
        n = len(self.returns)
        per = max(1, -(-n // points))
        ends = [self.steps[min(i + per, n) - 1] for i in range(0, n, per)]
        means = [round(float(np.mean(self.returns[i:i + per])), 6) for i in range(0, n, per)]
        last = self.mean()
        return {"file": curve.name if curve is not None else None, "episodes": n,
                "window": self.window,
                "mean_return_last": None if last is None else round(last, 6),
                "episodes_per_point": per, "end_steps": ends, "returns": means}


def curve_path(out: Path) -> Path:
    """The learning curve beside an agent file: ``NAME.curve.png``."""
    return out.with_suffix(".curve.png")


def _outputs(out: Path, suffix: str, example: str, force: bool, inputs: Sequence[Path],
             curve: bool) -> tuple[Path, Path, Optional[Path]]:
    """Agent, card and (when one is drawn) curve, checked by the output rule before anything
    trains."""
    from ..outputs import check_output

    what = "a Q-table" if suffix == ".npy" else "a trained agent"
    if out.suffix != suffix:
        raise InputError(f"{what} is saved as {suffix}, not {out.name}")
    out, card = agent_outputs(out, example, force=force, inputs=inputs)
    if not curve:
        return out, card, None
    return out, card, check_output(curve_path(out), inputs, force=force, what="learning curve")


@dataclass(frozen=True, kw_only=True)
class Training:
    """How an agent is trained (everything but the environment, the algorithm and the
    files): its steps, seed and episode horizon, the named configuration, and for continuous
    actions under a shield how the shield acts and what an intervention costs.

    >>> Training(steps=2000, seed=3).horizon is None
    True
    """

    steps: int                                  #: environment steps
    seed: int = 0                               #: stable-baselines3's and NumPy's seed
    horizon: Optional[int] = None               #: agent steps per episode (None: the adapter's)
    profile: Optional[str] = None               #: the named configuration (the model card's)
    intervention_penalty: float = 0.0           #: reward lost per unit of projection distance
    shield_mode: Optional[str] = None           #: continuous: project, replace or mask
    scale: Optional[Sequence[float]] = None     #: continuous: the unit of each component


def train_agent(adapter, config: dict, algorithm: str, out: str | Path, training: Training, *,
                shield=None, progress: Optional[Progress] = None, force: bool = False,
                inputs: Sequence[Path] = (),
                draw_curve: Optional[CurveDrawer] = None) -> dict[str, Any]:
    """Train ``algorithm`` on the adapter's environment, under ``shield`` if given; save the
    agent (``.zip``), its learning curve and its model card (see the module docstring).

    Args:
        adapter: the environment's adapter.
        config: the environment's configuration (:meth:`EnvAdapter.config`).
        algorithm: a key of :data:`LEARNERS`.
        out: the agent file to write (its card ``NAME.json`` beside it).
        training: steps, seed, horizon and the rest (:class:`Training`).
        shield: a shield in the loop (masked or replaced, see the module docstring).
        progress: called with (steps done, total, mean return of the last episodes).
        force: replace existing outputs.
        inputs: the files read (never an output).
        draw_curve: draws the learning curve (None: none drawn).

    Returns:
        The model card.

    Example: ``train_agent(get_adapter("corridor"), {}, "ppo", "a.zip", Training(steps=2000))``.
    """
    import torch

    steps, seed, horizon, profile = (training.steps, training.seed, training.horizon,
                                     training.profile)
    intervention_penalty, shield_mode, scale = (training.intervention_penalty,
                                                training.shield_mode, training.scale)

    if algorithm not in LEARNERS:
        raise InputError(f"unknown algorithm {algorithm!r}; the algorithms are "
                         f"{', '.join(ALGORITHMS)}")
    learner = LEARNERS[algorithm]
    continuous = bool(adapter.parameters)
    if not (learner.continuous if continuous else learner.discrete):
        takes = "continuous actions (sac, td3, ppo, a2c)" if continuous else \
            "discrete actions (dqn, ppo, a2c, maskable-ppo, q-learning)"
        raise InputError(f"--algorithm {algorithm} does not fit {adapter.name}, which takes "
                         f"{takes.split(' (')[0]}", hint=f"give one for {takes}")
    if not (intervention_penalty >= 0 and intervention_penalty < float("inf")):
        raise InputError(f"--intervention-penalty {intervention_penalty}: give a finite "
                         "number, 0 or more")
    if intervention_penalty and (shield is None or not continuous):
        raise InputError("--intervention-penalty lowers the reward by the projection distance: "
                         "it needs continuous actions and --shield")
    out, card_path, curve = _outputs(Path(out), ".zip", "agent.zip", force, inputs,
                                     draw_curve is not None)
    if shield is None and learner.needs_mask:
        from ..checking.shield import load_shield

        shield = load_shield("none", actions=tuple(adapter.actions))
    torch.set_num_threads(1)
    horizon = horizon or adapter.horizon
    if continuous and shield_mode is None:  # the default: project a Box, mask a hybrid
        from .continuous import space_parts

        shield_mode = "mask" if space_parts(adapter, _space(adapter, config))[0] else "project"
    vec = _vec_env(adapter, config, shield, horizon, intervention_penalty,
                   mode=shield_mode, scale=scale)
    settings = {**learner.settings(steps), **adapter.training_settings(algorithm, steps)}
    policy = "MultiInputPolicy" if type(vec.observation_space).__name__ == "Dict" else \
        "MlpPolicy"
    model = _learner_class(learner, shield is not None)(policy, vec, seed=seed, verbose=0,
                                                        device="cpu", **settings)
    returns = Returns()
    start = time.perf_counter()
    rollout = settings.get("n_steps", 1)  # PPO and A2C take whole rollouts
    total = -(-steps // rollout) * rollout
    model.learn(total_timesteps=steps, callback=_callback(returns, total, progress))
    wall = time.perf_counter() - start
    vec.close()
    save_model(model, out)
    card = _card(adapter, config, learner.name, out, seed=seed, steps=steps, wall=wall,
                 horizon=horizon, settings={**settings, "policy": policy}, profile=profile,
                 shield=shield, shielding=_shielding(learner, shield, continuous, shield_mode),
                 returns=returns,
                 curve=curve, packages=("torch", "stable_baselines3", learner.package),
                 done=int(model.num_timesteps))
    if intervention_penalty:
        card["intervention_penalty"] = intervention_penalty
    if continuous and shield is not None and scale is not None:  # the projection's units
        card["projection_scale"] = [float(x) for x in scale]
    _finish(card, returns, curve, card_path, draw_curve)
    return card


def _shielding(learner: Learner, shield, continuous: bool = False,
               mode: Optional[str] = None) -> str:
    """How the shield reached the learner: none, masked, replaced or projected."""
    if shield is None:
        return "none"
    if continuous:
        return {"replace": "replaced", "mask": "masked, values projected"}.get(mode or "",
                                                                             "projected")
    return "masked" if learner.masks else "replaced"


def _penalised(env, penalty: float):
    """``env`` (a shielded continuous one) with each step's reward lowered by ``penalty``
    times its projection distance."""
    import gymnasium as gym

    class Penalised(gym.Wrapper):
        def step(self, action):
            obs, reward, terminated, truncated, info = self.env.step(action)
            return (obs, float(reward) - penalty * info["shield"]["distance"], terminated,
                    truncated, info)

    return Penalised(env)


def _vec_env(adapter, config: dict, shield, horizon: int, penalty: float = 0.0, *,
             mode: Optional[str] = None, scale: Optional[Sequence[float]] = None):
    """One environment, cut at ``horizon``, its episodes' returns reported (Monitor), under
    the shield's wrapper when there is one; checked to have the adapter's actions."""
    from gymnasium import spaces
    from gymnasium.wrappers import TimeLimit
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    if adapter.parameters:  # the action space fits the declaration (InputError if not)
        from .continuous import space_parts

        hybrid, _ = space_parts(adapter, _space(adapter, config))
        if hybrid and shield is None:  # the agent's one vector: made by the wrapper
            from ..checking.shield import load_shield

            shield = load_shield("none", actions=tuple(adapter.actions),
                                 parameters=adapter.parameters)

    def make():
        env = Monitor(TimeLimit(adapter.make_env(config), max_episode_steps=horizon))
        from .wrapper import ShieldWrapper, indexed

        if shield is None:  # spaces from 0, as the agent acts and observes
            return indexed(_said(env, adapter.name))
        shielded = ShieldWrapper(env, shield, adapter=adapter, mode=mode, scale=scale)
        return indexed(_penalised(shielded, penalty) if penalty else shielded)

    vec = DummyVecEnv([make])
    offset = _offset_parts(vec.observation_space)
    if offset:  # (a whole Discrete(n, start) observation is observed as its index)
        vec.close()
        raise InputError(f"{adapter.name}'s observation space {vec.observation_space} holds "
                         f"a discrete part that does not start at 0 ({offset[0]}): "
                         "Stable-Baselines3 one-hot encodes discrete parts from 0",
                         hint="start that part at 0 in the environment (or in a wrapper its "
                              "adapter's make_env adds)")
    space = vec.action_space
    if not adapter.parameters and (not isinstance(space, spaces.Discrete)
                                   or int(space.n) != len(adapter.actions)):
        vec.close()
        raise InputError(f"{adapter.name} has the action space {space}; train needs "
                         f"{len(adapter.actions)} discrete actions, one per action of the "
                         f"adapter ({', '.join(adapter.actions)})")
    return vec


def _offset_parts(space, place: str = "") -> list[str]:
    """Where a space holds a ``Discrete(n, start)`` part (in a Dict or Tuple) or a
    ``MultiDiscrete`` (anywhere) that does not start at 0."""
    from gymnasium import spaces

    parts = getattr(space, "spaces", None)
    if isinstance(parts, dict):
        return [found for key, part in parts.items()
                for found in _offset_parts(part, f"{place}[{key!r}]")]
    if isinstance(parts, tuple):
        return [found for i, part in enumerate(parts)
                for found in _offset_parts(part, f"{place}[{i}]")]
    offset = (isinstance(space, spaces.Discrete) and place and int(space.start) != 0) or \
        (isinstance(space, spaces.MultiDiscrete) and bool(np.any(space.start != 0)))
    return [f"{place} {space}".strip()] if offset else []


def _said(env, name: str):
    """``env`` with an exception of its ``reset`` or ``step`` said as the adapter ``name``'s
    (:func:`~tracecheck.live.adapter_checks.raised`: exit 2, no traceback), as the shield's
    wrapper says it."""
    import gymnasium as gym

    from ..errors import TracecheckError
    from .adapter_checks import USERS, raised

    class Said(gym.Wrapper):
        def reset(self, **kwargs):
            try:
                return self.env.reset(**kwargs)
            except TracecheckError:
                raise
            except USERS as exc:  # noqa: BLE001 - the environment's own code
                raise raised(name, exc, "in reset()", env=True) from exc

        def step(self, action):
            try:
                return self.env.step(action)
            except TracecheckError:
                raise
            except USERS as exc:  # noqa: BLE001 - the environment's own code
                raise raised(name, exc, "in step()", env=True) from exc
    return Said(env)


def _space(adapter, config: dict):
    """The action space of ``adapter``'s environment in ``config``."""
    env = adapter.make_env(config)
    try:
        return env.action_space
    finally:
        env.close()


def _learner_class(learner: Learner, shielded: bool):
    if learner.package == "sb3_contrib":
        try:
            import sb3_contrib
        except ImportError:
            raise InputError("--algorithm maskable-ppo needs sb3-contrib",
                             hint="pip install 'tracecheck[maskable]'") from None
        return getattr(sb3_contrib, learner.name)
    if learner.name == "DQN" and shielded:
        return _masked_dqn()
    import stable_baselines3

    return getattr(stable_baselines3, learner.name)


def _masked_dqn():
    """``MaskedDQN``: a DQN that explores and exploits only what the mask allows."""
    import stable_baselines3 as sb3
    import torch

    class MaskedDQN(sb3.DQN):
        def _masks(self, n_envs: int) -> np.ndarray:
            return np.stack(self.get_env().env_method("action_masks"))[:n_envs]

        def _sample_action(self, learning_starts, action_noise=None, n_envs: int = 1):
            masks = self._masks(n_envs)
            if self.num_timesteps < learning_starts or np.random.rand() < self.exploration_rate:
                action = np.array([np.random.choice(np.flatnonzero(m)) for m in masks])
            else:
                with torch.no_grad():
                    obs, _ = self.policy.obs_to_tensor(self._last_obs)
                    q = self.q_net(obs).cpu().numpy()
                action = np.where(masks, q, -np.inf).argmax(axis=1)
            return action, action

    return MaskedDQN


def _callback(returns: Returns, total: int, progress: Optional[Progress]):
    """A stable-baselines3 callback: each finished episode's return into ``returns`` (from
    the Monitor's ``info["episode"]``), and ``progress`` every 50 of ``total`` steps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class Report(BaseCallback):
        def _on_step(self) -> bool:
            for info in self.locals.get("infos", ()):
                if "episode" in info:
                    returns.add(self.num_timesteps, info["episode"]["r"])
            if progress is not None and self.num_timesteps % 50 == 0:
                progress(self.num_timesteps, total, returns.mean())
            return True

    return Report()


def _card(adapter, config: dict, algorithm: str, out: Path, *, seed: int, steps: int,
          wall: float, horizon: int, settings: dict, profile: Optional[str], shield,
          shielding: str, returns: Returns, curve: Path,
          packages: Sequence[str], done: Optional[int] = None) -> dict[str, Any]:
    """The model card: what was trained, how, on what, with which libraries; ``done`` the
    steps taken (whole rollouts: PPO's and A2C's may pass ``steps``)."""
    card: dict[str, Any] = {
        "agent": out.name, "algorithm": algorithm, "environment": adapter.name,
        "environment_id": adapter.env_id, "environment_config": config}
    if profile is not None:
        card["reward_profile"] = profile
    card.update({
        "horizon": horizon, "seed": seed, "steps": steps,
        "environment_steps": steps if done is None else done, "wall_time_s": round(wall, 2),
        "settings": settings, "actions": list(adapter.actions),
        "shield": shield.name if shield is not None else None,
        "shield_sha256": shield.sha256 if shield is not None else None,
        "shielding": shielding, "masked": shielding.startswith("masked"),
        "learning_curve": returns.summary(curve),
        "versions": _versions((*packages, "gymnasium", *adapter.requires)),
        "sha256": file_sha256(out)})
    return card


def _versions(packages: Sequence[str]) -> dict[str, str]:
    """Python's version and each package's (those imported that say theirs)."""
    versions = {"python": platform.python_version(), "numpy": np.__version__}
    for package in packages:
        version = getattr(sys.modules.get(package), "__version__", None)
        if version:
            versions[package] = str(version)
    return versions


def _finish(card: dict, returns: Returns, curve: Optional[Path], card_path: Path,
            draw_curve: Optional[CurveDrawer]) -> None:
    """The learning curve (``curve``: its path, None exactly when no ``draw_curve`` draws
    one), then the model card (last: a card means the rest is there)."""
    if curve is not None:
        _draw(card, returns, curve, draw_curve)
    write_card(card, card_path)


def shielding_text(card: dict) -> str:
    """How a model card's agent met its shield, for a sentence: `` under shield S, actions
    projected`` ("" without one)."""
    return {"none": "", "masked": f" under shield {card['shield']}, actions masked",
            "replaced": f" under shield {card['shield']}, blocked actions replaced",
            "projected": f" under shield {card['shield']}, actions projected",
            "masked, values projected": f" under shield {card['shield']}, operations masked "
                                        "and their values projected",
            }[card["shielding"]]


def _draw(card: dict, returns: Returns, curve: Path, draw_curve: CurveDrawer) -> None:
    title = f"{card['algorithm']} on {card['environment']}{shielding_text(card)}, " \
            f"seed {card['seed']}"
    draw_curve(returns.steps, returns.returns, curve, window=returns.window,
               steps=card["environment_steps"], title=title)


def train_q_table(adapter, config: dict, out: str | Path, *, steps: int = 200_000,
                  seed: int = 0, horizon: int = 100, progress: Optional[Progress] = None,
                  force: bool = False, inputs: Sequence[Path] = (),
                  draw_curve: Optional[CurveDrawer] = None) -> dict[str, Any]:
    """Tabular Q-learning (see :data:`~tracecheck.live.agents.Q_LEARNING`) on an environment
    with discrete observations; saves the table as ``.npy``, its learning curve and its
    model card beside it.

    The same seed gives the same table: exploration draws from a generator seeded with it,
    and the environment is reset with it once.
    """
    out, card_path, curve = _outputs(Path(out), ".npy", "agent.npy", force, inputs,
                                     draw_curve is not None)
    from .wrapper import indexed

    env = indexed(adapter.make_env(config))  # actions and observations as indexes 0 … n-1
    n_obs = getattr(env.observation_space, "n", None)
    if n_obs is None:
        raise InputError(f"{adapter.name} has observations {env.observation_space}; Q-learning "
                         "needs a discrete observation space")
    returns = Returns()
    start = time.perf_counter()
    q = _q_learning(env, n_obs, len(adapter.actions), steps, seed, horizon, returns, progress)
    wall = time.perf_counter() - start
    from ..outputs import atomic_file

    with atomic_file(out) as stream:
        np.save(stream, q, allow_pickle=False)
    card = _card(adapter, config, "q-learning", out, seed=seed, steps=steps, wall=wall,
                 horizon=horizon, settings=dict(Q_LEARNING), profile=None, shield=None,
                 shielding="none", returns=returns, curve=curve, packages=())
    _finish(card, returns, curve, card_path, draw_curve)
    return card


def _q_learning(env, n_obs: int, n_act: int, steps: int, seed: int, horizon: int,
                returns: Returns, progress: Optional[Progress]) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = np.zeros((n_obs, n_act))
    p = Q_LEARNING
    decay = max(1, int(steps * p["decay_fraction"]))
    obs, _ = env.reset(seed=seed)
    t, total = 0, 0.0
    for k in range(steps):
        if rng.random() < max(p["epsilon_floor"], 1.0 - k / decay):
            a = int(rng.integers(n_act))
        else:
            row = q[obs]
            a = int(rng.choice(np.flatnonzero(row == row.max())))
        nxt, reward, terminated, truncated, _ = env.step(a)
        target = reward if terminated else reward + p["gamma"] * q[nxt].max()
        q[obs, a] += p["alpha"] * (target - q[obs, a])
        obs, t, total = nxt, t + 1, total + float(reward)
        if terminated or truncated or t >= horizon:
            returns.add(k + 1, total)
            obs, _ = env.reset()
            t, total = 0, 0.0
        if progress is not None and (k + 1) % 500 == 0:
            progress(k + 1, steps, returns.mean())
    return q
