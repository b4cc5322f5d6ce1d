"""Hybrid action spaces live — a discrete choice of operation, each with its own REAL
parameters (tracecheck.live.continuous, wrapper, rollout, resimulate, stats): the cruise
control of tests/fixtures/acc_env with ACCELERATE(a), BRAKE(b) and KEEP
(``acc_cruise.hybrid:Hybrid``, a Platform-v0-style ``Tuple((Discrete(3), Tuple((Box, Box,
Box))))``)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tests.helpers import ACC_ENV, acc_installed, forget_acc, record_runs, run
from tracecheck.b.machine import load_machine
from tracecheck.errors import InputError
from tracecheck.live.adapter import EnvAdapter
from tracecheck.live.continuous import ContinuousShield

HYBRID = "acc_cruise.hybrid:Hybrid"
SHIELD = ACC_ENV / "acc_cruise" / "hybrid_v1.mch"
THROTTLE = "acc_cruise.throttle:Throttle"
THROTTLE_V1 = ACC_ENV / "acc_cruise" / "throttle_v1.mch"


def _box(low, high):
    return gym.spaces.Box(low, high, (1,), np.float32)


SPACE = gym.spaces.Tuple((gym.spaces.Discrete(3),
                          gym.spaces.Tuple((_box(0.0, 2.0), _box(0.0, 4.0), _box(0.0, 0.0)))))


class _Adapter(EnvAdapter):
    name = "h"
    actions = ("ACCELERATE", "BRAKE", "KEEP")
    parameters = {"ACCELERATE": ("a",), "BRAKE": ("b",)}
    fallback = "BRAKE"
    fallback_action = (4.0,)
    variables = ("Gap", "EgoSpeed", "LeadSpeed")


def _shield(mode=None, adapter=None, space=SPACE):
    return ContinuousShield(load_machine(SHIELD), adapter or _Adapter(), space, mode=mode)


def _decided(shield, gap, ego, lead):
    shield.decide(shield.machine.env({"Gap": gap, "EgoSpeed": ego, "LeadSpeed": lead}))
    return shield


# ------------------------------------------------------------------ the shield itself


def test_the_agent_acts_with_scores_then_every_parameter():
    shield = _shield()
    assert shield.mode == "mask" and shield.hybrid
    space = shield.agent_space
    assert space.low.tolist() == [-1, -1, -1, 0, 0] and space.high.tolist() == [1, 1, 1, 2, 4]
    assert shield.params == ("a", "b")


def test_mask_keeps_an_allowed_proposal_and_sends_the_environment_its_pair():
    shield = _decided(_shield(), 40.0, 20.0, 20.0)  # a < 9.5: ACCELERATE by 1.5 is allowed
    d = shield.filter(np.array([1.0, 0.0, 0.5, 1.5, 3.0]))
    assert (d.op, d.proposed_op, d.parameters, d.distance) == ("ACCELERATE", "ACCELERATE",
                                                               {"a": 1.5}, 0.0)
    assert not d.intervened and not d.deadlock
    index, values = d.sent
    assert index == 0 and [v.tolist() for v in values] == [[1.5], [0.0], [0.0]]
    assert values[0].dtype == np.float32


def test_mask_projects_the_values_of_the_chosen_operation():
    # Gap 20, ego 15, lead 14: ACCELERATE allows a < 1.5, so a = 2 is moved to just below it
    shield = _decided(_shield(), 20.0, 15.0, 14.0)
    d = shield.filter(np.array([1.0, 0.0, 0.5, 2.0, 3.0]))
    assert d.op == "ACCELERATE" and d.intervened and not d.deadlock
    assert 1.49 < d.parameters["a"] < 1.5 and d.distance == pytest.approx(2.0 - d.parameters["a"])
    assert shield.machine.allows("ACCELERATE", {"Gap": 20.0, "EgoSpeed": 15.0,
                                                "LeadSpeed": 14.0}, d.parameters)
    assert shield.bands("ACCELERATE") == {"a": ((0.0, 1.5),)}


def test_mask_takes_the_best_scored_operation_the_shield_enables():
    # Gap 10, ego 15, lead 14: ACCELERATE and KEEP are disabled, BRAKE needs b > 3.5
    shield = _decided(_shield(), 10.0, 15.0, 14.0)
    assert shield.enabled == {"BRAKE"}
    d = shield.filter(np.array([1.0, -0.5, 0.5, 2.0, 1.0]))
    assert (d.op, d.proposed_op) == ("BRAKE", "ACCELERATE")
    assert d.intervened and d.distance is None and 3.5 < d.parameters["b"] <= 3.6
    assert d.proposal == {"a": 2.0} and d.scores == {"ACCELERATE": 1.0, "BRAKE": -0.5,
                                                     "KEEP": 0.5}


def test_an_operation_without_parameters_is_taken_without_values():
    shield = _decided(_shield(), 40.0, 20.0, 20.0)
    d = shield.filter(np.array([0.0, 0.0, 1.0, 2.0, 4.0]))
    assert d.op == "KEEP" and d.parameters == {} and d.executed.size == 0
    assert d.sent[0] == 2 and not d.intervened and d.distance == 0.0


def test_the_environments_own_pair_is_accepted():
    shield = _decided(_shield(), 40.0, 20.0, 20.0)
    d = shield.filter((1, (np.array([0.0]), np.array([2.5]), np.array([0.0]))))
    assert (d.op, d.parameters, d.scores["BRAKE"]) == ("BRAKE", {"b": 2.5}, 1.0)
    d = shield.filter(("ACCELERATE", [0.5]))
    assert (d.op, d.parameters) == ("ACCELERATE", {"a": 0.5})
    with pytest.raises(InputError, match=r"the agent's choice 7 is not an action index 0 … 2"):
        shield.filter((7, [0.0]))


def test_nothing_allowed_fails_closed_with_the_fallback_operation():
    shield = _decided(_shield(), 1.0, 30.0, 10.0)  # BRAKE would need b > 24.5
    assert shield.enabled == set() and not shield.any_allowed()
    d = shield.filter(np.array([1.0, 0.0, 0.0, 1.0, 1.0]))
    assert (d.op, d.parameters, d.deadlock) == ("BRAKE", {"b": 4.0}, True)


def test_replace_takes_the_fallback_when_the_proposal_is_not_allowed():
    shield = _decided(_shield("replace"), 20.0, 15.0, 14.0)
    kept = shield.filter(np.array([1.0, 0.0, 0.0, 1.0, 0.0]))
    assert (kept.op, kept.parameters, kept.intervened) == ("ACCELERATE", {"a": 1.0}, False)
    d = shield.filter(np.array([1.0, 0.0, 0.0, 2.0, 0.0]))
    assert (d.op, d.parameters, d.intervened, d.deadlock) == ("BRAKE", {"b": 4.0}, True,
                                                              False)


@pytest.mark.parametrize("mode, space, message", [
    ("project", SPACE, r"--shield-mode project does not fit h's action space"),
    ("mask", _box(0.0, 2.0), r"declares parameters for ACCELERATE, BRAKE and the actions "
                             r"ACCELERATE, BRAKE, KEEP, but the environment's action space "
                             r"Box.* is one Box"),
    (None, gym.spaces.Tuple((gym.spaces.Discrete(2), _box(0.0, 2.0))),
     r"h has 3 actions \(ACCELERATE, BRAKE, KEEP\); the discrete part of the environment's "
     r"action space .* has 2"),
    (None, gym.spaces.Tuple((gym.spaces.Discrete(3), gym.spaces.Tuple((_box(0, 1),)))),
     r"has 1 parameter spaces; the adapter h has 3 actions"),
    (None, gym.spaces.Dict({"x": _box(0, 1)}), r"neither a one-dimensional Box nor a hybrid"),
])
def test_spaces_and_modes_that_do_not_fit_are_refused(mode, space, message):
    with pytest.raises(InputError, match=message):
        _shield(mode, space=space)


def test_a_box_refuses_mask():
    class Throttle(EnvAdapter):
        name = "t"
        actions = ("ACCELERATE",)
        parameters = {"ACCELERATE": ("a",)}

    with pytest.raises(InputError, match=r"--shield-mode mask does not fit t's action space"):
        ContinuousShield(load_machine(THROTTLE_V1), Throttle(), _box(-4.0, 2.0), mode="mask")


def test_a_shared_box_gives_every_operation_with_parameters_its_components():
    space = gym.spaces.Tuple((gym.spaces.Discrete(3), _box(0.0, 4.0)))
    shield = _decided(_shield(space=space), 20.0, 15.0, 14.0)
    d = shield.filter(np.array([0.0, 1.0, 0.0, 0.0, 3.0]))
    assert d.op == "BRAKE" and d.sent[0] == 1 and d.sent[1].tolist() == [3.0]


def test_an_adapter_with_parameters_for_an_unknown_action_is_refused(tmp_path, monkeypatch):
    from tracecheck.live.adapter import load_adapter

    (tmp_path / "stray_adapters.py").write_text(
        "from tracecheck.live.adapter import EnvAdapter\n\n"
        "class Stray(EnvAdapter):\n    name = 'stray'\n"
        "    actions = ('ACCELERATE', 'BRAKE', 'KEEP')\n"
        "    parameters = {'STEER': ('s',)}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(InputError, match=r"keyed by its actions \(ACCELERATE, BRAKE, KEEP\): "
                                         r"STEER is not one"):
        load_adapter("stray_adapters:Stray")


@settings(max_examples=60, deadline=None)
@given(gap=st.floats(0.0, 80.0), ego=st.floats(0.0, 40.0), lead=st.floats(0.0, 40.0),
       action=st.lists(st.floats(-1.0, 5.0), min_size=5, max_size=5),
       mode=st.sampled_from(["mask", "replace"]))
@example(gap=0.0, ego=0.0, lead=1.0, action=[0.0, 0.0, 0.0, 0.0, 1.1880681485291735e-116],
         mode="mask")  # found by CI: a proposal float32 rounds to a refused 0.0
def test_every_executed_action_is_allowed_or_the_recorded_fallback(gap, ego, lead, action,
                                                                    mode):
    shield = _decided(_shield(mode), gap, ego, lead)
    d = shield.filter(np.array(action))
    state = {"Gap": gap, "EgoSpeed": ego, "LeadSpeed": lead}
    if d.deadlock:
        assert (d.op, d.parameters) == ("BRAKE", {"b": 4.0})
        if mode == "mask":
            assert not shield.enabled
        return
    assert shield.machine.allows(d.op, state, d.parameters)
    if mode == "mask":  # the best-scored enabled operation
        best = max((s, -i) for i, (a, s) in enumerate(zip(shield.actions, action[:3]))
                   if a in shield.enabled)
        assert d.op == shield.actions[-best[1]]


# ------------------------------------------------------------------ recorded, replayed


@pytest.fixture(scope="module")
def hybrid(tmp_path_factory):
    """A PPO file that always prefers ACCELERATE by 2 (then KEEP, then BRAKE by 1), and
    runs of it unshielded and under the shield; the hybrid environment installed."""
    folder = tmp_path_factory.mktemp("hybrid")
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        from acc_cruise.hybrid import make_agent

        agent = make_agent(folder / "agent.zip")
        runs = record_runs(folder, HYBRID, agent, {"none": ("none", []), "v1": (SHIELD, [])})
    forget_acc()
    return agent, runs


def test_a_hybrid_recording_keeps_the_operation_its_values_and_the_agents_scores(hybrid):
    from tracecheck.episodes.reader import read_header, read_run

    _, runs = hybrid
    header = read_header(runs["v1"])
    assert header.action_parameters == {"ACCELERATE": ["a"], "BRAKE": ["b"]}
    assert header.action_low == [0.0, 0.0] and header.action_high == [2.0, 4.0]
    assert header.shield_mode == "mask" and header.projection_scale == [1.0, 1.0]
    machine = load_machine(SHIELD)
    episodes = list(read_run(runs["v1"]).episodes)
    assert not any(e.end.crashed for e in episodes)
    ops = set()
    for e in episodes:
        for before, s in zip(e.steps, e.steps[1:]):
            ops.add(s.action)
            assert s.preferred_action == "ACCELERATE" and s.proposal == {"a": 2.0}
            assert s.action_values == {"ACCELERATE": 1.0, "BRAKE": 0.0, "KEEP": 0.5}
            if not s.deadlock:
                assert s.action in s.allowed_actions
                assert machine.allows(s.action, before.state, s.parameters or {})
    assert ops == {"ACCELERATE", "BRAKE", "KEEP"} or ops >= {"ACCELERATE", "BRAKE"}
    unshielded = list(read_run(runs["none"]).episodes)
    assert all(e.end.crashed for e in unshielded)


def test_replay_finds_the_infeasible_choices_and_resimulation_prevents_the_crashes(capsys,
                                                                                  hybrid):
    agent, runs = hybrid
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        code, out, err = run(capsys, "replay", runs["none"], "--shield", SHIELD,
                             "--resimulate", "--agent", agent, "--env", HYBRID, "--json")
    forget_acc()
    assert code == 0, err
    report = json.loads(out)
    assert report["infeasible_episodes"] == 4 and report["crashes_after_infeasible"] == 4
    resim = report["resimulation"]
    assert resim["resimulated"] == 4 and resim["mismatches"] == 0
    assert resim["crashes_prevented"] == 4


def test_statistics_count_a_changed_operation_as_an_intervention(capsys, hybrid):
    _, runs = hybrid
    code, out, err = run(capsys, "stats", runs["v1"], "--json")
    assert code == 0, err
    continuous = json.loads(out)["runs"][0]["continuous"]
    assert continuous["interventions"]["ratio"] > 0.5 and continuous["parameters"] == ["a", "b"]
    code, out, _ = run(capsys, "info", runs["v1"])
    assert "continuous: ACCELERATE(a), BRAKE(b), shield mode mask, scale 1, 1" in out


# ------------------------------------------------------------------ training


def test_train_on_a_hybrid_space_masks_projects_and_says_so(capsys, acc_env, tmp_path):
    out = tmp_path / "sac.zip"
    code, said, err = run(capsys, "train", "--env", HYBRID, "--env-config", "max_steps=20",
                          "--shield", SHIELD, "--steps", "100", "-o", out)
    assert code == 0, err
    assert ("(SAC on hybrid under shield hybrid_v1, operations masked and their values "
            "projected, 100 steps") in " ".join(said.split())
    card = json.loads(out.with_suffix(".json").read_text())
    assert card["shielding"] == "masked, values projected"
    code, _, err = run(capsys, "record", "--env", HYBRID, "--agent", out, "--shield", SHIELD,
                       "-n", "1", "--env-config", "max_steps=10", "-o", tmp_path / "r.mcap")
    assert code == 0, err
    unshielded = tmp_path / "free.zip"  # the wrapper flattens the space without a shield too
    code, said, err = run(capsys, "train", "--env", HYBRID, "--env-config", "max_steps=20",
                          "--steps", "100", "-o", unshielded)
    assert code == 0, err
    assert "(SAC on hybrid, 100 steps" in " ".join(said.split())


def test_train_takes_the_shield_mode_and_scale_only_with_a_shield(capsys, acc_env, tmp_path):
    out = tmp_path / "td3.zip"
    code, said, err = run(capsys, "train", "--env", THROTTLE, "--env-config", "max_steps=20",
                          "--algorithm", "td3", "--shield", THROTTLE_V1, "--shield-mode", "replace",
                          "--steps", "100", "-o", out)
    assert code == 0, err
    assert "under shield throttle_v1, blocked actions replaced" in " ".join(said.split())
    code, _, err = run(capsys, "train", "--env", THROTTLE, "--shield-mode", "replace",
                       "--steps", "100", "-o", tmp_path / "x.zip")
    assert code == 2 and "--shield-mode and --scale say how --shield moves continuous " \
                         "actions" in " ".join(err.split())
    code, _, err = run(capsys, "train", "--env", HYBRID, "--shield", SHIELD, "--shield-mode",
                       "project", "--steps", "100", "-o", tmp_path / "x.zip")
    assert code == 2 and "--shield-mode project does not fit hybrid's action space" in \
        " ".join(err.split())
    assert not (tmp_path / "x.zip").exists()


class _KeepAdapter(_Adapter):
    fallback = "KEEP"  # without parameters: no fallback_action
    fallback_action = None


def test_a_fallback_without_parameters_and_a_refused_fallback_in_replace_mode():
    nothing = _decided(_shield(adapter=_KeepAdapter()), 1.0, 30.0, 10.0)
    d = nothing.filter(np.array([1.0, 0.0, 0.0, 1.0, 1.0]))
    assert (d.op, d.parameters, d.deadlock, d.sent[0]) == ("KEEP", {}, True, 2)
    # Gap 10, ego 15, lead 14: only BRAKE (b > 3.5); replace's fallback KEEP is refused, so
    # the best-scored enabled operation is taken, as mask takes it — no deadlock
    shield = _decided(_shield("replace", adapter=_KeepAdapter()), 10.0, 15.0, 14.0)
    d = shield.filter(np.array([1.0, 0.5, 0.0, 2.0, 1.0]))
    assert (d.op, d.deadlock) == ("BRAKE", False) and 3.5 < d.parameters["b"] <= 3.6
    with pytest.raises(InputError, match=r"fallback_action = \(0\.0,\), but its fallback KEEP "
                                         r"takes no parameters"):
        _shield(adapter=type("Bad", (_KeepAdapter,), {"fallback_action": (0.0,)})())


def test_hybrid_statistics_judge_every_step_and_count_every_fallback(capsys, tmp_path):
    """Steps of KEEP (no parameters) count: the agent's scores say whether the shield changed
    its choice, and a fallback KEEP is a fallback."""
    from tracecheck.episodes import new_header
    from tracecheck.episodes.files import write_run
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    scores = {"ACCELERATE": 1.0, "BRAKE": 0.0, "KEEP": 0.5}
    moves = [("ACCELERATE", {"a": 2.0}, False),  # as proposed
             ("KEEP", None, False),  # the shield chose KEEP instead: an intervention
             ("KEEP", None, True)]  # nothing allowed: the fallback KEEP
    state = {"Gap": 40.0, "EgoSpeed": 20.0, "LeadSpeed": 20.0}
    steps = [StepRecord(0, 0.0, None, state, 0.0, False)]
    for k, (op, values, deadlock) in enumerate(moves, 1):
        steps.append(StepRecord(k, float(k), op, state, 1.0, False, parameters=values,
                                proposal={"a": 2.0}, action_values=scores,
                                preferred_action="ACCELERATE", deadlock=deadlock or None,
                                allowed_actions=() if deadlock else (op,)))
    steps = tuple(steps)
    path = tmp_path / "hybrid.mcap"
    write_run(path, new_header("recorded", actions=list(scores),
                               variables=["Gap", "EgoSpeed", "LeadSpeed"],
                               action_parameters={"ACCELERATE": ["a"], "BRAKE": ["b"]},
                               action_low=[0.0, 0.0], action_high=[2.0, 4.0],
                               shield_mode="mask"),
              [Episode(0, steps, make_end(steps, "time-limit"), seed=0)])
    code, out, err = run(capsys, "stats", path, "--json")
    assert code == 0, err
    found = json.loads(out)["runs"][0]
    continuous = found["continuous"]
    assert (continuous["interventions"]["count"], continuous["interventions"]["steps"]) == (2, 3)
    assert (continuous["fallback"]["count"], continuous["fallback"]["steps"]) == (1, 3)
    per_episode = found["metrics"]["interventions"]
    assert per_episode["mean"] == pytest.approx(2 / 3)


def test_a_proposal_the_space_rounds_to_a_refused_value_moves_back_inside():
    """BRAKE(b) allows b in (0, 4]: a proposed b of 1e-116 is allowed over the reals, but a
    float32 space makes it 0.0, which is refused — the shield sends the float32 nearest it
    inside (the smallest above 0), not the fallback, and says BRAKE is enabled."""
    shield = _decided(_shield("mask"), 0.0, 0.0, 1.0)
    assert shield.enabled == {"BRAKE"}
    d = shield.filter(np.array([0.0, 0.0, 0.0, 0.0, 1e-116]))
    tiny = float(np.nextafter(np.float32(0.0), np.float32(1.0)))
    assert not d.deadlock and (d.op, d.parameters) == ("BRAKE", {"b": tiny})
    assert shield.machine.allows("BRAKE", {"Gap": 0.0, "EgoSpeed": 0.0, "LeadSpeed": 1.0},
                                 d.parameters)
