"""Continuous actions live: the projection shield, the wrapper, recording and agents
(tracecheck.live.continuous, wrapper, rollout, agents), on the throttle environment of
tests/fixtures/acc_env (a user's own, ``acc_cruise.throttle:Throttle``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.helpers import ACC_ENV, acc_installed, forget_acc, record_runs, run
from tracecheck.b.machine import load_machine, load_machine_text
from tracecheck.errors import InputError
from tracecheck.live.adapter import EnvAdapter
from tracecheck.live.continuous import NUDGES, ContinuousShield

THROTTLE = "acc_cruise.throttle:Throttle"
V1 = ACC_ENV / "acc_cruise" / "throttle_v1.mch"
V2 = ACC_ENV / "acc_cruise" / "throttle_v2.mch"
SPACE = gym.spaces.Box(low=-4.0, high=2.0, shape=(1,), dtype=np.float32)


class _Adapter(EnvAdapter):
    name = "t"
    actions = ("ACCELERATE",)
    parameters = {"ACCELERATE": ("a",)}
    fallback_action = (-4.0,)
    variables = ("Gap", "EgoSpeed", "LeadSpeed")


def _shield(mode="project", adapter=None, space=SPACE, scale=None, machine=None):
    return ContinuousShield(machine or load_machine(V1), adapter or _Adapter(), space,
                            mode=mode, scale=scale)


def _state(gap, ego, lead):
    return {"Gap": gap, "EgoSpeed": ego, "LeadSpeed": lead}


def _decide(shield, state):
    shield.decide(shield.machine.env(state))
    return shield


def _guard_allows(machine, state, a) -> bool:
    return bool(machine.evaluate("Gap + LeadSpeed - 1.0 - (EgoSpeed + a) > EgoSpeed + a",
                                 {**state, "a": a}))


# ------------------------------------------------------------------ the shield itself


def test_allowed_proposal_is_kept():
    shield = _decide(_shield(), _state(40.0, 20.0, 20.0))  # a < 9.5: all of [-4, 2]
    d = shield.filter([1.5])
    assert d.executed.tolist() == [1.5] and d.distance == 0.0
    assert not d.intervened and not d.deadlock
    assert shield.bands() == {"a": ((-4.0, 2.0),)}


def test_project_takes_the_nearest_allowed_action_confirmed_by_the_evaluator():
    state = _state(28.0, 20.0, 15.0)  # a < (28 + 15 - 1 - 40) / 2 = 1.0, open
    shield = _decide(_shield(), state)
    d = shield.filter([2.0])
    a = d.executed[0]  # the largest float32 (the space's type) the evaluator accepts
    assert a == float(np.nextafter(np.float32(1.0), np.float32(0.0)))
    assert _guard_allows(shield.machine, state, a)
    assert not _guard_allows(shield.machine, state, float(np.nextafter(np.float32(a),
                                                                       np.float32(2.0))))
    assert d.intervened and not d.deadlock and d.distance == pytest.approx(1.0, abs=1e-6)
    assert d.parameters == {"a": a} and d.proposal == {"a": 2.0}
    assert shield.bands() == {"a": ((-4.0, 1.0),)}


def test_a_proposal_outside_the_space_is_first_moved_into_it():
    shield = _decide(_shield(), _state(40.0, 20.0, 20.0))
    d = shield.filter(np.array([7.0]))
    assert d.proposal == {"a": 2.0} and d.executed.tolist() == [2.0] and d.distance == 0.0


def test_replace_takes_the_fallback_action():
    shield = _decide(_shield("replace"), _state(28.0, 20.0, 15.0))
    d = shield.filter([2.0])
    assert d.executed.tolist() == [-4.0] and d.intervened and not d.deadlock
    assert d.distance == pytest.approx(6.0)


def test_replace_with_the_fallback_refused_takes_the_allowed_action_nearest_it():
    """``replace`` where the guard refuses the fallback itself but allows other actions:
    the allowed action nearest the fallback is executed (confirmed by the evaluator), not
    the refused fallback, and the step is no deadlock (docs/continuous.md, the modes)."""
    machine = load_machine_text("""MACHINE Mid
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS
  ACCELERATE(a) = SELECT a : REAL & a > x THEN x := a END
