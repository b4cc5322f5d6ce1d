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


class OffsetCorridorEnv(CorridorEnv):
    """The corridor with spaces that do not start at 0, as a new user's thermostat had
    (``Discrete(3, start=-1)``: cool, off, heat): the actions Left and Right are -1 and 0,
    the cells 10 … 15; any other action is refused, as a careful environment does."""

    def __init__(self, slip: bool = True, render_mode: Optional[str] = None) -> None:
        super().__init__(slip, render_mode)
        self.observation_space = gym.spaces.Discrete(6, start=10)
        self.action_space = gym.spaces.Discrete(2, start=-1)

    def reset(self, *, seed: Optional[int] = None, options=None):
        obs, info = super().reset(seed=seed, options=options)
        return obs + 10, info

    def step(self, action):
        if not self.action_space.contains(action):
            raise ValueError(f"bad action {action!r}")
        obs, reward, terminated, truncated, info = super().step(int(action) + 1)
        return obs + 10, reward, terminated, truncated, info


class OffsetCorridor(Corridor):
    name = "offsetcorridor"

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return OffsetCorridorEnv(**config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(obs) - 10}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and int(obs) == 10


LAVA_SHIELD = """
MACHINE LavaCorridor
SETS CELL = {Floor, Lava, Goal}
VARIABLES pos, ahead, behind, cells, seen
INVARIANT pos : 0..5 & ahead : CELL & behind : CELL & cells : 0..5 --> CELL & seen : POW(CELL)
INITIALISATION pos := 2 || ahead := Floor || behind := Floor || cells := (0..5) * {Floor}
  || seen := {}
OPERATIONS
  Left = SELECT behind /= Lava & cells(pos - 1) /= Lava THEN skip END;
  Right = SELECT ahead /= Lava THEN skip END
END
"""


class LavaCorridor(Corridor):
    """The corridor in the vocabulary of a user's grid world: elements given as ``str``,
    the map as a numpy array of names, a set as a Python ``set``, the position as numpy —
    converted by the machine's types (:mod:`tracecheck.b.conversion`)."""

    name = "lavacorridor"
    variables = ("pos", "ahead", "behind", "cells", "seen")
    model_name = "LavaCorridor"

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        cells = np.array(["Lava", "Floor", "Floor", "Floor", "Floor", "Goal"])
        p = int(obs)
        return {"pos": np.int64(p), "ahead": str(cells[min(p + 1, 5)]),
                "behind": cells[max(p - 1, 0)], "cells": cells, "seen": {"Floor", str(cells[p])}}


def left_leaning_table() -> np.ndarray:
    """A Q-table that prefers Left everywhere: unshielded it walks into the pit."""
    table = np.zeros((6, 2))
    table[:, 0] = 1.0
    return table


# ------------------------------------------------------------------ a continuous observation

CRUISE_SHIELD = """
MACHINE CruiseShield
VARIABLES Gap, Speed, LeadSpeed
INVARIANT Gap : REAL & Speed : REAL & LeadSpeed : REAL
INITIALISATION Gap := 30.0 || Speed := 20.0 || LeadSpeed := 20.0
OPERATIONS
  KEEP = SELECT Gap - 2.0 * (Speed - LeadSpeed) > 10.0 THEN skip END;
  ACCEL = SELECT Gap - 3.0 * (Speed - LeadSpeed) > 25.0 THEN skip END;
  BRAKE = skip
END
"""


class CruiseEnv(gym.Env):
    """1-D adaptive cruise control: the gap to a lead car that brakes now and then, the ego
    speed and the lead speed (m, m/s) as a float32 Box; a crash when the gap closes."""

    def __init__(self, render_mode: Optional[str] = None) -> None:
        self.observation_space = gym.spaces.Box(0.0, 200.0, (3,), np.float32)
        self.action_space = gym.spaces.Discrete(3)
        self.obs = np.zeros(3, np.float32)

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        self.obs = np.array([30.0 + self.np_random.uniform(0, 5), 20.0, 20.0], np.float32)
        return self.obs.copy(), {}

    def step(self, action):
        gap, speed, lead = (float(v) for v in self.obs)
        speed = max(0.0, speed + (0.0, 1.5, -3.0)[int(action)])
        lead = max(0.0, lead + float(self.np_random.uniform(-2.0, 1.0)))
        gap = gap + lead - speed
        self.obs = np.array([max(gap, 0.0), speed, lead], np.float32)
        crashed = gap <= 0.0
        return self.obs.copy(), -1.0 if crashed else speed / 30.0, crashed, False, \
            {"crashed": crashed}


