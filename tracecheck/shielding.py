"""Pre-shielding (the paper's Fig. 3): the shield allows, the agent chooses among what it allows.

:class:`ShieldWrapper` is a ``gymnasium.Wrapper`` around the highway environment: after each
reset and step it turns the observation into the B state, asks the shield which actions are
enabled, exposes them as ``action_masks()`` (the sb3-contrib MaskablePPO convention) and
reports the decision in ``info["shield"]``. Any agent can so be shielded, in training too.
When the shield allows nothing it fails closed: the step is a deadlock and the fallback
action (SLOWER unless configured) is taken — never silently action 0.
"""

from __future__ import annotations

import gc
import time
from typing import Any, Optional, Sequence

import gymnasium as gym
import numpy as np

from .b.evaluate import MEMO_KEY
from .errors import InputError
from .highway import ACTIONS, StateAdapter
from .shield import Shield

__all__ = ["ShieldWrapper", "choose"]


def choose(values: Sequence[float], allowed: Sequence[bool],
           fallback: int) -> tuple[int, bool]:
    """The highest-valued allowed action; (fallback, True) when nothing is allowed."""
    allowed = np.asarray(allowed, dtype=bool)
    if not allowed.any():
        return fallback, True
    masked = np.where(allowed, np.asarray(values, dtype=np.float64), -np.inf)
    return int(np.argmax(masked)), False


class ShieldWrapper(gym.Wrapper):
    """Shield an environment with a B machine (see the module docstring).

    ``step(action)`` takes an allowed action as given. An action the shield does not allow is
    replaced — by the fallback if the shield allows it, else by the first allowed action —
    and ``info["shield"]["replaced"]`` says so; MaskablePPO-style agents never send one.
    """

    def __init__(self, env: gym.Env, shield: Shield, fallback: str = "SLOWER") -> None:
        super().__init__(env)
        if fallback not in ACTIONS:
            raise InputError(f"unknown fallback action {fallback!r}; the actions are "
                             f"{', '.join(ACTIONS)}")
        self.shield = shield
        self.fallback = ACTIONS.index(fallback)
        self.adapter = StateAdapter(env)
        self.state: dict[str, Any] = {}
        self.allowed = np.ones(len(ACTIONS), dtype=bool)
        self.decision_us = 0.0
        self._env = dict(shield.machine.base_env)  # kept: each decision only updates it

    def _decide(self) -> None:
        # no garbage collection inside the decision: its latency is the shield's own
        collecting = gc.isenabled()
        gc.disable()
        try:
            start = time.perf_counter()
            env = self._env
            env.pop(MEMO_KEY, None)
            env.update(self.state)
            enabled = self.shield.machine.enabled_in(env)
            self.decision_us = (time.perf_counter() - start) * 1e6
        finally:
            if collecting:
                gc.enable()
        self.allowed = np.array([a in enabled for a in ACTIONS], dtype=bool)

    def _info(self, info: dict, requested: Optional[int] = None,
              taken: Optional[int] = None) -> dict:
        info = dict(info)
        info["b_state"] = self.state
        info["shield"] = {
            "name": self.shield.name,
            "allowed": [a for a, ok in zip(ACTIONS, self.allowed) if ok],
            "deadlock": not self.allowed.any(),
            "decision_us": self.decision_us,
        }
        if taken is not None:
            info["shield"].update(requested=ACTIONS[requested], taken=ACTIONS[taken],
                                  replaced=requested != taken)
        return info

    def action_masks(self) -> np.ndarray:
        """Which actions the shield allows in the current state."""
        return self.allowed.copy()

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self.state = self.adapter.state(obs, 0.0, False, initial=True)
        self._decide()
        return obs, self._info(info)

    def step(self, action):
        requested = int(action)
        taken = requested
        if not self.allowed[requested]:
            if self.allowed[self.fallback] or not self.allowed.any():
                taken = self.fallback
            else:
                taken = int(np.flatnonzero(self.allowed)[0])
        obs, reward, terminated, truncated, info = self.env.step(taken)
        crashed = bool(info.get("crashed", False))
        self.state = self.adapter.state(obs, float(reward), crashed)
        self._decide()
        return obs, reward, terminated, truncated, self._info(info, requested, taken)
