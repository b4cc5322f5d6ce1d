"""ShieldWrapper: masks, decisions in info, fail-closed deadlock handling."""

from __future__ import annotations

import numpy as np
import pytest

from tracecheck.errors import InputError
from tracecheck.live.envs.highway import ACTIONS, make_env
from tracecheck.checking.shield import load_shield
from tracecheck.live.wrapper import ShieldWrapper, choose

NOTHING = """
MACHINE Nothing
SETS Vehicles
CONSTANTS EgoVehicle
PROPERTIES card(Vehicles) = 5 & EgoVehicle : Vehicles
VARIABLES Crash
INVARIANT Crash : BOOL
INITIALISATION Crash :: BOOL
OPERATIONS
    IDLE = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    LANE_LEFT = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    LANE_RIGHT = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    FASTER = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    SLOWER = SELECT Crash = TRUE & Crash = FALSE THEN skip END
END
"""


def test_choose():
    assert choose([0.1, 0.9, 0.5, 0.2, 0.3], [True, False, True, False, True], 4) == (2, False)
    assert choose([0.1, 0.9, 0.5, 0.2, 0.3], [False] * 5, 4) == (4, True)


def test_masks_and_info():
    env = ShieldWrapper(make_env(), load_shield("paper"))
    obs, info = env.reset(seed=5)
    masks = env.action_masks()
    assert masks.dtype == bool and masks.shape == (5,)
    assert info["shield"]["allowed"] == [a for a, ok in zip(ACTIONS, masks) if ok]
    assert info["shield"]["name"] == "paper" and info["shield"]["decision_us"] > 0
    assert set(info["b_state"]) >= {"VehiclesX", "Crash"}
    allowed = int(np.flatnonzero(masks)[0])
    obs, reward, *_, info = env.step(allowed)
    assert info["shield"]["replaced"] is False and info["shield"]["taken"] == ACTIONS[allowed]


def test_disallowed_action_is_replaced_and_reported():
    env = ShieldWrapper(make_env(), load_shield("paper"))
    env.reset(seed=5)
    for _ in range(20):
        masks = env.action_masks()
        if not masks.all():
            break
        env.step(1)
    blocked = int(np.flatnonzero(~masks)[0])
    *_, info = env.step(blocked)
    assert info["shield"]["replaced"] is True
    assert info["shield"]["requested"] == ACTIONS[blocked]
    assert masks[ACTIONS.index(info["shield"]["taken"])]


def test_deadlock_fails_closed(tmp_path):
    path = tmp_path / "nothing.mch"
    path.write_text(NOTHING)
    env = ShieldWrapper(make_env(), load_shield(path), fallback="IDLE")
    _, info = env.reset(seed=1)
    # in a deadlock the mask holds the fallback alone: what the wrapper takes, and never an
    # empty mask for a masked learner
    assert info["shield"]["deadlock"] and info["shield"]["allowed"] == []
    assert env.action_masks().tolist() == [a == "IDLE" for a in ACTIONS]
    *_, info = env.step(3)
    assert info["shield"]["taken"] == "IDLE"  # the fallback, never silently action 0


def test_unknown_fallback():
    with pytest.raises(InputError, match="unknown fallback action 'BRAKE'"):
        ShieldWrapper(make_env(), load_shield("none"), fallback="BRAKE")


# ------------------------------------------------------------------ any environment
# (issue 23, bug 9): the adapter from the env's id, numpy observations, vector envs, the docs


def cruise_shield(text=None):
    from tests.live.cruise import SHIELD_V1
    from tracecheck.b.machine import load_machine_text
    from tracecheck.checking.shield import Shield

    machine = load_machine_text(text or SHIELD_V1, file="acc_v1.mch")
    return Shield("acc_v1", machine.sha256, "acc_v1.mch", machine)


def test_the_adapter_is_found_from_the_envs_id(monkeypatch):
    import gymnasium as gym

    from tests.live.cruise import ENV_ID, install

    install(monkeypatch)
    env = ShieldWrapper(gym.make(ENV_ID), cruise_shield())
    obs, info = env.reset(seed=3)
    assert env.env_adapter.name == "cruise" and obs.dtype == np.float32
    gap = info["b_state"]["Gap"]
    # the float32 observation as the float it is, exactly: what the shield decided on
    assert type(gap) is float and gap == float(obs[0]) and np.float32(gap) == obs[0]
    assert info["shield"]["allowed"] == ["KEEP", "ACCEL", "BRAKE"]
    *_, info = env.step(2)
    assert info["shield"]["taken"] == "BRAKE" and type(info["b_state"]["EgoSpeed"]) is float