END""")

    class Mid(_Adapter):
        fallback_action = (0.0,)
        variables = ("x",)

    shield = ContinuousShield(machine, Mid(), SPACE, mode="replace")
    shield.decide(machine.env({"x": 0.5}))
    d = shield.filter([-3.0])
    a = float(d.executed[0])
    assert not d.deadlock and d.intervened
    assert a == float(np.nextafter(np.float32(0.5), np.float32(2.0)))  # just above 0.5
    shield.decide(machine.env({"x": 3.0}))  # nothing in [-4, 2] allowed: a deadlock
    d = shield.filter([-3.0])
    assert d.deadlock and d.executed.tolist() == [0.0]


def test_nothing_allowed_fails_closed_with_the_fallback():
    shield = _decide(_shield(), _state(10.0, 20.0, 10.0))  # a < -10.5: outside [-4, 2]
    assert not shield.any_allowed()
    d = shield.filter([1.0])
    assert d.deadlock and d.executed.tolist() == [-4.0]
    assert shield.bands() == {"a": ()}


class _Two(EnvAdapter):
    name = "two"
    actions = ("MOVE",)
    parameters = {"MOVE": ("u", "v")}
    variables = ("x",)


def _two(guard: str):
    """A machine of one operation MOVE(u, v) whose guard is ``guard`` (state: ``x``)."""
    return load_machine_text(f"""MACHINE Two
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS
  MOVE(u, v) = PRE u : REAL & v : REAL & {guard} THEN skip END
END""")


def test_the_scale_weighs_the_components():
    machine = _two("u + 0.0 * x <= 0.0")
    space = gym.spaces.Box(low=-1.0, high=1.0, shape=(2,), dtype=np.float32)
    shield = _shield(adapter=_Two(), space=space, machine=machine, scale=(0.5, 1.0))
    shield.decide(machine.env({"x": 0.0}))
    d = shield.filter([0.5, 0.25])
    assert d.executed.tolist() == [0.0, 0.25] and d.distance == pytest.approx(1.0)  # 0.5 / 0.5


@pytest.mark.parametrize("dtype, allowed", [(np.float32, False), (np.float64, True)])
def test_a_float32_space_allows_nothing_where_only_other_floats_are_allowed(dtype, allowed):
    """a = 0.1 in a float32 space: the environment can take no allowed value, so nothing is
    allowed — what the shield says (``allowed`` empty) and does (the fallback) agree."""
    machine = load_machine_text("""MACHINE T VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL
INITIALISATION Gap, EgoSpeed, LeadSpeed := 0.0, 0.0, 0.0
OPERATIONS ACCELERATE(a) = PRE a : REAL & a = 0.1 + 0.0 * Gap THEN skip END END""")
    space = gym.spaces.Box(low=-4.0, high=2.0, shape=(1,), dtype=dtype)
    shield = _decide(_shield(machine=machine, space=space), _state(40.0, 20.0, 20.0))
    assert shield.any_allowed() == allowed
    d = shield.filter([1.0])
    assert d.deadlock == (not allowed)
    assert d.executed.tolist() == ([0.1] if allowed else [-4.0])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_decisions_numbers_are_numpys_to_the_bit(dtype):
    """The decision's proposal (clipped into the bounds), its distance and whether the
    shield intervened or the space rounded: computed over Python floats, they are what
    numpy's clip and norm give, to the bit, in one and two dimensions."""
    rng = np.random.default_rng(3)
    for n, machine_, adapter in ((1, load_machine(V1), _Adapter()),
                                 (2, _two("u + 0.5 * v <= x"), _Two())):
        low, high = (-4.0, 2.0) if n == 1 else (-1.0, 1.0)
        space = gym.spaces.Box(low=low, high=high, shape=(n,), dtype=dtype)
        scale = tuple(rng.uniform(0.1, 3.0, n).tolist())
        shield = _shield(adapter=adapter, space=space, machine=machine_, scale=scale)
        for _ in range(200):
            state = _state(*rng.uniform(0.0, 40.0, 3).tolist()) if n == 1 else \
                {"x": float(rng.uniform(-1.5, 1.5))}
            shield.decide(machine_.env(state))
            proposal = rng.uniform(low - 1.0, high + 1.0, n)
            d = shield.filter(proposal)
            clipped = np.clip(proposal, space.low.astype(np.float64),
                              space.high.astype(np.float64))
            assert list(d.proposal.values()) == clipped.tolist()
            assert np.signbit(list(d.proposal.values())).tolist() == \
                np.signbit(clipped).tolist()  # -0.0 at a bound 0.0 is numpy's 0.0
            as_sent = clipped.astype(dtype).astype(np.float64)
            assert d.cast == bool(np.any(as_sent != clipped))
            assert d.intervened == bool(np.any(d.executed != as_sent))
            expected = float(np.sqrt(np.sum(((d.executed - clipped) / np.array(scale)) ** 2)))
            assert d.distance == (expected if d.intervened else 0.0)


