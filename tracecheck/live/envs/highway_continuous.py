"""The paper's highway with continuous actions: highway-env's ``ContinuousAction`` (the
adapter ``highway-continuous``).

The same environment and state vocabulary as :mod:`tracecheck.live.envs.highway`
(``highway-fast-v0``, three lanes, 1 Hz, the paper's variables ``Crash``, ``VehiclesX`` …),
so the highway's property set, scenes and one-line readings apply unchanged. The action is
one operation, ``DRIVE(acceleration, steering)``: the two components of highway-env's action
vector in its order, in its normalised units — ``Box(-1, 1, (2,))``, mapped linearly to an
acceleration of ±5 m/s² and a steering angle of ±π/4 rad (positive: to the right, towards
larger y). Its shield is ``highway_continuous`` (models/shields/highway_continuous.mch), a
longitudinal rule in the spirit of RSS. When the shield allows nothing the ego brakes fully
and keeps its wheels straight.

``highway-fast-v0`` is the Gymnasium id of both highway adapters, so
``ShieldWrapper(gym.make("highway-fast-v0", …), shield)`` needs ``adapter=`` to say which.
"""

from __future__ import annotations

from typing import Any, Optional

from ...checking.shield import SHIELD_DIR
from .highway import HighwayAdapter, env_config

__all__ = ["ACTION_CONFIG", "HighwayContinuousAdapter", "continuous_config"]

#: highway-env's action configuration: acceleration and steering, normalised to [-1, 1]
ACTION_CONFIG = {"type": "ContinuousAction", "longitudinal": True, "lateral": True}


def continuous_config(profile: str = "base", duration: int = 60) -> dict[str, Any]:
    """The highway's configuration (:func:`~tracecheck.live.envs.highway.env_config`) with
    continuous actions."""
    return {**env_config(profile, duration), "action": dict(ACTION_CONFIG)}


class HighwayContinuousAdapter(HighwayAdapter):
    name = "highway-continuous"
    description = ("the highway with continuous actions: acceleration and steering in "
                   "[-1, 1]")
    actions = ("DRIVE",)
    parameters = {"DRIVE": ("acceleration", "steering")}
    default_shield = "highway_continuous"
    shields = {"highway_continuous": SHIELD_DIR / "highway_continuous.mch"}
    observation_shape = None  # checked against the environment (its agents are made for it)
    fallback = None
    fallback_action = (-1.0, 0.0)  # full braking (-5 m/s²), steering straight

    def default_config(self) -> dict[str, Any]:
        return continuous_config("base", self.horizon)

    def claims(self, variables) -> bool:
        """A run that names no environment is the discrete highway's, never this one's."""
        return False

    def training_settings(self, algorithm: str, steps: int) -> dict[str, Any]:
        """The algorithms' own settings (the discrete highway's are the paper's DQN's)."""
        return {}

    def config(self, overrides: Optional[dict[str, Any]] = None,
               profile: Optional[str] = None, horizon: Optional[int] = None) -> dict[str, Any]:
        """The highway's configuration (:meth:`HighwayAdapter.config`) with continuous
        actions unless the user's settings say otherwise."""
        config = super().config(overrides, profile, horizon)
        if "action" not in (overrides or {}):
            config["action"] = dict(ACTION_CONFIG)
        return config