class Cruise(EnvAdapter):
    name = "cruise"
    env_id = "Cruise-v0"
    actions = ("KEEP", "ACCEL", "BRAKE")
    variables = ("Gap", "Speed", "LeadSpeed")
    model_name = "CruiseShield"
    horizon = 40

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return CruiseEnv(**config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        gap, speed, lead = (float(v) for v in obs)
        return {"Gap": gap, "Speed": speed, "LeadSpeed": lead}

    def scene(self, step):
        """The two cars on a road, drawn through the adapter's scene hook."""
        from tracecheck.live.scene import Box, Line, Scene, Text

        gap = step.state["Gap"]
        ego = (0.85, 0.2, 0.2, 1.0) if step.crashed else (0.16, 0.4, 0.9, 1.0)
        return Scene(shapes=(
            Line(((-10.0, 1.5), (80.0, 1.5)), (0.6, 0.6, 0.6, 1.0), 0.2, group="road"),
            Box(-2.0, 0.0, 4.0, 2.0, fill=ego, label=f"ego, {step.state['Speed']:.1f} m/s",
                group="ego"),
            Box(gap + 2.0, 0.0, 4.0, 2.0, fill=(0.55, 0.55, 0.55, 1.0),
                label=f"lead, {step.state['LeadSpeed']:.1f} m/s", group="lead"),
            Text(gap / 2, -2.2, f"gap {gap:.1f} m", 1.6, group="gap")),
            view=(-10.0, -5.0, 90.0, 8.0), caption="The ego car (blue, red once crashed) "
            "behind the lead car (grey), 4 m long each; the label is the gap between them.")


# ------------------------------------------------------------------ an image observation

class _ViewedCorridorEnv(CorridorEnv):
    """The corridor whose observation is :meth:`view` of the agent's cell."""

    def view(self) -> np.ndarray:
        raise NotImplementedError

    def reset(self, *, seed: Optional[int] = None, options=None):
        super().reset(seed=seed)
        return self.view(), {}

    def step(self, action):
        _, reward, terminated, truncated, info = super().step(action)
        return self.view(), reward, terminated, truncated, info


class ImageCorridorEnv(_ViewedCorridorEnv):
    """The corridor seen as a 7×7 RGB picture (channel last, as MiniGrid's ``ImgObsWrapper``
    gives): the agent's cell lit on the middle row."""

    def __init__(self, slip: bool = True, render_mode: Optional[str] = None) -> None:
        super().__init__(slip, render_mode)
        self.observation_space = gym.spaces.Box(0, 255, (7, 7, 3), np.uint8)

    def view(self) -> np.ndarray:
        picture = np.zeros((7, 7, 3), np.uint8)
        picture[3, self.pos, :] = 255
        return picture


class ImageCorridor(Corridor):
    name = "imagecorridor"
    observation_shape = (7, 7, 3)

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return ImageCorridorEnv(**config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(env.unwrapped.pos)}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and reward == 0.0


# ------------------------------------------------------------------ a NaN observation

class NanCruise(Cruise):
    """The cruise control whose sensor fails at step 3: the gap becomes NaN."""

    name = "nancruise"

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        env = CruiseEnv()
        step, count = env.step, [0]

        def failing(action):
            count[0] += 1
            obs, *rest = step(action)
            if count[0] == 3:
                obs = obs.copy()
                obs[0] = np.nan
            return (obs, *rest)
        env.step = failing
        return env


class ByteCorridorEnv(_ViewedCorridorEnv):
    """The corridor whose observation space says uint8 while it gives floats in [0, 1]."""

    def __init__(self, slip: bool = True, render_mode: Optional[str] = None) -> None:
        super().__init__(slip, render_mode)
        self.observation_space = gym.spaces.Box(0, 255, (2,), np.uint8)

    def view(self) -> np.ndarray:
        return np.array([self.pos / 5, 0.5])


class ByteCorridor(Corridor):
    name = "bytecorridor"

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return ByteCorridorEnv(**config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(env.unwrapped.pos)}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and reward == 0.0


class _PlainWrapper(gym.ObservationWrapper):
    """A wrapper that does not record its arguments (as MiniGrid's ImgObsWrapper)."""

    def observation(self, observation):
        return observation


class WrappedCorridor(Corridor):
    name = "wrappedcorridor"

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        gym.register("TracecheckCorridor-v0", entry_point=CorridorEnv,
                     disable_env_checker=True) if "TracecheckCorridor-v0" not in gym.registry \
            else None
        return _PlainWrapper(gym.make("TracecheckCorridor-v0", **config))


class HiddenCorridor(Corridor):
    """The corridor whose states the adapter reads from the environment, not the
    observation (as LunarLander's terrain, or a grid world's map)."""

    name = "hiddencorridor"

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(env.unwrapped.pos)}


class DictCorridorEnv(_ViewedCorridorEnv):
    """The corridor observed as a ``Dict``: the cell (``Discrete``) and two lamps (``Box``),
    as a robot's several sensors are."""

    def __init__(self, slip: bool = True, render_mode: Optional[str] = None) -> None:
        super().__init__(slip, render_mode)
        self.observation_space = gym.spaces.Dict({
            "cell": gym.spaces.Discrete(6),
            "lamps": gym.spaces.Box(0.0, 1.0, (2,), np.float32)})

    def view(self) -> dict:
        return {"cell": self.pos, "lamps": np.array([self.pos / 5, 0.5], np.float32)}


class DictCorridor(Corridor):
    name = "dictcorridor"

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return DictCorridorEnv(**config)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return {"pos": int(obs["cell"])}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and int(obs["cell"]) == 0


class _BrokenCorridorEnv(CorridorEnv):
    def reset(self, *, seed: Optional[int] = None, options=None):
        raise RuntimeError("lidar not connected")


class BrokenCorridor(Corridor):
    """The corridor whose environment cannot reset (a sensor that is not there)."""

    name = "brokencorridor"

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        return _BrokenCorridorEnv(**config)
