"""Agents: train a DQN with the paper's settings, load one, rank its actions.

Two kinds of agent file: a stable-baselines3 model (``.zip``: DQN, PPO or A2C, or
sb3-contrib's MaskablePPO, for any environment whose spaces match it) and a tabular
Q-learning agent (``.npy``: a table of one row per discrete observation and one column per
action, read with ``allow_pickle=False``).
Loading a stable-baselines3 agent unpickles Python code from the file: tracecheck only
loads agent files from paths the user gives. Only load files you trust; a ``.npy`` table
runs no code.
"""

from __future__ import annotations

import hashlib
import platform
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from ..errors import InputError
from .envs.highway import ENV_ID, env_config

__all__ = ["Agent", "load_agent", "train", "train_q_table", "PAPER_DQN", "Q_LEARNING",
           "file_sha256"]

#: The paper's DQN settings (§4.2), for stable-baselines3.
PAPER_DQN: dict[str, Any] = {
    "policy_kwargs": {"net_arch": [256, 256]},
    "learning_rate": 5e-4,
    "gamma": 0.9,
    "buffer_size": 15_000,
    "batch_size": 32,
    "learning_starts": 200,
    "train_freq": 1,
    "gradient_steps": 1,
    "target_update_interval": 50,
    "exploration_initial_eps": 1.0,
    "exploration_final_eps": 0.05,
}


#: Tabular Q-learning: step size, discount, and epsilon-greedy exploration falling linearly
#: from 1 to its floor over the first 80 % of the steps.
Q_LEARNING: dict[str, float] = {"alpha": 0.1, "gamma": 0.99, "epsilon_floor": 0.05,
                                "decay_fraction": 0.8}


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass
class Agent:
    """A loaded agent: its action values for an observation, best first."""

    path: str
    sha256: str
    algorithm: str
    model: Any

    @property
    def id(self) -> str:
        return Path(self.path).stem

    def values(self, obs: np.ndarray) -> np.ndarray:
        """One value per action (Q-values for DQN and Q-tables, probabilities for policy
        methods)."""
        if self.algorithm == "q-learning":
            return self.model[int(obs)].astype(np.float64)
        import torch

        with torch.no_grad():
            tensor, _ = self.model.policy.obs_to_tensor(np.asarray(obs, dtype=np.float32))
            if self.algorithm == "DQN":
                return self.model.q_net(tensor)[0].cpu().numpy().astype(np.float64)
            dist = self.model.policy.get_distribution(tensor)
            return dist.distribution.probs[0].cpu().numpy().astype(np.float64)


