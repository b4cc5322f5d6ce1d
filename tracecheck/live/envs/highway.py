"""The highway environment of the paper's case study, its observations as B states, and its
adapter (:class:`HighwayAdapter`, the default environment).

``highway-fast-v0`` with three lanes, the policy at 1 Hz and the default Kinematics
observation (5 vehicles: presence, x, y, vx, vy, normalised to [-1, 1]). An episode lasts
up to 60 agent steps (60 s) and ends early at a crash; highway-env's own time limit is set
past that so it never cuts an episode short.

:class:`StateAdapter` turns observations into states in the paper's vocabulary with the
conventions of its traces: metres and m/s (de-normalised with the feature ranges), ego x
absolute and the other vehicles relative to the ego, accelerations the change of velocity
over the last second (0 in the initial state), ``Crash`` the environment's crash flag,
``Reward`` the step reward, ``PresentVehicles`` from the presence feature, elements
``EgoVehicle``, ``Vehicles2`` … ``Vehicles5``.
"""

from __future__ import annotations

import functools
from types import MappingProxyType
from typing import Any, Mapping, Optional

import numpy as np

from ...b.values import Elem, FuncValue, format_value
from ...checking.shield import SHIELD_DIR
from ...episodes.vocabulary import Vocabulary
from ...errors import InputError
from ..adapter import EnvAdapter, Observer
from ..settings import setting_kinds
from .highway_properties import HIGHWAY_TOML
from .highway_scene import road_plots, road_scene

__all__ = ["ENV_ID", "REWARD_PROFILES", "env_config", "make_env", "StateAdapter", "ACTIONS",
           "ELEMENTS", "HighwayAdapter", "road_reading", "HIGHWAY", "PAPER_DQN"]

ENV_ID = "highway-fast-v0"
#: The state variables of the paper's highway model (Section 4.1).
VARIABLES = ("Crash", "PresentVehicles", "VehiclesX", "VehiclesY", "VehiclesVx", "VehiclesVy",
             "VehiclesAx", "VehiclesAy", "Reward")
#: The agent's actions, in highway-env's DiscreteMetaAction order: 0 = LANE_LEFT, …
ACTIONS = ("LANE_LEFT", "IDLE", "LANE_RIGHT", "FASTER", "SLOWER")
#: The paper's vocabulary, which ProB's and SimB's traces of the paper use.
HIGHWAY = Vocabulary(VARIABLES, ACTIONS, "HighwayEnvironment", "Vehicles")
ELEMENTS = tuple(Elem(n) for n in ("EgoVehicle", "Vehicles2", "Vehicles3", "Vehicles4",
                                   "Vehicles5"))
#: Reward settings: highway-env's defaults, and the paper's HIGHER PENALTY agent (§4.2).
REWARD_PROFILES: dict[str, dict[str, float]] = {
    "base": {},
    "higher-penalty": {"collision_reward": -2.0, "right_lane_reward": 0.2},
}


def env_config(profile: str = "base", duration: int = 60) -> dict[str, Any]:
    """The environment configuration for a reward profile and an episode length (s)."""
    if profile not in REWARD_PROFILES:
        raise InputError(f"unknown reward profile {profile!r}; the profiles are "
                         f"{', '.join(REWARD_PROFILES)}")
    return {"lanes_count": 3, "policy_frequency": 1, "duration": duration + 1,
            "observation": {"type": "Kinematics"}, **REWARD_PROFILES[profile]}


def make_env(profile: str = "base", duration: int = 60, render_mode: Optional[str] = None):
    """A configured ``highway-fast-v0`` environment."""
    import gymnasium as gym
    import highway_env  # noqa: F401 - registers the environments

    return gym.make(ENV_ID, config=env_config(profile, duration), render_mode=render_mode)