@pytest.mark.parametrize("change, message", [
    ({"parameters": {"ACCELERATE": ("b",)}}, "binds the components of its action to "
                                              "ACCELERATE(b), but the shield ThrottleShield "
                                              "has ACCELERATE(a)"),
    ({"fallback_action": (9.0,)}, "fallback_action = (9.0,); it must be 1 finite number(s) "
                                  "within the action space's bounds a ∈ [-4.0, 2.0]"),
])
def test_declarations_that_do_not_fit_are_refused(change, message):
    adapter = type("Bad", (_Adapter,), change)()
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]").replace(".", r"\.")):
        _shield(adapter=adapter)


def test_a_space_with_other_components_is_refused():
    space = gym.spaces.Box(low=-1.0, high=1.0, shape=(2,), dtype=np.float32)
    with pytest.raises(InputError, match=r"names 1 parameter\(s\) \(a\) for ACCELERATE, but "
                                         r"its action space .* has 2 component\(s\)"):
        _shield(space=space)
    with pytest.raises(InputError, match="not a one-dimensional Box"):
        _shield(space=gym.spaces.Discrete(3))
    with pytest.raises(InputError, match="not a one-dimensional Box"):
        _shield(space=gym.spaces.Box(-4.0, 2.0, (1, 1), np.float32))
    # integers: a projected 1.5 would reach the environment as 1, recorded as 1.5
    with pytest.raises(InputError, match=r"its action space Box\(-4, 2, \(1,\), int64\) takes "
                                         r"int64 values: the shield decides REAL ones") as e:
        _shield(space=gym.spaces.Box(-4, 2, (1,), np.int64))
    assert "give the environment a float Box" in e.value.hint
    if np.dtype(np.longdouble).itemsize > 8:  # float128 here: a header could not say it
        with pytest.raises(InputError, match="wider than the float64 values tracecheck"):
            _shield(space=gym.spaces.Box(-4.0, 2.0, (1,), np.longdouble))


def test_untyped_parameters_and_clashing_names_are_refused():
    untyped = load_machine_text("""MACHINE U
VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL
INITIALISATION Gap, EgoSpeed, LeadSpeed := 1.0, 1.0, 1.0
OPERATIONS ACCELERATE(a) = PRE a >= -4.0 THEN skip END
END""")
    with pytest.raises(InputError, match=r"must type each parameter REAL in its guard to "
                                         r"take a continuous action; `a : REAL` is not in "
                                         r"it") as e:
        _shield(machine=untyped)
    assert e.value.hint == ("add `a : REAL` to its guard (PRE a : REAL & …); an INTEGER "
                            "choice is a discrete action")
    assert e.value.line == 5  # the operation's line
    with pytest.raises(InputError, match=r"--scale takes 1 positive number\(s\)"):
        _shield(scale=(0.0,))


@settings(max_examples=60, deadline=None)
@given(gap=st.floats(0.0, 80.0), ego=st.floats(0.0, 40.0), lead=st.floats(0.0, 40.0),
       proposal=st.floats(-10.0, 10.0), mode=st.sampled_from(["project", "replace"]))