def load_agent(path: str | Path, adapter=None, env=None) -> Agent:
    """Load an agent for an environment (its adapter, and the environment to compare spaces
    with; the highway when not given): a Q-table (``.npy``) or a stable-baselines3 DQN,
    PPO or A2C with one discrete action per adapter action.

    A stable-baselines3 file unpickles code: load only files you trust.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such agent file: {path}")
    if adapter is None:
        from .adapter import get_adapter

        adapter = get_adapter("highway")
    actions = adapter.actions
    if path.suffix == ".npy":
        return _load_table(path, actions, env)
    if not zipfile.is_zipfile(path):
        raise InputError(f"{path} is not a stable-baselines3 agent (not a zip archive) nor "
                         "a Q-table (.npy)")
    import stable_baselines3 as sb3
    import torch

    torch.set_num_threads(1)

    last: Optional[Exception] = None
    for name, cls in _algorithms(sb3):
        try:
            model = cls.load(path, device="cpu")
        except Exception as exc:  # noqa: BLE001 - try the next algorithm
            last = exc
            continue
        if (name == "MaskablePPO") != type(model.policy).__name__.startswith("Maskable"):
            continue  # a plain PPO file loads as MaskablePPO too (and the other way round)
        space = model.action_space
        if getattr(space, "n", None) != len(actions):
            raise InputError(f"{path}: the agent has action space {space}; {adapter.name} "
                             f"has {len(actions)} discrete actions ({', '.join(actions)})")
        _check_observations(path, model.observation_space, adapter, env)
        return Agent(str(path), file_sha256(path), name, model)
    raise InputError(f"{path} is not a stable-baselines3 DQN, PPO or A2C agent nor an "
                     f"sb3-contrib MaskablePPO one ({last})")


def _algorithms(sb3):
    """The algorithms an agent file may hold: stable-baselines3's, and MaskablePPO when
    sb3-contrib is installed."""
    found = [("DQN", sb3.DQN)]
    try:
        from sb3_contrib import MaskablePPO

        found.append(("MaskablePPO", MaskablePPO))
    except ImportError:
        pass
    return found + [("PPO", sb3.PPO), ("A2C", sb3.A2C)]


def _check_observations(path: Path, space, adapter, env) -> None:
    """The agent's observation space must be the environment's."""
    if env is None:
        if adapter.name == "highway" and getattr(space, "shape", None) != (5, 5):
            raise InputError(f"{path}: the agent observes shape {space.shape}; the highway "
                             "Kinematics observation is (5, 5)")
        return
    theirs = env.observation_space
    if type(space) is not type(theirs) or getattr(space, "shape", None) != getattr(
            theirs, "shape", None) or getattr(space, "n", None) != getattr(theirs, "n", None):
        raise InputError(f"{path}: the agent observes {space}, but {adapter.name} gives "
                         f"{theirs}")


def _load_table(path: Path, actions: tuple[str, ...], env) -> Agent:
    try:
        table = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise InputError(f"{path} is not a Q-table (.npy of numbers): {exc}") from None
    if table.ndim != 2 or table.dtype.kind not in "fiu":
        raise InputError(f"{path}: a Q-table is a 2-D array of numbers (observations × "
                         f"actions), not {table.dtype} of shape {table.shape}")
    if table.shape[1] != len(actions):
        raise InputError(f"{path}: the Q-table has {table.shape[1]} actions; the environment "
                         f"has {len(actions)} ({', '.join(actions)})")
    if not np.all(np.isfinite(table)):
        raise InputError(f"{path}: the Q-table holds NaN or infinite values")
    n = getattr(getattr(env, "observation_space", None), "n", None)
    if env is not None and n != table.shape[0]:
        raise InputError(f"{path}: the Q-table has {table.shape[0]} rows; the environment "
                         f"has {n if n is not None else 'no discrete'} observations")
    return Agent(str(path), file_sha256(path), "q-learning", table.astype(np.float64))


def train(profile: str, out: str | Path, *, steps: int = 20_000, seed: int = 0,
          duration: int = 60, progress: Optional[Any] = None, force: bool = False,
          inputs: Sequence[Path] = (), config: Optional[dict[str, Any]] = None) -> dict[str, Any]:
    """Train a DQN with the paper's settings on a reward profile; save it and its card.

    ``progress`` is called with (steps done, total) as training goes; ``config`` is the
    environment's whole configuration (default: the profile's for ``duration``). Returns the
    model card (also written next to the agent as ``NAME.json``). Both files follow the
    output rule (see :func:`agent_outputs`).
    """
    import stable_baselines3 as sb3
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    import gymnasium as gym
    import highway_env  # noqa: F401 - registers the environments

    out = Path(out)
    config = env_config(profile, duration) if config is None else config  # checks the profile
    path = out if out.suffix == ".zip" else out.with_suffix(out.suffix + ".zip")
    path, card_path = agent_outputs(path, "agent.zip", force=force, inputs=inputs)
    torch.set_num_threads(1)
    env = gym.make(ENV_ID, config=config)
    settings = dict(PAPER_DQN, exploration_fraction=min(1.0, 6000 / steps))

    class Report(BaseCallback):
        def _on_step(self) -> bool:
            if progress is not None and self.num_timesteps % 100 == 0:
                progress(self.num_timesteps, steps)
            return True

    model = sb3.DQN("MlpPolicy", env, seed=seed, verbose=0, device="cpu", **settings)
    start = time.perf_counter()
    model.learn(total_timesteps=steps, callback=Report())
    wall = time.perf_counter() - start
    save_model(model, path)
    import stable_baselines3

    card = {
        "agent": path.name, "algorithm": "DQN", "environment": ENV_ID,
        "environment_config": config, "reward_profile": profile,
        "seed": seed, "steps": steps, "wall_time_s": round(wall, 1),
        "settings": {**settings, "policy": "MlpPolicy"},
        "versions": {"python": platform.python_version(), "torch": torch.__version__,
                     "stable_baselines3": stable_baselines3.__version__,
                     "gymnasium": gym.__version__, "highway_env": highway_env.__version__},
        "sha256": file_sha256(path),
    }
    write_card(card, card_path)
    return card


def agent_outputs(out: Path, example: str, *, force: bool = False,
                  inputs: Sequence[Path] = ()) -> tuple[Path, Path]:
    """The agent file and its model card (``NAME.json`` beside it), checked by the output
    rule (:mod:`tracecheck.outputs`) before any training: neither is one of ``inputs``, and
    existing ones are replaced only with ``force``, each once complete."""
    from ..outputs import check_output

    card = out.with_suffix(".json")
    check_output(out, inputs, force=force, example=example)
    check_output(card, inputs, force=force, what="model card")
    return out, card


def save_model(model, path: Path) -> None:
    """A stable-baselines3 model saved to ``path`` (renamed into place once complete)."""
    from ..outputs import atomic_file

    with atomic_file(path) as stream:
        model.save(stream)


def write_card(card: dict, path: Path) -> None:
    from ..outputs import write_file
    from ..render.jsontext import json_text

    write_file(path, json_text(card, indent=2) + "\n")


def train_q_table(adapter, config: dict, out: str | Path, *, steps: int = 200_000,
                  seed: int = 0, horizon: int = 100, force: bool = False,
                  inputs: Sequence[Path] = ()) -> dict[str, Any]:
    """Tabular Q-learning (see :data:`Q_LEARNING`) on an environment with discrete
    observations; saves the table as ``.npy`` and a model card next to it.

    The same seed gives the same table: exploration draws from a generator seeded with it,
    and the environment is reset with it once.
    """
    out = Path(out)
    if out.suffix != ".npy":
        raise InputError(f"a Q-table is saved as .npy, not {out.name}")
    out, card_path = agent_outputs(out, "agent.npy", force=force, inputs=inputs)
    env = adapter.make_env(config)
    n_obs = getattr(env.observation_space, "n", None)
    if n_obs is None:
        raise InputError(f"{adapter.name} has observations {env.observation_space}; Q-learning "
                         "needs a discrete observation space")
    rng = np.random.default_rng(seed)
    n_act = len(adapter.actions)
    q = np.zeros((n_obs, n_act))
    p = Q_LEARNING
    decay = max(1, int(steps * p["decay_fraction"]))
    start = time.perf_counter()
    obs, _ = env.reset(seed=seed)
    t = 0
    for k in range(steps):
        if rng.random() < max(p["epsilon_floor"], 1.0 - k / decay):
            a = int(rng.integers(n_act))
        else:
            row = q[obs]
            a = int(rng.choice(np.flatnonzero(row == row.max())))
        nxt, reward, terminated, truncated, _ = env.step(a)
        target = reward if terminated else reward + p["gamma"] * q[nxt].max()
        q[obs, a] += p["alpha"] * (target - q[obs, a])
        obs, t = nxt, t + 1
        if terminated or truncated or t >= horizon:
            obs, _ = env.reset()
            t = 0
    wall = time.perf_counter() - start
    from ..outputs import atomic_file

    with atomic_file(out) as stream:
        np.save(stream, q, allow_pickle=False)
    import gymnasium

    card = {
        "agent": out.name, "algorithm": "q-learning", "environment": adapter.name,
        "environment_id": adapter.env_id, "environment_config": config, "horizon": horizon,
        "seed": seed, "steps": steps, "wall_time_s": round(wall, 2), "settings": dict(p),
        "actions": list(adapter.actions),
        "versions": {"python": platform.python_version(), "numpy": np.__version__,
                     "gymnasium": gymnasium.__version__},
        "sha256": file_sha256(out),
    }
    write_card(card, card_path)
    return card