def test_an_env_no_installed_adapter_is_for_asks_for_one():
    import gymnasium as gym

    from tests.live.cruise import ENV_ID

    with pytest.raises(InputError) as info:
        ShieldWrapper(gym.make(ENV_ID), cruise_shield())
    text = info.value.render()
    assert f"no installed adapter is for the environment {ENV_ID!r}" in text
    assert "adapter=MyAdapter()" in text and "frozenlake (FrozenLake-v1)" in text


def test_an_env_without_a_gymnasium_id_asks_for_its_adapter():
    from tests.live.cruise import Cruise, CruiseEnv

    with pytest.raises(InputError, match="the environment has no Gymnasium id"):
        ShieldWrapper(CruiseEnv(), cruise_shield())
    env = ShieldWrapper(CruiseEnv(), cruise_shield(), adapter=Cruise())
    assert env.reset(seed=0)[1]["shield"]["allowed"] == ["KEEP", "ACCEL", "BRAKE"]


def test_two_adapters_for_one_id_are_ambiguous(monkeypatch):
    from importlib import metadata

    import gymnasium as gym

    from tests.live.cruise import ENV_ID, install
    from tracecheck import registry

    install(monkeypatch)
    points = dict(registry.entry_points())
    points["cruise2"] = metadata.EntryPoint("cruise2", "tests.live.cruise:Cruise",
                                            registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda: points)
    with pytest.raises(InputError, match="are all for 'TracecheckCruise-v0'; give the one"):
        ShieldWrapper(gym.make(ENV_ID), cruise_shield())


@pytest.mark.parametrize("how", ["make_vec", "SyncVectorEnv"])
def test_under_a_vector_env(monkeypatch, how):
    import gymnasium as gym

    from tests.live.cruise import ENV_ID, install

    install(monkeypatch)
    shield = cruise_shield()
    if how == "make_vec":
        envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync",
                            wrappers=[lambda e: ShieldWrapper(e, shield)])
    else:
        envs = gym.vector.SyncVectorEnv([lambda: ShieldWrapper(gym.make(ENV_ID), shield)] * 2)
    obs, infos = envs.reset(seed=0)
    assert [m.tolist() for m in envs.call("action_masks")] == [[True, True, True]] * 2
    assert infos["b_state"]["Gap"].tolist() == [float(g) for g in obs[:, 0]]
    for _ in range(12):  # accelerate into the lead car: the shield takes KEEP off
        obs, _, _, _, infos = envs.step(np.array([1, 1]))
        if not all(m[1] for m in envs.call("action_masks")):
            break
    masks = envs.call("action_masks")
    assert not all(m[1] for m in masks)  # ACCEL blocked in some sub-environment
    states = envs.get_attr("state")
    assert all(m.tolist() == [s["Gap"] > 10.0, s["Gap"] > 20.0 and s["EgoSpeed"] < 40.0,
                              s["EgoSpeed"] > 0.0] for m, s in zip(masks, states))
    envs.close()


def test_the_python_section_of_docs_environments_runs():
    """docs/environments.md, "Using the shield from Python": its code blocks as a doctest."""
    import doctest
    import re

    from tests.helpers import ROOT

    text = (ROOT / "docs" / "environments.md").read_text()
    section = text.split("## Using the shield from Python", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) >= 3
    test = doctest.DocTestParser().get_doctest("\n".join(blocks), {}, "environments.md",
                                               "docs/environments.md", 0)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted >= 15 and result.failed == 0