def test_every_executed_action_is_allowed_or_the_recorded_fallback(gap, ego, lead, proposal,
                                                                    mode):
    shield = _decide(_shield(mode), _state(gap, ego, lead))
    d = shield.filter([proposal])
    a = float(d.executed[0])
    assert -4.0 <= a <= 2.0
    if d.deadlock:
        assert a == -4.0
        bound = (gap + lead - 1.0 - 2 * ego) / 2  # over the reals; the evaluator's floats agree
        assert mode == "replace" or bound <= -4.0 + 1e-9
    else:
        assert _guard_allows(shield.machine, _state(gap, ego, lead), a)
        clipped = min(max(proposal, -4.0), 2.0)
        if mode == "project":  # nothing allowed lies nearer than the executed action …
            grid = np.linspace(-4.0, 2.0, 601)
            ok = [g for g in grid if _guard_allows(shield.machine, _state(gap, ego, lead), g)]
            # … up to the float32 rounding of what is sent (at most NUDGES float32 steps)
            tol = 1e-9 + NUDGES * float(np.spacing(np.float32(max(abs(clipped), abs(a)))))
            assert all(abs(g - clipped) >= abs(a - clipped) - tol for g in ok)


# ------------------------------------------------------------------ recording


@pytest.fixture(scope="module")
def throttle(tmp_path_factory):
    """A PPO file that always proposes full throttle (+2), and runs of it: unshielded, under
    v1 projected, under v1 replaced; the throttle environment installed meanwhile."""
    folder = tmp_path_factory.mktemp("throttle")
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        from acc_cruise.throttle import make_agent

        agent = make_agent(folder / "full.zip", 2.0)
        runs = record_runs(folder, THROTTLE, agent, {
            "none": ("none", []), "v1": (V1, []),
            "replace": (V1, ["--shield-mode", "replace"])})
    forget_acc()
    return agent, runs


def test_recorded_steps_keep_proposal_execution_distance_and_band(throttle):
    from tracecheck.episodes.reader import read_header, read_run

    _, runs = throttle
    header = read_header(runs["v1"])
    assert header.action_parameters == {"ACCELERATE": ["a"]}
    assert header.action_low == [-4.0] and header.action_high == [2.0]
    assert header.shield_mode == "project" and header.projection_scale == [1.0]
    machine = load_machine(V1)
    episodes = list(read_run(runs["v1"]).episodes)
    assert not any(e.end.crashed for e in episodes)
    moved = 0
    for e in episodes:
        for before, s in zip(e.steps, e.steps[1:]):
            assert s.action == "ACCELERATE" and s.proposal == {"a": 2.0}
            a = s.parameters["a"]
            assert s.projection_distance == pytest.approx(2.0 - a)
            if s.deadlock:
                assert a == -4.0 and s.allowed_actions == ()
                continue
            assert _guard_allows(machine, before.state, a)
            (low, high), = s.allowed_intervals["a"]
            assert low == -4.0 and low <= a <= high
            moved += a < 2.0
    assert moved > 10


def test_unshielded_full_throttle_crashes_and_the_shield_prevents_it(throttle):
    from tracecheck.episodes.reader import read_run

    _, runs = throttle
    none = list(read_run(runs["none"]).episodes)
    assert all(e.end.crashed for e in none)
    assert all(s.parameters == {"a": 2.0} and s.projection_distance == 0.0
               for e in none for s in e.steps[1:])
    replaced = list(read_run(runs["replace"]).episodes)
    assert not any(e.end.crashed for e in replaced)
    assert {s.parameters["a"] for e in replaced for s in e.steps[1:]} == {2.0, -4.0}


def test_continuous_options_are_refused_for_discrete_actions(capsys, acc_env, acc_agent,
                                                             tmp_path):
    code, _, err = run(capsys, "record", "--env", "acc", "--agent", acc_agent, "--shield",
                       "none", "-n", "1", "--shield-mode", "replace", "-o", tmp_path / "x.mcap")
    assert code == 2 and "--shield-mode and --scale are for continuous actions" in err
    code, _, err = run(capsys, "record", "--env", "acc", "--agent", acc_agent, "--shield",
                       "none", "-n", "1", "--shield-mode", "sideways", "-o",
                       tmp_path / "x.mcap")
    assert code == 2 and "--shield-mode 'sideways': give one of project, replace" in err