class StateAdapter:
    """Observations to B states (see the module docstring)."""

    def __init__(self, env) -> None:
        obs_type = env.unwrapped.observation_type
        self.features = list(obs_type.features)
        missing = {"presence", "x", "y", "vx", "vy"} - set(self.features)
        if missing:
            raise InputError(f"the observation lacks the features {sorted(missing)}")
        self.scale = {f: (max(abs(lo), abs(hi)) if obs_type.normalize else 1.0)
                      for f, (lo, hi) in obs_type.features_range.items()}
        self.index = {f: i for i, f in enumerate(self.features)}
        self._last: Optional[tuple[np.ndarray, np.ndarray]] = None

    def _column(self, obs: np.ndarray, feature: str) -> np.ndarray:
        return obs[:, self.index[feature]].astype(np.float64) * self.scale.get(feature, 1.0)

    def state(self, obs: np.ndarray, reward: float, crashed: bool,
              initial: bool = False) -> dict[str, Any]:
        obs = np.asarray(obs)
        if obs.shape[0] != len(ELEMENTS):
            raise InputError(f"the observation has {obs.shape[0]} vehicles, the paper's "
                             f"vocabulary {len(ELEMENTS)}")
        vx, vy = self._column(obs, "vx"), self._column(obs, "vy")
        if initial or self._last is None:
            ax, ay = np.zeros_like(vx), np.zeros_like(vy)
        else:
            ax, ay = vx - self._last[0], vy - self._last[1]
        self._last = (vx, vy)
        present = obs[:, self.index["presence"]] > 0.5

        def fn(values: np.ndarray) -> FuncValue:
            return FuncValue({e: float(v) for e, v in zip(ELEMENTS, values)})

        return {
            "Crash": bool(crashed),
            "PresentVehicles": frozenset(e for e, p in zip(ELEMENTS, present) if p)
            | {ELEMENTS[0]},
            "VehiclesX": fn(self._column(obs, "x")), "VehiclesY": fn(self._column(obs, "y")),
            "VehiclesVx": fn(vx), "VehiclesVy": fn(vy), "VehiclesAx": fn(ax),
            "VehiclesAy": fn(ay), "Reward": float(reward),
        }


def _highway_defaults() -> Optional[Mapping[str, Any]]:
    """highway-env's default configuration, read-only (None: highway-env is not installed)."""
    try:
        return _highway_default_config()
    except Exception:  # noqa: BLE001 - not installed: make_env says so
        return None


@functools.cache
def _highway_default_config() -> Mapping[str, Any]:
    """highway-env's default configuration, remembered once read (a failure is not: it
    raises, and the next call tries again)."""
    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    import highway_env  # noqa: F401 - registers the environments

    return MappingProxyType(load_env_creator(gym.spec(ENV_ID).entry_point).default_config())


class _HighwayObserver(Observer):
    def __init__(self, adapter, env) -> None:
        super().__init__(adapter, env)
        self.inner = StateAdapter(env)  # remembers the last velocities (accelerations)

    def state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        return self.inner.state(obs, reward, bool(info.get("crashed", False)), initial=initial)


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


