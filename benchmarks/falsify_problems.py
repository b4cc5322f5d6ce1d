"""Falsification problems whose violations are rare under uniform sampling, as environments
``tracecheck falsify`` runs (``--env benchmarks.falsify_problems:Needle`` …), for
``bench_falsify.py``. Each is deterministic given its settings; its B state carries the
quantity the STL property reads, so the robustness says how close an episode came.

* ``Needle``: settings ``a, b`` in [0, 1]; the episode violates ``G({d > R})`` where the point
  lies within ``R`` of (0.7, 0.3): a disc of area pi R^2 = 0.5 % of the square (known).
* ``Corner``: settings ``x, y, z`` in [0, 1]; violates ``G({s < 2.8})`` where x + y + z >= 2.8:
  a corner of volume 0.2^3 / 6 = 0.133 % of the cube (known).
* ``Brake``: a car follows a lead car under a shield that brakes when its stopping distance
  comes within 7.6 m of the gap; the lead brakes at a time and with a strength and duration
  the settings give (each in [0, 1]); the episode violates ``G({gap > 0.0})`` (a crash) only
  for hard, long braking at some times: about 0.5 % of the cube (the benchmark measures it
  by Monte Carlo).
"""

from __future__ import annotations

import math
from typing import Any, Optional

import gymnasium as gym
import numpy as np

from tracecheck.live.adapter import EnvAdapter

#: the needle's radius: pi R^2 = 0.005
R = math.sqrt(0.005 / math.pi)
CORNER = 2.8

#: the one-step problems' machines: their variable, and the one action always allowed
NEEDLE_MACHINE = """MACHINE Needle
VARIABLES d
INVARIANT d : REAL
INITIALISATION d := 1.0
OPERATIONS NOOP = skip
END
"""
CORNER_MACHINE = """MACHINE Corner
VARIABLES s
INVARIANT s : REAL
INITIALISATION s := 0.0
OPERATIONS NOOP = skip
END
"""

BRAKE_SHIELD = """MACHINE Follow
VARIABLES gap, speed, lead
INVARIANT gap : REAL & speed : REAL & lead : REAL
INITIALISATION gap := 30.0 || speed := 20.0 || lead := 20.0
OPERATIONS
  KEEP = SELECT (speed > lead => gap - (speed * speed - lead * lead) / 16.0 > 7.6) &
                (speed <= lead => gap > 7.6) THEN skip END;
  BRAKE = SELECT speed > 0.0 THEN skip END;
  IDLE = SELECT speed <= 0.0 THEN skip END
END
"""


class _OneShot(gym.Env):
    """One step; the state is computed from the settings."""

    def __init__(self, render_mode: Optional[str] = None, **settings: float) -> None:
        self.observation_space = gym.spaces.Discrete(1)
        self.action_space = gym.spaces.Discrete(1)
        self.settings = settings

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        return 0, {"value": self.value()}

    def step(self, action):
        return 0, 0.0, True, False, {"value": self.value()}

    def value(self) -> float:
        raise NotImplementedError


class NeedleEnv(_OneShot):
    def value(self) -> float:
        return math.hypot(self.settings["a"] - 0.7, self.settings["b"] - 0.3)


class CornerEnv(_OneShot):
    def value(self) -> float:
        return self.settings["x"] + self.settings["y"] + self.settings["z"]


class _Static(EnvAdapter):
    actions = ("NOOP",)
    horizon = 2
    variable = ""

    @property
    def variables(self):  # type: ignore[override]
        return (self.variable,)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {self.variable: float(info["value"])}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return False


class Needle(_Static):
    name = "needle"
    variable = "d"
    model_name = "Needle"

    def default_config(self) -> dict[str, Any]:
        return {"a": 0.0, "b": 0.0}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return NeedleEnv(render_mode, **config)


class Corner(_Static):
    name = "corner"
    variable = "s"
    model_name = "Corner"

    def default_config(self) -> dict[str, Any]:
        return {"x": 0.0, "y": 0.0, "z": 0.0}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return CornerEnv(render_mode, **config)


class BrakeEnv(gym.Env):
    """0.5 s steps: the lead car (at 20 m/s, 30 m ahead) brakes from step 1 + 30 t for
    1 + 19 u steps at 10 k^3 m/s^2; the ego car keeps its speed (KEEP), brakes at 8 m/s^2
    (BRAKE) or stands (IDLE). The shield keeps the ego car's stopping distance, less the
    lead's at its present speed, 7.6 m short of the gap — which the lead's own braking, harder
    than the ego car's, can beat."""

    STEPS = 60

    def __init__(self, render_mode: Optional[str] = None, t: float = 0.0, k: float = 0.0,
                 u: float = 0.0) -> None:
        self.observation_space = gym.spaces.Discrete(1)
        self.action_space = gym.spaces.Discrete(3)
        self.start, self.decel, self.length = 1 + int(30 * t), 10.0 * k ** 3, 1 + int(19 * u)

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        self.gap, self.speed, self.lead, self.k = 30.0, 20.0, 20.0, 0
        return 0, self._info()

    def _info(self) -> dict:
        return {"gap": self.gap, "speed": self.speed, "lead": self.lead}

    def step(self, action):
        self.k += 1
        dt = 0.5
        if self.start <= self.k < self.start + self.length:
            self.lead = max(0.0, self.lead - self.decel * dt)
        if int(action) == 1:
            self.speed = max(0.0, self.speed - 8.0 * dt)
        self.gap += (self.lead - self.speed) * dt
        crashed = self.gap <= 0.0
        return 0, (-10.0 if crashed else 0.0), crashed, self.k >= self.STEPS, \
            {**self._info(), "crashed": crashed}


class Brake(EnvAdapter):
    name = "brake"
    actions = ("KEEP", "BRAKE", "IDLE")
    variables = ("gap", "speed", "lead")
    model_name = "Follow"
    horizon = BrakeEnv.STEPS

    def default_config(self) -> dict[str, Any]:
        return {"t": 0.0, "k": 0.0, "u": 0.0}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return BrakeEnv(render_mode, **config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"gap": float(info["gap"]), "speed": float(info["speed"]),
                "lead": float(info["lead"])}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(info.get("crashed"))


def agent_table(path, actions: int) -> str:
    """A Q-table for one observation: the first action best, then the next …"""
    np.save(path, np.array([[float(actions - i) for i in range(actions)]]))
    return str(path)