def test_agents_of_the_other_kind_are_refused(capsys, acc_env, acc_agent, throttle, tmp_path):
    agent, _ = throttle
    code, _, err = run(capsys, "record", "--env", "acc", "--agent", agent, "--shield", "none",
                       "-n", "1", "-o", tmp_path / "x.mcap")
    assert code == 2 and "acc has 3 discrete actions (KEEP, ACCEL, BRAKE)" in err
    code, _, err = run(capsys, "record", "--env", THROTTLE, "--agent", acc_agent, "--shield",
                       "none", "-n", "1", "-o", tmp_path / "x.mcap")
    assert code == 2 and "throttle takes continuous actions" in err
    assert not (tmp_path / "x.mcap").exists()


def test_a_shield_without_the_parameters_is_refused_before_any_episode(capsys, acc_env,
                                                                       throttle, tmp_path):
    agent, _ = throttle
    code, _, err = run(capsys, "record", "--env", THROTTLE, "--agent", agent, "--shield",
                       ACC_ENV / "acc_cruise" / "acc_v2.mch", "-n", "1",
                       "-o", tmp_path / "x.mcap")
    assert code == 2 and "lacks ACCELERATE" in err
    assert not (tmp_path / "x.mcap").exists()


def test_resimulation_reapplies_the_vectors_then_projects(capsys, acc_env, throttle):
    agent, runs = throttle
    code, out, err = run(capsys, "replay", runs["none"], "--shield", V1, "--resimulate",
                         "--agent", agent, "--env", THROTTLE, "--json")
    assert code == 0, err
    import json

    resim = json.loads(out)["resimulation"]
    assert resim["resimulated"] == 4 and resim["mismatches"] == 0
    assert resim["crashes_prevented"] == 4  # full throttle, projected, no longer crashes


# ------------------------------------------------------------------ training


def test_train_sac_under_the_shield_projects_and_says_so(capsys, acc_env, tmp_path):
    import json

    out = tmp_path / "sac.zip"
    code, said, err = run(capsys, "train", "--env", THROTTLE, "--env-config", "max_steps=20",
                          "--shield", V1, "--steps", "120", "--intervention-penalty", "0.5",
                          "--scale", "2", "-o", out)
    assert code == 0, err
    assert "(SAC on throttle under shield throttle_v1, actions projected, 120 steps" in \
        " ".join(said.split())
    card = json.loads(out.with_suffix(".json").read_text())
    assert card["algorithm"] == "SAC" and card["shielding"] == "projected"
    assert card["intervention_penalty"] == 0.5
    assert card["projection_scale"] == [2.0]  # the units its distances were measured in
    from tracecheck.live.agents import load_agent

    assert load_agent(out).continuous and load_agent(out).algorithm == "SAC"


@pytest.mark.parametrize("env, algorithm, message", [
    (THROTTLE, "dqn", "--algorithm dqn does not fit throttle, which takes continuous actions"),
    ("acc", "sac", "--algorithm sac does not fit acc, which takes discrete actions"),
    (THROTTLE, "q-learning", "--algorithm q-learning chooses among discrete actions"),
])
def test_train_refuses_an_algorithm_for_the_other_kind(capsys, acc_env, tmp_path, env,
                                                       algorithm, message):
    code, _, err = run(capsys, "train", "--env", env, "--algorithm", algorithm, "--steps", "50",
                       "-o", tmp_path / "a.zip")
    assert code == 2 and message in " ".join(err.split())
    assert not (tmp_path / "a.zip").exists()


def test_the_penalty_needs_a_shield(capsys, acc_env, tmp_path):
    code, _, err = run(capsys, "train", "--env", THROTTLE, "--steps", "50",
                       "--intervention-penalty", "1", "-o", tmp_path / "a.zip")
    assert code == 2 and "needs continuous actions and --shield" in err