class HighwayAdapter(EnvAdapter):
    name = "highway"
    description = ("highway-env's highway-fast-v0: three lanes, five vehicles observed, the "
                   "paper's case study")
    env_id = ENV_ID
    actions = ACTIONS
    variables = VARIABLES
    model_name = HIGHWAY.name
    set_name = HIGHWAY.set_name
    default_shield = "paper"
    fallback = "SLOWER"
    seconds_per_step = 1.0
    horizon = 60
    requires = ("gymnasium", "highway_env")
    profiles = REWARD_PROFILES
    shields = {name: SHIELD_DIR / f"{name}.mch" for name in ("none", "paper", "strict")}
    property_sets = {"highway": HIGHWAY_TOML}
    properties = "highway"
    observation_shape = (5, 5)  # the Kinematics observation: 5 vehicles, 5 features
    plotted = ("speed", "nearest_gap")
    reset_parameters = {
        "other_speed": "every other vehicle's initial speed (and the speed it keeps to), m/s; "
                       "highway-env draws each from 21-24 m/s"}

    def default_config(self) -> dict[str, Any]:
        return env_config("base", self.horizon)

    def config(self, overrides: Optional[dict[str, Any]] = None,
               profile: Optional[str] = None, horizon: Optional[int] = None) -> dict[str, Any]:
        """highway-env's configuration: the reward profile, and ``duration`` one past the
        horizon so that highway-env's own time limit never cuts an episode short."""
        overrides = self.check_config(overrides)
        config = env_config(profile or "base", horizon or self.horizon)
        config.update(overrides or {})
        return config

    def config_keys(self):
        """highway-env's own configuration keys (it ignores others without a word)."""
        defaults = _highway_defaults()
        return None if defaults is None else frozenset(defaults)

    def config_kinds(self):
        """What each of highway-env's keys takes, from the type of its default."""
        return {k: setting_kinds(v) for k, v in (_highway_defaults() or {}).items()}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        import gymnasium as gym
        import highway_env  # noqa: F401 - registers the environments

        return gym.make(ENV_ID, config=config, render_mode=render_mode)

    def reset(self, env, seed: Optional[int], options: Optional[dict[str, Any]] = None):
        """highway-env's reset (with the options it takes itself, e.g. ``config``);
        ``options["other_speed"]`` then sets every other vehicle's
        speed and target speed (where highway-env placed them: their spacing stays the one
        of the speeds it drew), and the observation is taken again."""
        options = dict(options or {})
        speed = options.pop("other_speed", None)
        obs, info = env.reset(seed=seed, options=options or None)  # highway-env's own
        if speed is None:
            return obs, info
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or \
                not 0.0 <= float(speed) <= 100.0:
            raise InputError(f"other_speed={speed!r}: give a speed from 0 to 100 m/s")
        inner = env.unwrapped
        for vehicle in inner.road.vehicles:
            if vehicle not in inner.controlled_vehicles:
                vehicle.speed = float(speed)
                if hasattr(vehicle, "target_speed"):
                    vehicle.target_speed = float(speed)
        return inner.observation_type.observe(), info

    def observer(self, env) -> Observer:
        return _HighwayObserver(self, env)

    def describe(self, state: dict[str, Any]) -> Optional[str]:
        return road_reading(state)

    def scene(self, step, shield: Optional[str] = None):
        """The road around the ego vehicle; for the ``paper`` shield, the zones it tests."""
        if not all(isinstance(step.state.get(v), FuncValue) for v in VARIABLES[2:6]):
            return None
        return road_scene(step.state, bool(step.crashed), zones=shield == "paper")

    def plots(self, state: dict[str, Any]) -> dict[str, float]:
        """The ego vehicle's speed (m/s) and the distance to the nearest other vehicle (m)."""
        return road_plots(state)

    def training_settings(self, algorithm: str, steps: int) -> dict[str, Any]:
        """The paper's DQN settings (§4.2; exploration over the first 6000 of 20 000 steps),
        and a discount of 0.8 for the other algorithms."""
        if algorithm == "dqn":
            return dict(PAPER_DQN, exploration_fraction=min(1.0, 6000 / steps))
        return {"gamma": 0.8}

    def claims(self, variables) -> bool:
        """A run in the paper's vocabulary is the highway's (its ProB and SimB traces)."""
        return set(VARIABLES) <= set(variables)


def road_reading(state: dict[str, Any]) -> Optional[str]:
    """A state on the road in one line: each present vehicle's position and speed (by
    name), then the values of the variables that are neither functions nor sets; None for a
    state without positions.

    >>> road_reading({"Crash": False, "PresentVehicles": frozenset({ELEMENTS[0]}),
    ...               "VehiclesX": FuncValue({ELEMENTS[0]: 0.0}),
    ...               "VehiclesY": FuncValue({ELEMENTS[0]: 4.0})})
    'EgoVehicle at x = 0, y = 4 (Crash = FALSE)'
    """
    x, y = state.get("VehiclesX"), state.get("VehiclesY")
    present = state.get("PresentVehicles")
    if not (isinstance(x, FuncValue) and isinstance(y, FuncValue)
            and isinstance(present, frozenset)):
        return None
    vx = state.get("VehiclesVx")
    parts = []
    for e in sorted(present, key=str):
        speed = f", vx = {_number(vx.map[e])}" if isinstance(vx, FuncValue) and \
            e in vx.map else ""
        if e in x.map and e in y.map:
            parts.append(f"{e} at x = {_number(x.map[e])}, y = {_number(y.map[e])}{speed}")
    others = [f"{k} = {format_value(v)}" for k, v in state.items()
              if not isinstance(v, (FuncValue, frozenset))]
    return "; ".join(parts or ["no vehicle present"]) + \
        (f" ({', '.join(others)})" if others else "")


def _number(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)
