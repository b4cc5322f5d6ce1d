"""LunarLanderContinuous-v3: the adapter lunarlander-continuous and its shield
lunarlander_continuous (a hard landing and a tilt), on real and hand-made states."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.helpers import run
from tracecheck.b.values import FuncValue, format_value
from tracecheck.checking.shield import builtin_shields, load_shield
from tracecheck.live.adapter import get_adapter

pytest.importorskip("Box2D", reason="LunarLander needs the box2d extra "
                                    "(pip install 'tracecheck[box2d]')")

ADAPTER = "lunarlander-continuous"  # the adapter, shield and env fixtures (conftest.py)

PAD = 167.0  # the helipad's y in the surface's screen coordinates (200 - 10 · 10/3 m)


def lander(alt=1.0, v_x=0.0, v_y=0.0, angle=0.0, v_angular=0.0, legs=(False, False),
           ground=PAD):
    """A hand-made state: the lander above the centre at altitude ``alt`` (Gymnasium's o1:
    0 where the legs touch the helipad), over flat terrain at ``ground`` (screen y)."""
    surface = FuncValue({i: ((80.0 * (i - 1), ground), (80.0 * i, ground)) for i in range(1, 11)})
    return {"x": 400.0, "y": 200.0 - (alt + 1.5) * 200.0 / 3.0, "v_x": v_x, "v_y": v_y,
            "angle": angle, "v_angular": v_angular, "left_leg_on_ground": legs[0],
            "right_leg_on_ground": legs[1], "surface": surface}


def ranges(allowed):
    """The allowed interval of each parameter (the set is one box): its ends, as floats."""
    low = allowed.nearest({"main": -10.0, "lateral": -10.0})
    high = allowed.nearest({"main": 10.0, "lateral": 10.0})
    return {p: (low[p], high[p]) for p in ("main", "lateral")}


def test_the_adapter_is_the_lander_with_one_operation_of_two_parameters(adapter, env):
    assert adapter.name == "lunarlander-continuous"
    assert adapter.env_id == "LunarLanderContinuous-v3" and env.continuous
    assert adapter.actions == ("FIRE",) and adapter.parameters == {"FIRE": ("main", "lateral")}
    assert adapter.fallback_action == (1.0, 0.0) and adapter.fallback is None
    assert adapter.default_shield == "lunarlander_continuous" in builtin_shields()
    assert adapter.variables == get_adapter("lunarlander").variables
    assert env.action_space.shape == (2,) and env.action_space.low.tolist() == [-1.0, -1.0]
    assert "continuous" not in adapter.config_keys() and "gravity" in adapter.config_keys()


def test_the_envs_command_lists_it(capsys):
    code, out, _ = run(capsys, "envs", "--json")
    row = {r["name"]: r for r in json.loads(out)}["lunarlander-continuous"]
    assert code == 0 and row["actions"] == ["FIRE"]
    assert row["default_shield"] == "lunarlander_continuous"


def test_real_states_fit_the_shield_and_leave_a_box_of_actions(adapter, env, shield):
    rng = np.random.default_rng(0)
    count = 0
    for seed in (0, 1):
        obs, info = env.reset(seed=seed)
        observer = adapter.observer(env)
        state = observer.state(obs, info, 0.0, True)
        for _ in range(80):
            shield.check_state(state)
            allowed = shield.allowed("FIRE", state)
            assert allowed.separable and allowed.witness() is not None, str(allowed)
            count += 1
            obs, reward, terminated, _, info = env.step(rng.uniform(-1.0, 1.0, 2))
            state = observer.state(obs, info, float(reward), False)
            if terminated:
                break
    assert count >= 80


@pytest.mark.parametrize("state, main, lateral", [
    (lander(alt=1.0, v_y=-0.1), (-1.0, 1.0), (-1.0, 1.0)),
    (lander(alt=0.2, v_y=-0.8), (1.0, 1.0), (-1.0, 1.0)),
    (lander(alt=0.2, v_y=-0.8, legs=(True, False)), (-1.0, 1.0), (-1.0, 1.0)),
    (lander(angle=0.5, v_angular=0.1), (-1.0, 1.0), (0.75, 1.0)),
    (lander(angle=0.5, v_angular=-0.1), (-1.0, 1.0), (-0.5, 1.0)),
    (lander(angle=0.3), (-1.0, 1.0), (-0.5, 1.0)),
    (lander(angle=-0.5, v_angular=-0.1), (-1.0, 1.0), (-1.0, -0.75)),
    (lander(angle=-0.3), (-1.0, 1.0), (-1.0, 0.5)),
    (lander(alt=0.0, angle=0.5, v_angular=0.1, legs=(True, True)), (-1.0, 1.0), (-1.0, 1.0)),
], ids=["descending-slowly", "falling-fast-low", "a-leg-down", "tilted-far-and-tilting",
        "tilted-far-coming-back", "tilted", "tilted-far-the-other-way", "tilted-the-other-way",
        "landed-tilted"])
def test_the_rules_bound_one_engine_each(shield, state, main, lateral):
    assert ranges(shield.allowed("FIRE", state)) == {"main": main, "lateral": lateral}


def test_the_hard_landing_rule_starts_where_the_hand_computation_says(shield):
    """Falling at v_y = -0.6 over the helipad (ground o1 = (3.3 - 10/3) · 0.15 = -0.005): a
    step later the fall is 0.6267 and the height 0.6 / 44.44 less; full thrust (net
    +0.0187 a step) slows 0.6267 to 0.2 within (0.6267² - 0.2²) / (2 · 0.0187 · 44.44) =
    0.2122 of o1, twice that is 0.4245: the main engine must fire from o1 = 0.4245 - 0.005
    + 0.6 / 44.44 = 0.4330 down, not above."""
    threshold = 2.0 * (0.6267 ** 2 - 0.04) / (2.0 * 0.0187 * 44.444444444444444) - 0.005 \
        + 0.6 / 44.444444444444444
    assert threshold == pytest.approx(0.4330, abs=1e-4)
    for alt, fires in ((threshold - 0.002, True), (threshold + 0.002, False)):
        state = lander(alt=alt, v_y=-0.6)
        assert shield.evaluate("GROUND", state) == pytest.approx(-0.005)
        assert ranges(shield.allowed("FIRE", state))["main"][0] == (1.0 if fires else -1.0)


def test_the_rule_reads_the_terrain_under_the_lander(shield):
    """The same fall is refused far higher over a hill: terrain at screen y 140 (6 m) puts
    the ground at o1 (6 - 10/3) · 0.15 = 0.4."""
    over_pad, over_hill = lander(alt=0.6, v_y=-0.6), lander(alt=0.6, v_y=-0.6, ground=140.0)
    assert shield.evaluate("GROUND", over_hill) == pytest.approx(0.4)
    assert ranges(shield.allowed("FIRE", over_pad))["main"] == (-1.0, 1.0)
    assert ranges(shield.allowed("FIRE", over_hill))["main"] == (1.0, 1.0)


def test_the_shield_checks_and_guards_prints_a_real_states_allowed_set(adapter, env, tmp_path,
                                                                        capsys):
    code, out, err = run(capsys, "check-model", "lunarlander_continuous")
    assert code == 0 and "ok: 1 operation(s), 9 variable(s)" in out, err
    obs, info = env.reset(seed=0)
    state = adapter.observer(env).state(obs, info, 0.0, True)
    path = tmp_path / "state.json"
    path.write_text(json.dumps({k: format_value(v) for k, v in state.items()}))
    code, out, err = run(capsys, "guards", load_shield("lunarlander_continuous").path,
                         "--state", path)
    assert code == 0 and "FIRE: (main, lateral) ∈ [-1.0, 1.0] × [-1.0, 1.0]" in out, err


def test_an_idle_lander_moved_onto_the_allowed_set_touches_down_slowly(adapter, env, shield):
    """Doing nothing, the lander hits the ground at |v_y| > 1.5; moved to the nearest allowed
    action each step (what the shield wrapper does), its first touchdown is slow."""
    for shielded, slow in ((False, False), (True, True)):
        for seed in (0, 1, 2):
            obs, info = env.reset(seed=seed)
            observer = adapter.observer(env)
            state = observer.state(obs, info, 0.0, True)
            for _ in range(1000):
                before = float(obs[3])
                action = {"main": -1.0, "lateral": 0.0}
                if shielded:
                    action = shield.allowed("FIRE", state).nearest(action)
                obs, reward, terminated, _, info = env.step(
                    np.array([action["main"], action["lateral"]]))
                state = observer.state(obs, info, float(reward), False)
                if obs[6] or obs[7] or terminated:
                    break
            assert (before > -0.3) if slow else (before < -1.5), (shielded, seed, before)


def test_the_heuristic_lander_lands_as_well_under_the_shield(adapter, env, shield):
    """Gymnasium's own heuristic lands seeds 0-2 with or without the shield moving its
    actions (it asks for something the shield refuses in few steps)."""
    from gymnasium.envs.box2d.lunar_lander import heuristic

    for seed in (0, 1, 2):
        obs, info = env.reset(seed=seed)
        observer = adapter.observer(env)
        state = observer.state(obs, info, 0.0, True)
        moved = steps = 0
        while steps < 1000:
            steps += 1
            wanted = heuristic(env, obs)
            action = shield.allowed("FIRE", state).nearest(
                {"main": float(wanted[0]), "lateral": float(wanted[1])})
            moved += (action["main"], action["lateral"]) != tuple(float(w) for w in wanted)
            obs, reward, terminated, _, info = env.step(
                np.array([action["main"], action["lateral"]]))
            state = observer.state(obs, info, float(reward), False)
            if terminated:
                break
        assert reward == 100 and moved < 0.25 * steps, (seed, moved, steps)
