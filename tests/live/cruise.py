"""A 1-D adaptive cruise control, for the tests: a user's own environment with float32
observations and a B shield in two versions.

The observation is ``[gap, ego speed, lead speed]`` as a float32 ``Box`` (as every Gymnasium
observation is); the actions are KEEP, ACCEL and BRAKE; the gap closing to 0 is a crash.
Registered with Gymnasium as ``TracecheckCruise-v0`` (a 200-step time limit), and its adapter
declares that id, so ``ShieldWrapper(gym.make("TracecheckCruise-v0"), shield)`` finds it once
it is installed (the tests install it as an entry point with :func:`install`).
"""

from __future__ import annotations

from typing import Any, Optional

import gymnasium as gym
import numpy as np

from tracecheck.live.adapter import EnvAdapter

ENV_ID = "TracecheckCruise-v0"

SHIELD_V1 = """
MACHINE ACCShield
CONSTANTS SafeGap /*@desc the smallest safe gap, in m */, MaxSpeed /*@desc top speed, m/s */
PROPERTIES SafeGap = 10.0 & MaxSpeed = 40.0
VARIABLES Gap /*@desc distance to the lead car, m */, EgoSpeed /*@desc ego speed, m/s */
INVARIANT Gap : REAL & EgoSpeed : REAL & EgoSpeed >= 0.0
INITIALISATION Gap := 50.0 || EgoSpeed := 20.0
OPERATIONS
  KEEP = SELECT Gap > SafeGap THEN skip END /*@desc keep the speed */;
  ACCEL = SELECT Gap > 2.0 * SafeGap & EgoSpeed < MaxSpeed THEN skip END /*@desc speed up */;
  BRAKE = SELECT EgoSpeed > 0.0 THEN skip END /*@desc slow down */
END
"""
#: the second version of the same machine: KEEP needs a larger gap
SHIELD_V2 = SHIELD_V1.replace("KEEP = SELECT Gap > SafeGap", "KEEP = SELECT Gap > 1.5 * SafeGap")


class CruiseEnv(gym.Env):
    """Ego car behind a lead car whose speed wanders (seeded)."""

    def __init__(self, render_mode: Optional[str] = None) -> None:
        self.observation_space = gym.spaces.Box(0.0, 200.0, shape=(3,), dtype=np.float32)
        self.action_space = gym.spaces.Discrete(3)
        self.gap, self.ego, self.lead = 30.1, 20.0, 20.0

    def _obs(self) -> np.ndarray:
        return np.array([self.gap, self.ego, self.lead], dtype=np.float32)

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        self.gap = 30.1 + float(self.np_random.uniform(0.0, 5.0))
        self.ego, self.lead = 20.0, 20.0
        return self._obs(), {}

    def step(self, action):
        self.ego = max(0.0, self.ego + (0.0, 2.0, -3.0)[int(action)])
        self.lead = max(0.0, self.lead + float(self.np_random.uniform(-2.0, 2.0)))
        self.gap = max(0.0, self.gap + self.lead - self.ego)
        crashed = self.gap <= 0.0
        return self._obs(), (-10.0 if crashed else 1.0), crashed, False, {}


class Cruise(EnvAdapter):
    name = "cruise"
    env_id = ENV_ID
    actions = ("KEEP", "ACCEL", "BRAKE")
    variables = ("Gap", "EgoSpeed")
    model_name = "ACCShield"
    horizon = 200

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return gym.make(ENV_ID, render_mode=render_mode, **config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"Gap": obs[0], "EgoSpeed": obs[1]}  # np.float32, as they come

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated)


if ENV_ID not in gym.registry:
    gym.register(ENV_ID, entry_point=CruiseEnv, max_episode_steps=200)


def install(monkeypatch) -> None:
    """Make ``cruise`` an installed adapter (an entry point of the group), for one test."""
    from importlib import metadata

    from tracecheck import registry

    points = dict(registry.entry_points())
    points["cruise"] = metadata.EntryPoint("cruise", "tests.live.cruise:Cruise",
                                           registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda: points)