class Unbounded(EnvAdapter):
    """The throttle environment with an action space that has no bounds (the shield's
    guard bounds the action instead)."""

    name = "unbounded"
    actions = ("ACCELERATE",)
    parameters = {"ACCELERATE": ("a",)}
    fallback_action = (-4.0,)
    variables = ("Gap", "EgoSpeed", "LeadSpeed")
    horizon = 30

    def make_env(self, config, render_mode=None):
        from acc_cruise.throttle import ThrottleEnv

        env = ThrottleEnv(**config)
        env.action_space = gym.spaces.Box(-np.inf, np.inf, shape=(1,), dtype=np.float64)
        return env

    def state(self, obs, info, reward, env, initial):
        return dict(zip(self.variables, (float(x) for x in obs)))

    def crashed(self, obs, reward, terminated, info):
        return bool(info.get("crash", False))


def test_an_action_space_without_bounds_records_them_as_none(capsys, acc_env, throttle,
                                                             tmp_path):
    from tracecheck.episodes.reader import read_header, read_run

    agent, _ = throttle  # proposes +2: allowed at first, projected once the gap closes
    out = tmp_path / "unbounded.mcap"
    code, _, err = run(capsys, "record", "--env", f"{__name__}:Unbounded", "--agent", agent,
                       "--shield", V1, "-n", "2", "-o", out)
    assert code == 0, err
    header = read_header(out)
    assert header.action_low == [None] and header.action_high == [None]
    steps = [s for e in read_run(out).episodes for s in e.steps[1:]]
    assert any(s.parameters["a"] < 2.0 for s in steps) and not any(s.crashed for s in steps)


def test_a_guard_that_allows_nothing_within_the_space_is_refused_before_any_episode():
    outside = load_machine_text("""MACHINE Out
VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL
INITIALISATION Gap, EgoSpeed, LeadSpeed := 1.0, 1.0, 1.0
OPERATIONS ACCELERATE(a) = PRE a : REAL & a >= 5.0 & a <= 9.0 & Gap > 0.0 THEN skip END
END""")
    with pytest.raises(InputError, match=r"the guard of ACCELERATE in Out allows only a ∈ "
                                         r"\[5\.0, 9\.0\], none of it within the action "
                                         r"space's bounds a ∈ \[-4\.0, 2\.0\]: no action"):
        _shield(machine=outside)
    _shield(machine=load_machine(V2))  # [-4, 2] itself: fine


def test_envs_lists_each_continuous_action_with_its_parameters(capsys):
    code, out, _ = run(capsys, "envs")
    assert code == 0 and "actions: DRIVE(acceleration, steering)" in out
    assert "actions: FIRE(main, lateral)" in out
    code, out, _ = run(capsys, "envs", "--json")
    import json

    rows = {r["name"]: r for r in json.loads(out)}
    assert rows["highway-continuous"]["parameters"] == {"DRIVE": ["acceleration", "steering"]}
    assert "parameters" not in rows["highway"]


def test_the_viewer_blocks_the_steps_replay_finds_infeasible(throttle):
    from tracecheck.checking.replaying import replay
    from tracecheck.checking.shield import load_shield
    from tracecheck.render.viewer import episode_data

    _, runs = throttle
    shield = load_shield(V1)
    report = replay([runs["none"]], shield)
    for e in report.per_episode:
        data = episode_data(runs["none"], e.episode, shield)
        assert data["first_infeasible"] == e.first_infeasible is not None
        assert len(data["blocked"]) == e.infeasible_steps


QUADRATIC = """MACHINE Quad
VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL
INITIALISATION Gap, EgoSpeed, LeadSpeed := 1.0, 1.0, 1.0
OPERATIONS ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 &
    Gap > (EgoSpeed + a) * (EgoSpeed + a) THEN skip END
END"""


