"""The paper's highway (``highway-fast-v0``) as an adapter; the details live in
:mod:`tracecheck.highway`."""

from __future__ import annotations

from typing import Any, Optional

from ...episodes.model import HIGHWAY
from ...highway import ACTIONS, ENV_ID, REWARD_PROFILES, StateAdapter, env_config
from ..adapter import EnvAdapter, Observer

__all__ = ["HighwayAdapter"]


class _HighwayObserver(Observer):
    def __init__(self, adapter, env) -> None:
        super().__init__(adapter, env)
        self.inner = StateAdapter(env)  # remembers the last velocities (accelerations)

    def state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        return self.inner.state(obs, reward, bool(info.get("crashed", False)), initial=initial)


class HighwayAdapter(EnvAdapter):
    name = "highway"
    env_id = ENV_ID
    actions = ACTIONS
    variables = HIGHWAY.variables
    model_name = HIGHWAY.name
    default_shield = "paper"
    fallback = "SLOWER"
    seconds_per_step = 1.0
    horizon = 60
    requires = ("gymnasium", "highway_env")
    profiles = REWARD_PROFILES
    properties = "highway"

    def default_config(self) -> dict[str, Any]:
        return env_config("base", self.horizon)

    def config(self, overrides: Optional[dict[str, Any]] = None,
               profile: Optional[str] = None, horizon: Optional[int] = None) -> dict[str, Any]:
        """highway-env's configuration: the reward profile, and ``duration`` one past the
        horizon so that highway-env's own time limit never cuts an episode short."""
        config = env_config(profile or "base", horizon or self.horizon)
        config.update(overrides or {})
        return config

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        import gymnasium as gym
        import highway_env  # noqa: F401 - registers the environments

        return gym.make(ENV_ID, config=config, render_mode=render_mode)

    def observer(self, env) -> Observer:
        return _HighwayObserver(self, env)
