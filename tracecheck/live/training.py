"""Shielded training: the shield in the loop, for every environment with an adapter.

The environment is wrapped in :class:`~tracecheck.live.wrapper.ShieldWrapper`, whose
``action_masks()`` say which actions the shield allows in the current state.

* ``maskable-ppo`` — sb3-contrib's MaskablePPO (``pip install 'tracecheck[maskable]'``): the
  policy's distribution is restricted to the allowed actions, in rollouts and updates alike.
* ``dqn`` — stable-baselines3's DQN whose action selection is masked: exploration draws
  uniformly among the allowed actions (also before learning starts) and the greedy choice is
  the best-valued allowed action. The TD target is left as DQN has it — the maximum over
  *all* actions of the next state — because the replay buffer does not keep the next state's
  mask: the values of actions the shield blocks are still learned from, and may be
  overestimated, but never chosen. At evaluation the agent runs under the shield (pre-shielding,
  ``tracecheck record --shield``), which masks its greedy choice the same way.

In a deadlock (the shield allows nothing) the mask holds the fallback action only, which is
what the wrapper takes: training never sees an empty mask. The model card names the shield
and its sha256.
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from ..errors import InputError
from .agents import PAPER_DQN, _writable, file_sha256

__all__ = ["train_shielded", "ALGORITHMS"]

ALGORITHMS = ("maskable-ppo", "dqn")


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


def train_shielded(adapter, config: dict, shield, algorithm: str, out: str | Path, *,
                   steps: int, seed: int = 0,
                   progress: Optional[Callable[[int, int], None]] = None) -> dict[str, Any]:
    """Train ``algorithm`` on the adapter's environment under ``shield``; save the agent
    (``.zip``) and its model card (``.json`` next to it); the card."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    from .wrapper import ShieldWrapper

    if algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {algorithm!r}; shielded training takes "
                         f"{', '.join(ALGORITHMS)}")
    out = Path(out)
    if out.suffix != ".zip":
        raise InputError(f"a trained agent is saved as .zip, not {out.name}")
    _writable(out, "agent.zip")
    torch.set_num_threads(1)
    vec = DummyVecEnv([lambda: ShieldWrapper(Monitor(adapter.make_env(config)), shield,
                                             adapter=adapter)])

    class Report(BaseCallback):
        def _on_step(self) -> bool:
            if progress is not None and self.num_timesteps % 50 == 0:
                progress(self.num_timesteps, steps)
            return True

    if algorithm == "maskable-ppo":
        try:
            from sb3_contrib import MaskablePPO
        except ImportError:
            raise InputError("--algorithm maskable-ppo needs sb3-contrib",
                             hint="pip install 'tracecheck[maskable]'") from None
        n_steps = max(64, min(2048, steps))
        settings = {"n_steps": n_steps, "batch_size": 64, "learning_rate": 3e-4,
                    "gamma": 0.8 if adapter.name == "highway" else 0.99}
        model = MaskablePPO("MlpPolicy", vec, seed=seed, verbose=0, device="cpu", **settings)
        name = "MaskablePPO"
    else:
        if adapter.name == "highway":
            settings = dict(PAPER_DQN, exploration_fraction=min(1.0, 6000 / steps))
        else:
            settings = {"learning_starts": min(1000, steps // 10), "exploration_fraction": 0.5,
                        "learning_rate": 1e-3, "gamma": 0.99, "target_update_interval": 250}
        model = _masked_dqn()("MlpPolicy", vec, seed=seed, verbose=0, device="cpu", **settings)
        name = "DQN"
    start = time.perf_counter()
    model.learn(total_timesteps=steps, callback=Report())
    wall = time.perf_counter() - start
    model.save(out)
    vec.close()
    import gymnasium
    import stable_baselines3

    card = {
        "agent": out.name, "algorithm": name, "masked": True,
        "environment": adapter.name, "environment_id": adapter.env_id,
        "environment_config": config, "shield": shield.name, "shield_sha256": shield.sha256,
        "seed": seed, "steps": steps, "wall_time_s": round(wall, 1),
        "settings": {**settings, "policy": "MlpPolicy"}, "actions": list(adapter.actions),
        "versions": {"python": platform.python_version(), "torch": torch.__version__,
                     "stable_baselines3": stable_baselines3.__version__,
                     "gymnasium": gymnasium.__version__},
        "sha256": file_sha256(out),
    }
    if name == "MaskablePPO":
        import sb3_contrib

        card["versions"]["sb3_contrib"] = sb3_contrib.__version__
    for package in adapter.requires:  # the environment's own packages (highway_env, …)
        module = sys.modules.get(package)
        if getattr(module, "__version__", None):
            card["versions"][package] = module.__version__
    from ..render.jsontext import json_text
    out.with_suffix(".json").write_text(json_text(card, indent=2) + "\n")
    return card