def test_a_guard_not_linear_in_its_parameters_is_decided_by_the_solver():
    shield = _shield(machine=load_machine_text(QUADRATIC))
    assert shield.ops["ACCELERATE"].solver
    _decide(shield, _state(4.0, 1.0, 1.0))  # (1 + a)² < 4: -3 < a < 1
    assert str(shield.allowed) == "a: not linear; decided by the solver (searched within the action space: a ∈ [-4.0, 2.0])"
    d = shield.filter([2.0])  # projected to just below 1, confirmed by the evaluator
    assert d.intervened and not d.deadlock and 0.999 < d.parameters["a"] < 1.0
    assert shield.machine.allows("ACCELERATE", _state(4.0, 1.0, 1.0), d.parameters)
    d = shield.filter([-4.0])
    assert -3.0 < d.parameters["a"] < -2.999 and not d.deadlock
    assert shield.filter([0.5]).parameters == {"a": 0.5}
    _decide(shield, _state(0.0, 1.0, 1.0))  # nothing is allowed: the solver proves it
    assert not shield.any_allowed() and shield.problem is None
    d = shield.filter([1.0])
    assert d.deadlock and d.parameters == {"a": -4.0}


def test_a_guard_neither_linear_nor_translatable_is_refused_before_any_episode():
    member = load_machine_text(QUADRATIC.replace(
        "Gap > (EgoSpeed + a) * (EgoSpeed + a)", "a : {1.0, 2.0}"))
    with pytest.raises(InputError, match=r"the shield Quad cannot decide ACCELERATE's "
                                         r"continuous actions: .*; nor can the solver: .*cannot "
                                         r"translate this membership to SMT"):
        _shield(machine=member)


def test_prob2trace_keeps_the_values_and_formats_without_a_place_refuse(capsys, throttle,
                                                                        tmp_path):
    """A ProB2 trace keeps each step's parameter values (its transitions' params), so the
    imported episode replays as the recording; SimB and Minari exports refuse a continuous
    run rather than drop them."""
    import json

    _, runs = throttle
    trace = tmp_path / "ep0.prob2trace"
    code, _, err = run(capsys, "export", "prob2trace", runs["none"], "--episode", "0", "-o",
                       trace)
    assert code == 2 and "a ProB2 trace has no place for the crash" in err  # issue 42: dropped
    assert not trace.exists()
    code, _, err = run(capsys, "export", "prob2trace", runs["none"], "--episode", "0", "-o",
                       trace, "--lossy")
    assert code == 0, err
    assert "note: a ProB2 trace has no place for the agent's proposals" in err
    doc = json.loads(trace.read_text())
    assert doc["transitionList"][2]["params"] == {"a": "2.0"}
    assert doc["machineOperationInfos"]["ACCELERATE"]["parameterNames"] == ["a"]
    back = tmp_path / "back.mcap"
    code, _, err = run(capsys, "import", "prob2trace", trace, "--model", V1, "-o", back)
    assert code == 0, err
    _, out, _ = run(capsys, "replay", back, "--shield", V1, "--json")
    _, original, _ = run(capsys, "replay", runs["none"], "--shield", V1, "--json")
    got, want = json.loads(out)["per_episode"][0], json.loads(original)["per_episode"][0]
    for key in ("first_infeasible", "infeasible_steps", "parameters", "margin", "max_margin"):
        assert got[key] == want[key], key
    code, _, err = run(capsys, "export", "simb", runs["none"], "-o", tmp_path / "simb")
    assert code == 2 and "which a SimB timed trace has no place for" in " ".join(err.split())
    assert not (tmp_path / "simb").exists()


def test_record_says_how_often_the_shield_allowed_nothing(capsys, acc_env, throttle, tmp_path):
    agent, runs = throttle
    from tracecheck.episodes.reader import read_run

    fallbacks = sum(bool(s.deadlock) for e in read_run(runs["v1"]).episodes for s in e.steps)
    assert fallbacks  # full throttle from a short gap: nothing allowed at some steps
    code, out, err = run(capsys, "record", "--env", THROTTLE, "--env-config", "max_steps=40",
                         "--agent", agent, "--shield", V1, "-n", "4", "-o", tmp_path / "a.mcap")
    assert code == 0, err
    assert (f"{fallbacks} step(s) where the shield allowed nothing and the fallback was taken"
            in " ".join(out.split()))


