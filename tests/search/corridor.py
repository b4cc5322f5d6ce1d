"""A corridor with a pit, for the attribution tests: where a crash is sealed is known.

The walker starts at 0 (or where the reset option ``head_start`` says) and moves on each STEP; position 5 is a pit (a crash); EXIT ends the
episode safely; WAIT stays. The agent (a Q-table) prefers STEP, then EXIT, then WAIT, and
takes the best the shield allows. Three shields make the three kinds of failure:

* ``OPEN`` allows everything: the agent steps into the pit at step 5 although EXIT was
  allowed there — the agent's choice at step 5;
* ``ONLY_STEP`` allows STEP alone: nothing the shield allows avoids the pit — unavoidable;
* ``GAP`` allows everything but EXIT and WAIT at 4: STEP at step 4 (from 3 to 4) leads to a
  state where the shield allows only the step into the pit — a shield gap at step 4.
"""

from __future__ import annotations

from typing import Any, Optional

import gymnasium as gym
import numpy as np

from tracecheck.live.adapter import EnvAdapter

PIT = 5
STEP, EXIT, WAIT = 0, 1, 2

_MACHINE = """MACHINE Corridor
VARIABLES pos
INVARIANT pos : INTEGER
INITIALISATION pos := 0
OPERATIONS
  STEP = SELECT {step} THEN pos := pos + 1 END;
  EXIT = SELECT {other} THEN skip END;
  WAIT = SELECT {other} THEN skip END
END
"""
OPEN = _MACHINE.format(step="pos >= 0", other="pos >= 0")
ONLY_STEP = _MACHINE.format(step="pos >= 0", other="pos < 0")
GAP = _MACHINE.format(step="pos >= 0", other="pos /= 4")
#: blocks the step into the pit
GUARDED = _MACHINE.format(step="pos < 4", other="pos >= 0")


class CorridorEnv(gym.Env):
    def __init__(self, render_mode: Optional[str] = None, start: int = 0) -> None:
        self.observation_space = gym.spaces.Discrete(8)
        self.action_space = gym.spaces.Discrete(3)
        self.start, self.pos = start, start

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        start = (options or {}).get("head_start", self.start)
        if not isinstance(start, int):
            raise ValueError(f"head_start must be a whole position, not {start!r}")
        self.pos = start
        return self.pos, {}

    def step(self, action):
        if int(action) == EXIT:
            return self.pos, 1.0, True, False, {"crashed": False}
        if int(action) == STEP:
            self.pos = min(7, self.pos + 1)
        crashed = self.pos == PIT
        return self.pos, (-10.0 if crashed else 0.0), crashed, False, {"crashed": crashed}


class Corridor(EnvAdapter):
    name = "corridor"
    actions = ("STEP", "EXIT", "WAIT")
    variables = ("pos",)
    model_name = "Corridor"
    horizon = 10
    #: the environment's reset reads it (the adapter's default reset hook passes it on)
    reset_parameters = {"head_start": "where the walker starts instead of start"}

    def default_config(self) -> dict[str, Any]:
        return {"start": 0}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return gym.wrappers.TimeLimit(CorridorEnv(render_mode, **config), 20)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(obs)}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(info.get("crashed"))


def agent_file(folder) -> str:
    """The Q-table: STEP over EXIT over WAIT, in every position."""
    path = folder / "walker.npy"
    table = np.zeros((8, 3))
    table[:, STEP], table[:, EXIT], table[:, WAIT] = 1.0, 0.5, 0.0
    np.save(path, table)
    return str(path)
