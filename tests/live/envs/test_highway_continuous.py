"""The highway with continuous actions: the adapter highway-continuous and its RSS-like
shield highway_continuous, on real highway-env states and on hand-made ones."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.helpers import run
from tracecheck.b.values import Elem, FuncValue, format_value
from tracecheck.checking.shield import builtin_shields, load_shield
from tracecheck.live.envs.highway import HIGHWAY

pytest.importorskip("highway_env")

ADAPTER = "highway-continuous"  # the adapter, shield and env fixtures (conftest.py)

NAMES = ("EgoVehicle", "Vehicles2", "Vehicles3", "Vehicles4", "Vehicles5")


def road(ego_vx=20.0, ego_vy=0.0, ego_y=4.0, others=()):
    """A hand-made state: the ego at x 100 in lane y ``ego_y``; ``others`` are (x, y, vx)
    relative to it; the vehicles not given are far behind in another lane."""
    rows = [(100.0, ego_y, ego_vx, ego_vy)] + [(x, y, vx, 0.0) for x, y, vx in others]
    rows += [(-150.0, -8.0, 0.0, 0.0)] * (5 - len(rows))
    elems = [Elem(n) for n in NAMES]

    def fn(col):
        return FuncValue({e: float(r[col]) for e, r in zip(elems, rows)})
    zeros = FuncValue({e: 0.0 for e in elems})
    return {"Crash": False, "PresentVehicles": frozenset(elems[:1 + len(others)]),
            "VehiclesX": fn(0), "VehiclesY": fn(1), "VehiclesVx": fn(2), "VehiclesVy": fn(3),
            "VehiclesAx": zeros, "VehiclesAy": zeros, "Reward": 0.0}


def real_states(adapter, env, seeds=(0, 1, 2), steps=6):
    """The states of a few episodes under random Box actions (gentle steering: at 1 Hz a
    random steering angle turns the car around in one step)."""
    rng = np.random.default_rng(0)
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        observer = adapter.observer(env)
        yield observer.state(obs, info, 0.0, True)
        for _ in range(steps):
            action = rng.uniform(-1.0, 1.0, 2).astype(np.float32) * np.float32([1.0, 0.02])
            obs, reward, terminated, _, info = env.step(action)
            yield observer.state(obs, info, float(reward), False)
            if terminated:
                break


def test_the_adapter_is_the_highway_with_one_operation_of_two_parameters(adapter):
    assert adapter.name == "highway-continuous" and adapter.env_id == "highway-fast-v0"
    assert adapter.actions == ("DRIVE",)
    assert adapter.parameters == {"DRIVE": ("acceleration", "steering")}
    assert adapter.fallback is None and adapter.fallback_action == (-1.0, 0.0)
    assert adapter.default_shield == "highway_continuous" in builtin_shields()
    assert adapter.variables == HIGHWAY.variables and adapter.seconds_per_step == 1.0
    assert adapter.properties == "highway"


def test_the_configuration_asks_for_continuous_actions_whatever_else_is_set(adapter):
    assert adapter.default_config()["action"]["type"] == "ContinuousAction"
    config = adapter.config({"lanes_count": 3}, profile="higher-penalty", horizon=30)
    assert config["action"]["type"] == "ContinuousAction" and config["duration"] == 31
    assert config["collision_reward"] == -2.0


def test_the_envs_command_lists_it(capsys):
    code, out, _ = run(capsys, "envs", "--json")
    row = {r["name"]: r for r in json.loads(out)}["highway-continuous"]
    assert code == 0 and row["actions"] == ["DRIVE"]
    assert row["default_shield"] == "highway_continuous"


def test_the_shields_units_are_the_environments(env, shield):
    """The constants the shield reasons with are highway-env's: normalised actions mapped to
    ±5 m/s², one agent step of 1 s in 5 simulation sub-steps."""
    action = env.unwrapped.action_type
    assert type(action).__name__ == "ContinuousAction" and env.action_space.shape == (2,)
    assert (env.action_space.low.tolist(), env.action_space.high.tolist()) == \
        ([-1.0, -1.0], [1.0, 1.0])
    state = road()
    assert shield.evaluate("ACC_RANGE", state) == action.acceleration_range[1] \
        == -action.acceleration_range[0]
    config = env.unwrapped.config
    assert shield.evaluate("DT", state) == 1.0 / config["policy_frequency"]
    assert shield.evaluate("SUBSTEPS", state) == \
        config["simulation_frequency"] / config["policy_frequency"]
    assert shield.evaluate("STEER_RANGE", state) == pytest.approx(action.steering_range[1])
    assert action.steering_range[0] == -action.steering_range[1]


def test_real_states_fit_the_shield_and_leave_a_box_of_actions(adapter, env, shield):
    count = 0
    for state in real_states(adapter, env):
        shield.check_state(state)
        assert shield.invariant(state)
        allowed = shield.allowed("DRIVE", state)
        assert allowed.params == ("acceleration", "steering") and allowed.separable
        point = allowed.witness()
        assert point is not None and allowed.contains(point), str(allowed)
        assert shield.is_enabled("DRIVE", state)
        nearest = allowed.nearest({"acceleration": 1.0, "steering": 0.0})
        assert nearest is not None and allowed.contains(nearest)
        count += 1
    assert count >= 10


def test_no_vehicle_ahead_leaves_the_bounds_and_the_steering_limit(shield):
    allowed = shield.allowed("DRIVE", road(ego_vx=20.0, others=[(-30.0, 0.0, 0.0)]))
    assert _acceleration_range(allowed) == (-1.0, 1.0)
    # |steering| · 20 m/s · 1 s <= 0.15 rad · 5 m: |steering| <= 0.0375
    assert _steering_range(allowed, 1.0) == (pytest.approx(-0.0375), pytest.approx(0.0375))
    assert allowed.contains({"acceleration": 1.0, "steering": 0.037})
    assert not allowed.contains({"acceleration": 0.0, "steering": 0.038})


def test_the_allowed_acceleration_behind_a_vehicle_is_the_hand_computed_one(shield):
    """Ego at 20 m/s, a vehicle as fast 50 m ahead (centres) in its lane. Where the front
    one stops at the latest: 50 - 5 + 20² / (2 · 6) = 78.33 m. The ego accelerating at u
    m/s² for 1 s and then braking at 5 m/s² reaches at most 20 + u/2 + 0.5 + (400 + 40 u +
    25) / 10 + (20 + u) / 10 = 65 + 4.6 u m; with the 1 m margin, u <= (78.33 - 66) / 4.6,
    so acceleration (u / 5) <= 0.5362."""
    state = road(ego_vx=20.0, others=[(50.0, 0.0, 0.0)])
    assert shield.evaluate("FRONT_STOP", state) == pytest.approx(45.0 + 400.0 / 12.0)
    bound = (45.0 + 400.0 / 12.0 - 66.0) / 4.6 / 5.0
    allowed = shield.allowed("DRIVE", state)
    assert _acceleration_range(allowed) == (-1.0, pytest.approx(bound, rel=1e-12))
    assert allowed.contains({"acceleration": bound - 1e-9, "steering": 0.0})
    assert not allowed.contains({"acceleration": bound + 1e-9, "steering": 0.0})
    nearest = allowed.nearest({"acceleration": 1.0, "steering": 1.0})
    assert nearest == {"acceleration": pytest.approx(bound), "steering": 0.0375}


def test_a_slow_vehicle_close_ahead_leaves_only_full_braking(shield):
    """Ego at 25 m/s, a vehicle at 10 m/s 12 m ahead: no acceleration keeps the RSS
    distance; the proper response, full braking, is all that is left."""
    state = road(ego_vx=25.0, others=[(12.0, 0.5, -15.0)])
    allowed = shield.allowed("DRIVE", state)
    assert _acceleration_range(allowed) == (-1.0, -1.0)
    assert not allowed.contains({"acceleration": -0.99, "steering": 0.0})
    assert allowed.nearest({"acceleration": 0.3, "steering": 0.0}) == \
        {"acceleration": -1.0, "steering": 0.0}


def test_slow_down_to_a_standstill_but_no_further(shield):
    """At 2 m/s the ego may brake by at most 2 m/s in the step (acceleration >= -0.4); behind
    a stopped vehicle 6 m ahead it must stop exactly there (-0.4)."""
    free = shield.allowed("DRIVE", road(ego_vx=2.0))
    assert _acceleration_range(free) == (pytest.approx(-0.4), 1.0)
    stuck = shield.allowed("DRIVE", road(ego_vx=2.0, others=[(6.0, 0.0, -2.0)]))
    assert _acceleration_range(stuck) == (pytest.approx(-0.4), pytest.approx(-0.4))
    assert stuck.witness()["acceleration"] == pytest.approx(-0.4)


@pytest.mark.parametrize("speed", [0.0, 0.3, 1.7, 2.9, 3.3, 4.1, 4.9, 5.0, 7.3])
def test_stopping_exactly_is_a_point_the_evaluator_allows(shield, speed):
    """Behind a stopped vehicle 5.5 m ahead (centres) the one allowed acceleration brakes to
    a standstill, or fully: the two bounds are the same float, so the point is allowed."""
    allowed = shield.allowed("DRIVE", road(ego_vx=speed, others=[(5.5, 0.0, -speed)]))
    point = allowed.witness()
    assert point is not None and point["acceleration"] == -min(speed, 5.0) / 5.0
    assert allowed.contains(point)


# the turn limit 0.15 rad · 5 m / speed, the speed bounded by |vx| + |vy|: at 20 m/s along
# the road and 0, 1 or 5 m/s to the side
L0, L1, L5 = 0.75 / 20.0, 0.75 / 21.0, 0.75 / 25.0
STRAIGHTEN = 20.0 / (np.pi * 21.0 ** 2)  # the steering that turns a 1 m/s drift at 21 m/s back


@pytest.mark.parametrize("ego_y, ego_vy, others, low, high", [
    (4.0, 5.0, (), -L5, 0.0),      # drifting right fast: no steering further right
    (4.0, -5.0, (), 0.0, L5),      # drifting left fast: no steering further left
    (-0.5, -1.0, (), 0.0, L1),     # left of the leftmost lane's centre, moving left
    (8.5, 1.0, (), -L1, 0.0),      # right of the rightmost lane's centre, moving right
    (8.5, -1.0, (), -L1, L1),      # moving back towards the road: free
    (4.0, 0.0, [(2.0, -4.0, 0.0)], 0.0, L0),     # a vehicle beside on the left
    (4.0, 0.0, [(-6.0, 4.0, 0.0)], -L0, 0.0),    # and on the right
    (4.0, 0.0, [(2.0, -4.0, 0.0), (-6.0, 4.0, 0.0)], 0.0, 0.0),  # on both sides: straight on
    (4.0, -1.0, [(2.0, -4.0, 0.0)], STRAIGHTEN, L1),  # drifting towards it: turn back
    (4.0, 1.0, [(2.0, -4.0, 0.0)], -STRAIGHTEN, L1),  # drifting away: straighten at most
    (4.0, 0.0, [(18.0, -4.0, -10.0)], 0.0, L0),  # slower, ahead: beside within the step
    (4.0, 0.0, [(18.0, -4.0, -5.0)], -L0, L0),   # not so much slower: not yet
    (4.0, 0.0, [(-18.0, 4.0, 10.0)], -L0, 0.0),  # faster, behind: beside within the step
], ids=["drift-right", "drift-left", "left-edge", "right-edge", "back-to-road", "left-neighbour",
        "right-neighbour", "both-neighbours", "drifting-towards", "drifting-away",
        "coming-beside", "not-yet-beside", "overtaken"])
def test_steering_is_bounded_by_the_turn_rate_the_road_and_the_neighbours(
        shield, ego_y, ego_vy, others, low, high):
    state = road(ego_vx=20.0, ego_vy=ego_vy, ego_y=ego_y, others=others)
    assert _steering_range(shield.allowed("DRIVE", state)) == \
        (pytest.approx(low), pytest.approx(high))


@pytest.mark.parametrize("ego_vy", [-7.3, -4.1, 0.3, 2.9, 6.6])
def test_between_two_neighbours_straightening_is_a_point_the_evaluator_allows(shield, ego_vy):
    """With vehicles beside on both sides only STRAIGHTEN is left, clamped to the turn limit
    for a fast drift: a point where two bounds meet as the same number."""
    state = road(ego_vx=20.0, ego_vy=ego_vy, others=[(2.0, -4.0, 0.0), (-6.0, 4.0, 0.0)])
    allowed = shield.allowed("DRIVE", state)
    point = allowed.witness()
    assert point is not None and allowed.contains(point)
    limit = 0.75 / (20.0 + abs(ego_vy))
    assert abs(point["steering"]) <= limit
    assert point["steering"] == pytest.approx(
        max(-limit, min(limit, -ego_vy * 5.0 / (np.pi / 4 * (20.0 + abs(ego_vy)) ** 2))))


def test_a_lane_change_meets_the_new_lanes_traffic(shield):
    """Drifting right at 3 m/s, a vehicle 30 m ahead 5 m to the right counts as in front (the
    lateral window widens by 3 m); not drifting, it does not."""
    ahead = [(30.0, 5.0, -10.0)]
    assert shield.evaluate("card(FrontVehicles)", road(ego_vy=3.0, others=ahead)) == 1
    assert shield.evaluate("card(FrontVehicles)", road(ego_vy=0.0, others=ahead)) == 0
    assert _acceleration_range(shield.allowed("DRIVE", road(ego_vy=3.0, others=ahead)))[1] < 1.0


def test_the_shield_checks_and_guards_prints_a_real_states_allowed_set(adapter, env, tmp_path,
                                                                        capsys):
    code, out, err = run(capsys, "check-model", "highway_continuous")
    assert code == 0 and "ok: 1 operation(s), 9 variable(s)" in out, err
    state = next(iter(real_states(adapter, env, seeds=(0,), steps=0)))
    path = tmp_path / "state.json"
    path.write_text(json.dumps({k: format_value(v) for k, v in state.items()}))
    code, out, err = run(capsys, "guards", load_shield("highway_continuous").path,
                         "--state", path)
    assert code == 0 and "enabled: DRIVE" in out and "DRIVE: (acceleration, steering) ∈" in out


def test_braking_onto_the_allowed_set_keeps_full_throttle_from_crashing(adapter, env, shield):
    """Full throttle crashes in these episodes; moved to the nearest allowed action each step
    (what the shield wrapper does) it does not."""
    crashes = {}
    for shielded in (False, True):
        crashes[shielded] = 0
        for seed in (100, 101):
            obs, info = env.reset(seed=seed)
            observer = adapter.observer(env)
            state = observer.state(obs, info, 0.0, True)
            for _ in range(25):
                action = {"acceleration": 1.0, "steering": 0.0}
                if shielded:
                    action = shield.allowed("DRIVE", state).nearest(action)
                obs, reward, terminated, _, info = env.step(
                    np.float32([action["acceleration"], action["steering"]]))
                state = observer.state(obs, info, float(reward), False)
                if terminated:
                    crashes[shielded] += bool(info.get("crashed"))
                    break
    assert crashes == {False: 2, True: 0}


def _acceleration_range(allowed, steering=0.0):
    """The lowest and highest acceleration allowed with ``steering``: the allowed points
    nearest far below and far above."""
    return tuple(allowed.nearest({"acceleration": a, "steering": steering})["acceleration"]
                 for a in (-10.0, 10.0))


def _steering_range(allowed, acceleration=-1.0):
    return tuple(allowed.nearest({"acceleration": acceleration, "steering": s})["steering"]
                 for s in (-10.0, 10.0))


def test_the_shield_is_proved_deadlock_free(capsys):
    """Some action is allowed in every state (∃ over both parameters, z3): nearly stopped,
    drifting towards a vehicle beside, the way back was once a steering beyond its range."""
    code, out, err = run(capsys, "prove", "highway_continuous", "--deadlock-free")
    assert code == 0 and "deadlock-free: proved" in out, out + err
    assert "WARNING" not in err


def test_the_bundled_sac_agent_acts_in_the_environment():
    from tracecheck.checking.shield import data_dir
    from tracecheck.live.adapter import get_adapter
    from tracecheck.live.agents import load_agent

    path = data_dir() / "agents" / "highway_continuous_sac.zip"
    card = json.loads(path.with_suffix(".json").read_text())
    assert card["algorithm"] == "SAC" and card["environment"] == "highway-continuous"
    adapter = get_adapter("highway-continuous")
    env = adapter.make_env(adapter.config(
        {k: v for k, v in card["environment_config"].items() if k != "duration"}))
    agent = load_agent(path, adapter=adapter, env=env)
    obs, _ = env.reset(seed=0)
    action = agent.act(obs)
    assert agent.continuous and action.shape == (2,) and np.all(np.abs(action) <= 1.0)