def test_info_names_the_continuous_actions_and_the_mode(capsys, throttle):
    _, runs = throttle
    code, out, _ = run(capsys, "info", runs["replace"])
    assert code == 0 and "continuous: ACCELERATE(a), shield mode replace, scale 1" in out
    code, out, _ = run(capsys, "info", runs["none"], "--json")
    import json

    assert json.loads(out)["files"][0]["continuous"].startswith("ACCELERATE(a)")


def test_a_float32_space_gets_a_value_the_guard_allows_as_it_is_sent():
    """3 a <= Gap: the nearest allowed a is 1/3 as a float64, which rounds up in float32 to
    a value the guard refuses; what is executed (and recorded) is the float32 below it."""
    third = load_machine_text("""MACHINE Third
VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL
INITIALISATION Gap, EgoSpeed, LeadSpeed := 1.0, 1.0, 1.0
OPERATIONS ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 & 3.0 * a <= Gap
    THEN skip END
END""")
    shield = _decide(_shield(machine=third), _state(1.0, 1.0, 1.0))
    d = shield.filter([0.9])
    a = d.executed[0]
    assert np.float32(a) == a and 3.0 * a <= 1.0  # a float32, allowed as it is
    assert a == float(np.nextafter(np.float32(1 / 3), np.float32(0)))
    assert d.parameters == {"a": a} and not d.deadlock


def test_replace_with_a_refused_fallback_takes_the_allowed_action_nearest_it():
    state = _state(28.0, 20.0, 15.0)  # a < 1.0: the fallback -4 is allowed
    narrow = load_machine_text(load_machine(V1).source.replace("a >= -4.0", "a >= -1.0"))
    shield = _decide(_shield("replace", machine=narrow), state)  # now -4 is refused
    d = shield.filter([2.0])
    assert not d.deadlock and d.executed[0] == -1.0  # the allowed action nearest -4


def test_a_q_table_and_a_penalty_that_is_not_finite_are_refused(capsys, acc_env, tmp_path):
    table = tmp_path / "q.npy"
    np.save(table, np.zeros((4, 1)))
    code, _, err = run(capsys, "record", "--env", THROTTLE, "--agent", table, "--shield",
                       "none", "-n", "1", "-o", tmp_path / "a.mcap")
    assert code == 2 and "a Q-table chooses among discrete actions" in err
    code, _, err = run(capsys, "train", "--env", THROTTLE, "--shield", V1, "--steps", "50",
                       "--intervention-penalty", "nan", "-o", tmp_path / "a.zip")
    assert code == 2 and "give a finite number" in err


def test_a_projected_float32_action_counts_as_on_the_boundary(capsys, throttle):
    """The shield sends the float32 value the guard allows, a few float32 steps inside the
    exact end it records: the statistics still see it on the boundary."""
    import json

    from tracecheck.episodes.reader import read_run

    _, runs = throttle
    projected = sum(1 for e in read_run(runs["v1"]).episodes for s in e.steps[1:]
                    if s.parameters["a"] < 2.0 and not s.deadlock)
    assert projected > 10
    code, out, err = run(capsys, "stats", runs["v1"], "--json")
    assert code == 0, err
    boundary = json.loads(out)["runs"][0]["continuous"]["boundary"]
    assert boundary["count"] == projected


def test_a_float64_proposal_the_space_rounds_is_no_intervention():
    """0.3 as float64 reaches a float32 space as 0.30000001…: allowed, so the shield did
    not intervene (it used to say replaced, distance 1.19e-8); the rounding is recorded."""
    shield = _decide(_shield(), _state(40.0, 20.0, 20.0))
    d = shield.filter(np.array([0.3]))
    assert not d.intervened and d.distance == 0.0 and d.cast and not d.deadlock
    assert d.executed.tolist() == [float(np.float32(0.3))] and d.proposal == {"a": 0.3}
    exact = shield.filter(np.array([0.5]))  # a float32 value: nothing rounded
    assert not exact.intervened and not exact.cast
    moved = _decide(_shield(), _state(28.0, 20.0, 15.0)).filter(np.array([1.7]))
    assert moved.intervened and moved.distance == pytest.approx(0.7, abs=1e-6)
