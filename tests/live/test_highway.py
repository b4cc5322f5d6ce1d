"""The environment adapter: observations become states in the paper's conventions."""

from __future__ import annotations

import numpy as np
import pytest

from tracecheck.errors import InputError
from tracecheck.live.envs.highway import ELEMENTS, StateAdapter, env_config, make_env


@pytest.fixture(scope="module")
def env():
    e = make_env("base", 60)
    yield e
    e.close()


def test_config_keeps_episodes_60_s_long():
    config = env_config("base", 60)
    assert config["lanes_count"] == 3 and config["policy_frequency"] == 1
    assert config["duration"] > 60  # highway-env's own limit never cuts an episode short
    assert env_config("higher-penalty")["collision_reward"] == -2.0
    assert env_config("higher-penalty")["right_lane_reward"] == 0.2
    with pytest.raises(InputError, match="unknown reward profile 'fast'; the profiles are base"):
        env_config("fast")


def test_adapter_conventions(env):
    obs, _ = env.reset(seed=3)
    adapter = StateAdapter(env)
    state = adapter.state(obs, 0.0, False, initial=True)
    assert set(state) == {"Crash", "PresentVehicles", "VehiclesX", "VehiclesY", "VehiclesVx",
                          "VehiclesVy", "VehiclesAx", "VehiclesAy", "Reward"}
    ego = ELEMENTS[0]
    # ego x absolute (metres), others relative; lanes 4 m apart as in the paper's traces
    assert state["VehiclesX"].map[ego] == pytest.approx(float(obs[0, 1]) * 200.0)
    assert state["VehiclesY"].map[ego] in (0.0, pytest.approx(4.0000001192092896),
                                           pytest.approx(8.000000238418579))
    assert state["VehiclesVx"].map[ego] == pytest.approx(float(obs[0, 3]) * 80.0)
    assert all(v == 0.0 for v in state["VehiclesAx"].map.values())
    assert ego in state["PresentVehicles"] and state["Crash"] is False
    obs2, reward, *_ = env.step(3)  # FASTER
    after = adapter.state(obs2, float(reward), False)
    assert after["VehiclesAx"].map[ego] == pytest.approx(
        after["VehiclesVx"].map[ego] - state["VehiclesVx"].map[ego])
    assert after["Reward"] == pytest.approx(float(reward))


def test_same_seed_same_episode():
    a, b = make_env(), make_env()
    oa, _ = a.reset(seed=11)
    ob, _ = b.reset(seed=11)
    for action in (3, 1, 0, 4, 2, 1):
        oa, *_ = a.step(action)
        ob, *_ = b.step(action)
    assert np.array_equal(oa, ob)