def test_a_guard_it_cannot_evaluate_fails_closed_and_says_why(tmp_path):
    """A guard without a value in a state (here a division by zero) is neither TRUE nor
    FALSE: its action is not allowed, the others are, and info says which guard and why
    (it used to stop the episode with the error)."""
    from tests.live.toy import SHIELD, CorridorEnv, Corridor

    path = tmp_path / "undefined.mch"
    path.write_text(SHIELD.replace("Right = SELECT pos < 5", "Right = SELECT 10 / (pos - 2) > 0"))
    env = ShieldWrapper(CorridorEnv(slip=False), load_shield(path), fallback="Left",
                        adapter=Corridor())
    _, info = env.reset(seed=0)  # pos = 2: Right's guard divides by zero
    assert info["shield"]["allowed"] == ["Left"] and not info["shield"]["deadlock"]
    assert info["shield"]["problem"].startswith("Right: ") and "division by zero" in \
        info["shield"]["problem"]
    *_, info = env.step(1)  # Right asked for: not allowed, so replaced
    assert info["shield"]["replaced"] and info["shield"]["taken"] == "Left"
    assert "problem" not in info["shield"]  # pos = 1: every guard evaluates


def test_a_recorded_deadlock_is_said_in_the_file(tmp_path, capsys):
    """A new user's elevator: record stored no deadlock (the rollout read the learner's mask,
    which holds the fallback in a deadlock), so each such step showed the fallback as
    allowed — the file, stats, Foxglove's log and Minari all said there was none, where
    replay counted 13 deadlock states."""
    import json

    import numpy as np
    from mcap.reader import make_reader

    from tests.helpers import run
    from tests.live.toy import SHIELD, left_leaning_table
    from tracecheck.checking.replaying import replay

    shield = tmp_path / "stuck.mch"  # in cells 2 and 3 nothing is allowed
    shield.write_text(SHIELD.replace("pos > 1", "pos > 3").replace("pos < 5", "pos < 2"))
    table = tmp_path / "left.npy"
    np.save(table, left_leaning_table())
    out = tmp_path / "run.mcap"
    code, said, err = run(capsys, "record", "--env", "tests.live.toy:Corridor", "--agent",
                          table, "--shield", shield, "-n", "6", "-o", out)
    assert code == 0, err
    with open(out, "rb") as f:
        steps = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(
            topics=["/tracecheck/step"])]
    stuck = [s for s in steps if s["step"] > 0 and s.get("deadlock")]
    assert stuck and all(s["allowed_actions"] == [] and s["action"] == "Left" for s in stuck)
    # each deadlock is the state before a step in cell 2 or 3: as the shield decided there
    before = {(s["episode"], s["step"]): s["state"]["pos"] for s in steps}
    assert all(before[(s["episode"], s["step"] - 1)] in (2, 3) for s in stuck)
    assert not any(s.get("deadlock") for s in steps
                   if s["step"] > 0 and before[(s["episode"], s["step"] - 1)] not in (2, 3))
    assert f"{len(stuck)} step(s) where the shield allowed nothing" in " ".join(said.split())
    report = replay([out], load_shield(shield))
    assert report.deadlock_states >= len(stuck)


def test_the_bundled_none_for_another_environment_says_how_to_allow_everything():
    """load_shield("none") is the highway's: wrapping a user's continuous environment with
    it said only "NoShield has no operation 'CLIMB'" (a new user's drone); now the lacking
    actions, and how to get a none of their own."""
    import gymnasium as gym

    from tracecheck.live.adapter import EnvAdapter

    class Lift(EnvAdapter):
        name = "lift"
        actions = ("HOLD", "CLIMB")
        parameters = {"CLIMB": ("r",)}
        fallback = "HOLD"
        variables = ("alt",)

    class LiftEnv(gym.Env):
        observation_space = gym.spaces.Box(0.0, 1.0, (1,))
        action_space = gym.spaces.Tuple((gym.spaces.Discrete(2),
                                         gym.spaces.Box(0.0, 1.0, (1,))))

    with pytest.raises(InputError) as info:
        ShieldWrapper(LiftEnv(), load_shield("none"), adapter=Lift())
    assert "NoShield lacks HOLD, CLIMB" in info.value.message
    assert 'load_shield("none", actions=adapter.actions, parameters=adapter.parameters)' \
        in info.value.hint
    mine = load_shield("none", actions=Lift.actions, parameters=Lift.parameters)
    assert ShieldWrapper(LiftEnv(), mine, adapter=Lift()).actions == ("HOLD", "CLIMB")
