"""A toy environment and its adapter, for the tests: a corridor of 6 cells, a pit in cell 0.

The agent starts in cell 2 (or, with ``slip``, wherever the seeded reset puts it: cell 1 to
4) and walks Left or Right; reaching cell 5 ends the episode with reward 1, stepping into
cell 0 ends it as a crash. Recorded and replayed through ``--env tests.live.toy:Corridor``,
as a user's own environment would be.
"""

from __future__ import annotations

from typing import Any, Optional

import gymnasium as gym
import numpy as np

from tracecheck.live.adapter import EnvAdapter

SHIELD = """
MACHINE CorridorShield
VARIABLES pos
INVARIANT pos : 0..5
INITIALISATION pos := 2
OPERATIONS
  Left = SELECT pos > 1 THEN pos := pos - 1 END;
  Right = SELECT pos < 5 THEN pos := pos + 1 END
END
"""


class CorridorEnv(gym.Env):
    def __init__(self, slip: bool = True, render_mode: Optional[str] = None) -> None:
        self.observation_space = gym.spaces.Discrete(6)
        self.action_space = gym.spaces.Discrete(2)
        self.slip = slip
        self.pos = 2

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        self.pos = int(self.np_random.integers(1, 5)) if self.slip else 2
        return self.pos, {}

    def step(self, action):
        self.pos += -1 if int(action) == 0 else 1
        if self.pos <= 0:
            return 0, 0.0, True, False, {}
        if self.pos >= 5:
            return 5, 1.0, True, False, {}
        return self.pos, 0.0, False, False, {}


class Corridor(EnvAdapter):
    name = "corridor"
    env_id = "Corridor-v0"
    actions = ("Left", "Right")
    variables = ("pos",)
    model_name = "CorridorShield"
    horizon = 20

    def default_config(self) -> dict[str, Any]:
        return {"slip": True}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return CorridorEnv(**config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(obs)}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and int(obs) == 0


def left_leaning_table() -> np.ndarray:
    """A Q-table that prefers Left everywhere: unshielded it walks into the pit."""
    table = np.zeros((6, 2))
    table[:, 0] = 1.0
    return table
