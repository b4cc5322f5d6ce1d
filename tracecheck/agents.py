"""Agents: train a DQN with the paper's settings, load one, rank its actions.

Loading a stable-baselines3 agent unpickles Python code from the file: tracecheck only
loads agent files from paths the user gives. Only load files you trust.
"""

from __future__ import annotations

import hashlib
import json
import platform
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

import numpy as np

from .errors import InputError
from .highway import ACTIONS, ENV_ID, env_config, make_env

__all__ = ["Agent", "load_agent", "train", "PAPER_DQN", "file_sha256"]

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
        """One value per action (Q-values for DQN, probabilities for policy methods)."""
        import torch

        with torch.no_grad():
            tensor, _ = self.model.policy.obs_to_tensor(np.asarray(obs, dtype=np.float32))
            if self.algorithm == "DQN":
                return self.model.q_net(tensor)[0].cpu().numpy().astype(np.float64)
            dist = self.model.policy.get_distribution(tensor)
            return dist.distribution.probs[0].cpu().numpy().astype(np.float64)


def load_agent(path: str | Path) -> Agent:
    """Load a stable-baselines3 agent (DQN, or PPO/A2C) with 5 discrete actions.

    This unpickles code from the file: load only files you trust.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such agent file: {path}")
    if not zipfile.is_zipfile(path):
        raise InputError(f"{path} is not a stable-baselines3 agent (not a zip archive)")
    import stable_baselines3 as sb3

    last: Optional[Exception] = None
    for name in ("DQN", "PPO", "A2C"):
        try:
            model = getattr(sb3, name).load(path, device="cpu")
        except Exception as exc:  # noqa: BLE001 - try the next algorithm
            last = exc
            continue
        space = model.action_space
        if getattr(space, "n", None) != len(ACTIONS):
            raise InputError(f"{path}: the agent has action space {space}; tracecheck needs "
                             f"{len(ACTIONS)} discrete actions ({', '.join(ACTIONS)})")
        shape = getattr(model.observation_space, "shape", None)
        if shape != (5, 5):
            raise InputError(f"{path}: the agent observes shape {shape}; the highway "
                             "Kinematics observation is (5, 5)")
        return Agent(str(path), file_sha256(path), name, model)
    raise InputError(f"{path} is not a stable-baselines3 DQN, PPO or A2C agent ({last})")


def train(profile: str, out: str | Path, *, steps: int = 20_000, seed: int = 0,
          duration: int = 60, progress: Optional[Any] = None) -> dict[str, Any]:
    """Train a DQN with the paper's settings on a reward profile; save it and its card.

    ``progress`` is called with (steps done, total) as training goes. Returns the model card
    (also written next to the agent as ``NAME.json``).
    """
    import stable_baselines3 as sb3
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    out = Path(out)
    env_config(profile, duration)  # validates the profile
    if out.is_dir():
        raise InputError(f"the output {out} is a folder; give a file name such as agent.zip")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.with_suffix(".probe").write_bytes(b"")
        out.with_suffix(".probe").unlink()
    except OSError as exc:
        raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    torch.set_num_threads(1)
    env = make_env(profile, duration)
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
    model.save(out)
    path = out if out.suffix == ".zip" else out.with_suffix(out.suffix + ".zip")
    import gymnasium
    import highway_env
    import stable_baselines3

    card = {
        "agent": path.name, "algorithm": "DQN", "environment": ENV_ID,
        "environment_config": env_config(profile, duration), "reward_profile": profile,
        "seed": seed, "steps": steps, "wall_time_s": round(wall, 1),
        "settings": {**settings, "policy": "MlpPolicy"},
        "versions": {"python": platform.python_version(), "torch": torch.__version__,
                     "stable_baselines3": stable_baselines3.__version__,
                     "gymnasium": gymnasium.__version__, "highway_env": highway_env.__version__},
        "sha256": file_sha256(path),
    }
    path.with_suffix(".json").write_text(json.dumps(card, indent=2) + "\n")
    return card
