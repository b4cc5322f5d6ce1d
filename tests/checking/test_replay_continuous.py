"""Replay of continuous actions: a step of an operation with REAL parameters is feasible when
its guard holds in the state before with the recorded values bound (one batch evaluation);
an infeasible one says how far outside the allowed values it lay (the margin)."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.helpers import run
from tracecheck.b import load_machine_text
from tracecheck.b.linear import allowed_set
from tracecheck.checking.replaying import replay, replay_columns
from tracecheck.checking.shield import load_shield
from tracecheck.episodes import new_header, read_columns
from tracecheck.episodes.columns import episode_columns
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.errors import InputError, UnsupportedError

#: adaptive cruise control: accelerate by a (m/s²) while the gap stays over 10 m at a
#: headway of 1.5 s; IDLE keeps the speed
ACC = """MACHINE Acc
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL
INITIALISATION Gap, Speed := 50.0, 20.0
OPERATIONS
  ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 & Gap - (Speed + a) * 1.5 > 10.0
                  THEN Speed := Speed + a END;
  IDLE = SELECT Gap > 10.0 THEN skip END
END
"""
ACTIONS = ["ACCELERATE", "IDLE"]


@pytest.fixture(scope="module")
def acc(tmp_path_factory):
    path = tmp_path_factory.mktemp("shield") / "acc.mch"
    path.write_text(ACC)
    return load_shield(path)


def s(gap: float, speed: float) -> dict:
    return {"Gap": gap, "Speed": speed}


def make(eid: int, start: dict, moves) -> Episode:
    """From ``start``, each move (action, parameters or None, state after)."""
    steps = [StepRecord(0, 0.0, None, start, 0.0, False)]
    for k, (action, params, after) in enumerate(moves, 1):
        steps.append(StepRecord(k, float(k), action, after, 1.0, False, parameters=params))
    steps = tuple(steps)
    return Episode(eid, steps, make_end(steps), seed=eid)


def episodes() -> list[Episode]:
    return [
        # at 40.45 and 20: a < 0.3 allowed ((40.45 - 10) / 1.5 - 20 = 0.3), so 1.5 is 1.2
        # outside; at 21.5, -4.0 is allowed; at 17.5, a < 2.8 and a <= 2.0: 2.0 is allowed
        make(0, s(40.45, 20.0), [("ACCELERATE", {"a": 1.5}, s(40.45, 21.5)),
                                 ("ACCELERATE", {"a": -4.0}, s(40.45, 17.5)),
                                 ("IDLE", None, s(40.45, 17.5)),
                                 ("ACCELERATE", {"a": 2.0}, s(40.45, 19.5))]),
        # every step allowed, the speed following a as the machine says
        make(1, s(60.0, 20.0), [("ACCELERATE", {"a": 1.0}, s(60.0, 21.0)),
                                ("ACCELERATE", {"a": -0.5}, s(60.0, 20.5))]),
        # nothing allowed: the gap is too short for any a (a deadlock for ACCELERATE alone)
        make(2, s(12.0, 20.0), [("ACCELERATE", {"a": -4.0}, s(12.0, 17.0))]),
    ]


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("runs") / "acc.mcap"
    write_run(path, new_header("recorded", actions=ACTIONS,
                               action_parameters={"ACCELERATE": ["a"]}, action_low=[-4.0],
                               action_high=[2.0], shield_mode="project"), episodes())
    return path


def test_infeasible_steps_and_their_margins(acc, run_file):
    report = replay([run_file], acc)
    e0, e1, e2 = report.per_episode
    assert (e0.first_infeasible, e0.action, e0.infeasible_steps) == (1, "ACCELERATE", 1)
    assert e0.parameters == {"a": 1.5}
    assert re.fullmatch(r"a ∈ \[-4\.0, 0\.(3|29+)\d*…?\)", e0.allowed), e0.allowed
    assert e0.margin == pytest.approx(1.2, abs=1e-9)
    assert e0.max_margin == e0.margin  # the episode's only infeasible step
    assert e0.enabled == ["ACCELERATE", "IDLE"]  # some value of a was allowed there
    assert e1.first_infeasible is None and e1.infeasible_steps == 0
    assert e1.parameters is e1.margin is e1.max_margin is None
    assert e1.postcondition_violations == []  # Speed := Speed + a with a as recorded
    assert e2.first_infeasible == 1 and e2.allowed == "a ∈ ∅"
    assert e2.margin is None and e2.margin_note == "nothing allowed"
    assert e2.max_margin is None
    assert e2.postcondition_violations == [1]  # 20 - 4 is not 17
    assert (report.infeasible_steps, report.infeasible_episodes) == (2, 2)
    data = report.to_json()["per_episode"][0]
    assert data["parameters"] == {"a": 1.5} and data["allowed"] == e0.allowed
    assert (data["margin"], data["max_margin"]) == (e0.margin, e0.max_margin)


def test_a_recorded_value_outside_is_infeasible_though_some_value_is_allowed(acc, run_file):
    """Feasibility is the guard with the recorded values, not "some value allowed"."""
    cols = read_columns(run_file)
    report = replay_columns(cols, acc)
    first = report.per_episode[0]
    before = cols.states.row(0)
    assert acc.machine.is_enabled("ACCELERATE", before)  # ∃ a: the enabled set has it …
    assert first.first_infeasible == 1  # … but 1.5 is not allowed


def test_the_largest_margin_of_an_episode(acc, tmp_path):
    ep = make(0, s(40.375, 20.0), [("ACCELERATE", {"a": 1.5}, s(40.375, 21.5)),
                                   ("ACCELERATE", {"a": 2.0}, s(40.375, 23.5))])
    report = replay_columns(episode_columns([ep], ACTIONS), acc)
    e = report.per_episode[0]
    # a < 0.25 at speed 20, a < -1.25 at 21.5 (exact in binary: margins 1.25 and 3.25)
    assert e.allowed == "a ∈ [-4.0, 0.25)"
    assert e.margin == pytest.approx(1.25, abs=1e-9)
    assert e.max_margin == pytest.approx(3.25, abs=1e-9)


def test_the_text_report_shows_the_first_continuous_action(capsys, run_file, tmp_path):
    shield = tmp_path / "acc.mch"
    shield.write_text(ACC)
    code, out, _ = run(capsys, "replay", run_file, "--shield", shield)
    assert code == 0
    text = " ".join(out.split())
    assert re.search(r"episode 0, step 1: ACCELERATE\(a=1\.5\): a ∈ \[-4\.0, 0\.(3|29+)\d*…?\), "
                     r"1\.2 from the nearest allowed value", text), out
    assert "episode 2, step 1: ACCELERATE(a=-4): a ∈ ∅, nothing allowed" in text
    code, out, _ = run(capsys, "replay", run_file, "--shield", shield, "--json")
    data = json.loads(out)["per_episode"]
    assert data[0]["margin"] == pytest.approx(1.2, abs=1e-9)
    assert data[2]["margin_note"] == "nothing allowed"


def test_a_discrete_report_has_no_continuous_lines(capsys, tmp_path):
    """A run of discrete actions reads as before (no line, no column of parameters)."""
    ep = make(0, s(40.0, 20.0), [("IDLE", None, s(9.0, 20.0)), ("IDLE", None, s(9.0, 20.0))])
    path = tmp_path / "run.mcap"
    write_run(path, new_header("recorded", actions=ACTIONS), [ep])
    shield = tmp_path / "acc.mch"
    shield.write_text(ACC)
    code, out, _ = run(capsys, "replay", path, "--shield", shield)
    assert code == 0 and "episodes that matter" in out and "continuous" not in out
    code, out, _ = run(capsys, "replay", path, "--shield", shield, "--format", "csv")
    assert "parameters" not in out.splitlines()[0]


def test_a_step_without_its_parameters_is_an_input_error(acc, tmp_path):
    ep = make(4, s(60.0, 20.0), [("ACCELERATE", {"a": 1.0}, s(60.0, 21.0)),
                                 ("ACCELERATE", None, s(60.0, 21.0))])
    path = tmp_path / "run.mcap"
    write_run(path, new_header("recorded", actions=ACTIONS), [ep])
    with pytest.raises(InputError) as info:
        replay([path], acc)
    assert info.value.message == (f"{path}, episode 4, step 2: the recorded action ACCELERATE "
                                  "has no value for its parameter a")


def test_a_file_without_any_parameters_is_an_input_error(acc, tmp_path):
    ep = make(0, s(60.0, 20.0), [("ACCELERATE", None, s(60.0, 21.0))])
    with pytest.raises(InputError) as info:
        replay_columns(episode_columns([ep], ACTIONS), acc)
    assert info.value.message == ("<memory>, episode 0, step 1: the recorded action ACCELERATE "
                                  "has no value for its parameter a")
    assert "parameters" in info.value.hint


def test_a_parameter_named_like_a_state_variable_is_refused(acc):
    start = {**s(60.0, 20.0), "a": 0.0}  # the states carry a variable a
    ep = make(0, start, [("ACCELERATE", {"a": 1.0}, {**s(60.0, 21.0), "a": 0.0})])
    with pytest.raises(InputError, match=r"^<memory>: the parameter a of ACCELERATE in the "
                                         r"shield acc has the name of a state variable"):
        replay_columns(episode_columns([ep], ACTIONS), acc)


# ------------------------------------------------------------------ the batch answer is the
# state-by-state answer, for random linear guards in one and two parameters

NUM = st.integers(-6, 6).map(float) | st.sampled_from([0.5, -1.25, 0.1, 1 / 3])
REL = st.sampled_from(["<", "<=", ">", ">=", "/=", "="])


@st.composite
def linear_atom(draw, params):
    terms = " + ".join(f"({draw(NUM)}) * {p}" for p in params if draw(st.booleans())) or "0.0"
    return f"{terms} + u * ({draw(NUM)}) {draw(REL)} v + ({draw(NUM)})"


@st.composite
def guard(draw, params, depth=2):
    """A Boolean combination of linear atoms, each naming one parameter (the engine decides
    whether some values are allowed only for those, see tracecheck.b.linear)."""
    if depth == 0 or draw(st.integers(0, 2)) == 0:
        return draw(linear_atom((draw(st.sampled_from(params)),)))
    op = draw(st.sampled_from(["&", "or", "=>"]))
    text = f"({draw(guard(params, depth - 1))}) {op} ({draw(guard(params, depth - 1))})"
    return f"not({text})" if draw(st.booleans()) else text


VALUE = st.integers(-24, 24).map(lambda k: k / 4) | st.floats(-8, 8, allow_nan=False)


def act_machine(text: str, params: tuple[str, ...]):
    typed = " & ".join(f"{p} : REAL" for p in params)
    return load_machine_text(f"""MACHINE G
VARIABLES u, v
INVARIANT u : REAL & v : REAL
INITIALISATION u, v := 0.0, 0.0
OPERATIONS Act({", ".join(params)}) = PRE {typed} & ({text}) THEN skip END
END""")


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([("a",), ("a", "b")]).flatmap(
    lambda ps: st.tuples(st.just(ps), guard(ps),
                         st.lists(st.tuples(NUM, NUM, st.tuples(VALUE, VALUE)),
                                  min_size=1, max_size=12))))
def test_the_batch_answer_is_the_state_by_state_answer(case):
    params, text, rows = case
    from tracecheck.checking.shield import Shield

    machine = act_machine(text, params)
    shield = Shield(name="G", sha256="0" * 64, path="G.mch", machine=machine)
    # one step an episode: step 1's answer is the row's
    eps = [make(i, {"u": u, "v": v}, [("Act", dict(zip(params, point)), {"u": u, "v": v})])
           for i, (u, v, point) in enumerate(rows)]
    try:
        report = replay_columns(episode_columns(eps, ["Act"]), shield)
    except UnsupportedError as exc:  # cannot tell: the scalar path cannot tell either
        assert any(_undecided(machine, {"u": u, "v": v}) for u, v, _ in rows), exc
        return
    for e, (u, v, point) in zip(report.per_episode, rows):
        values = dict(zip(params, point))
        allowed = allowed_set(machine, "Act", {"u": u, "v": v})
        assert (e.first_infeasible is None) == allowed.contains(values), (text, u, v, values)
        if e.first_infeasible is None:
            continue
        assert e.parameters == values
        nearest = allowed.nearest(values)
        if nearest is None:  # no float allowed: the distance over the reals, or none said
            exact = allowed.distance(values)
            assert (e.margin is None and e.margin_note) if not exact else \
                e.margin == pytest.approx(exact, rel=1e-9)
        else:  # over the reals, to the closure; on an open end, to the nearest float
            exact = allowed.distance(values)
            nearest_d = math.dist([nearest[p] for p in params], [values[p] for p in params])
            want = exact if exact else nearest_d
            assert e.margin == pytest.approx(want, rel=1e-12) and e.max_margin == e.margin
            assert 0 < e.margin <= nearest_d + 1e-9  # the reals hold every allowed float


def _undecided(machine, state: dict) -> bool:
    """Whether the scalar path refuses to say if the state's operation is enabled (its
    allowed set is non-empty over the reals, and no float in it could be found)."""
    try:
        machine.enabled(state)
    except UnsupportedError:
        return True
    return False


def test_many_steps_in_one_batch(acc):
    """A long episode of random accelerations: every step's answer is the evaluator's."""
    rng = np.random.default_rng(7)
    state, moves = s(40.0, 20.0), []
    for _ in range(300):
        after = s(float(rng.uniform(11, 80)), float(rng.uniform(0, 30)))
        moves.append(("ACCELERATE", {"a": float(rng.uniform(-5, 3))}, after))
    ep = make(0, state, moves)
    report = replay_columns(episode_columns([ep], ACTIONS), acc)
    machine = acc.machine
    bad = [k for k in range(1, len(ep.steps))
           if not machine.allowed("ACCELERATE", ep.steps[k - 1].state).contains(
               ep.steps[k].parameters)]
    e = report.per_episode[0]
    assert e.infeasible_steps == len(bad) and e.first_infeasible == bad[0]


def test_diff_decides_continuous_actions_as_replay_does(acc, run_file, tmp_path):
    """Under a headway of 1.0 s, a = 1.5 at gap 40.45 and speed 20 is allowed; under acc's
    1.5 s it is not: diff finds that one step, though both enable ACCELERATE there."""
    from tracecheck.checking.diffing import diff

    path = tmp_path / "loose.mch"
    path.write_text(ACC.replace("* 1.5 > 10.0", "* 1.0 > 10.0"))
    loose = load_shield(path)
    report = diff([run_file], acc, loose)
    assert (report.changed_steps, report.newly_blocked, report.newly_allowed) == (1, 1, 0)
    change = report.changes[0]
    assert (change.episode, change.step, change.action) == (0, 1, "ACCELERATE")
    assert not change.feasible_under_shield and change.feasible_under_against
    assert replay([run_file], loose).per_episode[0].first_infeasible is None
    assert diff([run_file], acc, acc).changed_steps == 0


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([("a",), ("a", "b")]).flatmap(
    lambda ps: st.tuples(st.just(ps), guard(ps),
                         st.lists(st.tuples(NUM, NUM, st.tuples(VALUE, VALUE)),
                                  min_size=1, max_size=12))))
def test_deadlocks_found_with_the_recorded_values_are_the_state_by_state_ones(case):
    """Replay tries the recorded values first ("some value allowed" confirmed in one batch
    evaluation) and decides the other states one by one: the deadlock states are those of
    the scalar decision, whichever values were recorded."""
    params, text, rows = case
    from tracecheck.checking.shield import Shield

    machine = act_machine(text, params)
    shield = Shield(name="G", sha256="0" * 64, path="G.mch", machine=machine)
    states = [{"u": u, "v": v} for u, v, _ in rows]
    ep = make(0, states[0], [("Act", dict(zip(params, point)), after)
                             for (_, _, point), after in zip(rows, states[1:] + states[:1])])
    try:
        report = replay_columns(episode_columns([ep], ["Act"]), shield)
    except UnsupportedError:  # undecided in a state: so is the scalar decision there
        with pytest.raises(UnsupportedError, match="undecided"):
            for st_ in ep.steps:
                machine.enabled(st_.state)
        return
    scalar = [k for k, st_ in enumerate(ep.steps) if "Act" not in machine.enabled(st_.state)]
    assert report.per_episode[0].deadlock_states == scalar, text


FAR = """MACHINE Far
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL
INITIALISATION Gap, Speed := 50.0, 20.0
OPERATIONS
  ACCELERATE(a) = PRE a : REAL & a > Gap - 50.0 THEN skip END
END
"""


@pytest.mark.parametrize("bounded", [True, False])
def test_replay_keeps_the_actions_within_the_run_headers_action_space(tmp_path, bounded):
    """The live shield allows only actions within the action space: where the guard allows
    values outside it alone, the state is a deadlock and the margin is to the values within
    it — as the run header declares the space; a run without one is judged by the guard."""
    (tmp_path / "far.mch").write_text(FAR)
    shield = load_shield(tmp_path / "far.mch")
    space = dict(action_low=[-4.0], action_high=[2.0]) if bounded else {}
    path = tmp_path / "far.mcap"
    write_run(path, new_header("recorded", actions=["ACCELERATE"],
                               action_parameters={"ACCELERATE": ["a"]}, **space), [
        # a > 1.9: 1.0 is 0.9 short, inside the space either way (the batch path)
        make(0, s(51.9, 20.0), [("ACCELERATE", {"a": 1.0}, s(51.9, 20.0))]),
        # a > 3: nothing within [-4, 2]; over the reals 2.0 is 1.0 short
        make(1, s(53.0, 20.0), [("ACCELERATE", {"a": 2.0}, s(53.0, 20.0))]),
    ])
    near, far = replay([path], shield).per_episode
    assert near.margin == pytest.approx(0.9) and near.deadlock_states == []
    if bounded:
        assert far.margin is None and far.margin_note == "nothing allowed"
        assert far.allowed == "a ∈ ∅" and far.deadlock_states == [0, 1]  # both states
    else:
        assert far.margin == pytest.approx(1.0) and far.deadlock_states == []
        assert far.allowed == "a ∈ (3.0, ∞)"


@pytest.mark.parametrize("floats, deadlock", [(["float32"], True), (["float64"], False),
                                              (None, False)])
def test_replay_allows_only_values_of_the_spaces_float_type(tmp_path, floats, deadlock):
    """a = Gap - 49.9 (0.1 here): no float32 is 0.1, so in a float32 space nothing is
    allowed — the live shield's deadlock, which replay used to call "ACCELERATE allowed" (a
    new user's drone); a float64 space, or a run that does not say (recorded before the
    header said it), has 0.1."""
    (tmp_path / "eq.mch").write_text(FAR.replace("a > Gap - 50.0", "a = Gap - 49.9"))
    space = dict(action_low=[-4.0], action_high=[2.0])
    if floats:
        space["action_floats"] = floats
    path = tmp_path / "eq.mcap"
    write_run(path, new_header("recorded", actions=["ACCELERATE"],
                               action_parameters={"ACCELERATE": ["a"]}, **space), [
        make(0, s(50.0, 20.0), [("ACCELERATE", {"a": -4.0}, s(50.0, 20.0))])])
    (one,) = replay([path], load_shield(tmp_path / "eq.mch")).per_episode
    assert one.deadlock_states == ([0, 1] if deadlock else [])


def test_a_strict_guard_whose_values_begin_at_the_spaces_bound_allows_nothing(tmp_path):
    """a > 2 within [-4, 2]: nothing — not a margin of 1 to the bound itself."""
    (tmp_path / "far.mch").write_text(FAR)
    path = tmp_path / "edge.mcap"
    write_run(path, new_header("recorded", actions=["ACCELERATE"],
                               action_parameters={"ACCELERATE": ["a"]},
                               action_low=[-4.0], action_high=[2.0]), [
        make(0, s(52.0, 20.0), [("ACCELERATE", {"a": 1.0}, s(52.0, 20.0))])])
    (edge,) = replay([path], load_shield(tmp_path / "far.mch")).per_episode
    assert edge.margin is None and edge.margin_note == "nothing allowed"


def test_a_state_the_solver_cannot_decide_stops_replay_naming_it(capsys, tmp_path):
    """a * a = 2.0 has no float solution: whether the state is a deadlock is undecided —
    exit 2 naming the file, episode and step, never a guess."""
    (tmp_path / "eq.mch").write_text(FAR.replace("a > Gap - 50.0", "a * a = Gap - 50.0"))
    path = tmp_path / "eq.mcap"
    write_run(path, new_header("recorded", actions=["ACCELERATE"],
                               action_parameters={"ACCELERATE": ["a"]}), [
        make(0, s(52.0, 20.0), [("ACCELERATE", {"a": 1.0}, s(52.0, 20.0))])])
    code, out, err = run(capsys, "replay", path, "--shield", tmp_path / "eq.mch")
    flat = " ".join(err.split())
    assert code == 2 and f"{path}, episode 0, step 0: undecided for ACCELERATE" in flat
    assert "tracecheck does not guess" in flat and "Traceback" not in err


def acc_shield(tmp_path):
    path = tmp_path / "acc.mch"
    path.write_text(ACC)
    return load_shield(path)


def test_recorded_values_of_a_parameter_not_typed_real_are_refused(tmp_path, run_file):
    """``ACCELERATE(a) = PRE a : 0..1``: "some value allowed" passed the recorded 1.5, -4.0
    and 2.0 as every step feasible, and diff against another such shield found nothing."""
    path = tmp_path / "int.mch"
    path.write_text(ACC.replace("MACHINE Acc", "MACHINE Int").replace(
        "a : REAL & a >= -4.0 & a <= 2.0 & Gap - (Speed + a) * 1.5 > 10.0", "a : 0..1")
        .replace("Speed := Speed + a", "skip"))
    integer = load_shield(path)
    message = (r"acc.mcap: the run records values of ACCELERATE's parameter a \(1.5 at "
               r"episode 0 step 1\), but the shield int does not type it REAL")
    with pytest.raises(InputError, match=message):
        replay([run_file], integer)
    from tracecheck.checking.diffing import diff
    for pair in ((integer, load_shield(path)), (acc_shield(tmp_path), integer)):
        with pytest.raises(InputError, match="does not type it REAL"):
            diff([run_file], *pair)


@pytest.mark.parametrize("command", ["replay", "diff"])
def test_a_shield_typing_only_some_parameters_real_is_refused_naming_the_others(
        tmp_path, capsys, command):
    shield = tmp_path / "boat.mch"
    shield.write_text(ACC.replace("ACCELERATE(a) = PRE a : REAL & a >= -4.0",
                                  "ACCELERATE(a, r) = PRE a : REAL & r >= 0.0 & a >= -4.0"))
    path = tmp_path / "boat.mcap"
    write_run(path, new_header("recorded", variables=["Gap", "Speed"], actions=ACTIONS,
                               action_parameters={"ACCELERATE": ["a", "r"]}),
              [make(0, s(50.0, 20.0), [("ACCELERATE", {"a": 1.0, "r": 0.5}, s(49.0, 21.0))])])
    against = ("--against", str(shield)) if command == "diff" else ()
    code, _, err = run(capsys, command, str(path), "--shield", str(shield), *against)
    assert code == 2
    assert "boat.mch:6:" in err and "ACCELERATE(a, r) types a REAL in its guard but not r" in err
    assert "hint: add `r : REAL` to the guard of ACCELERATE" in err
    assert "cannot enumerate" not in err and "Traceback" not in err


def test_a_recorded_value_the_shield_has_no_element_for_names_the_step(tmp_path, capsys):
    """A new user's tank recorded under --shield none (its mode a str, kept as a STRING),
    replayed against a shield whose Mode is an element of MODES: the first state holding
    'EMPTY' was said as "the state: …", no file, episode or step."""
    shield = tmp_path / "modes.mch"
    shield.write_text(ACC.replace("MACHINE Acc", "MACHINE Acc\nSETS MODES = {NORMAL, LOW}")
                      .replace("VARIABLES Gap, Speed", "VARIABLES Gap, Speed, Mode")
                      .replace("INVARIANT Gap : REAL", "INVARIANT Mode : MODES & Gap : REAL")
                      .replace("Gap, Speed := 50.0, 20.0", "Gap, Speed, Mode := 50.0, 20.0, "
                               "NORMAL"))
    path = tmp_path / "modes.mcap"
    write_run(path, new_header("recorded", variables=["Gap", "Speed", "Mode"],
                               actions=ACTIONS, action_parameters={"ACCELERATE": ["a"]}),
              [make(0, dict(s(50.0, 20.0), Mode="NORMAL"),
                    [("ACCELERATE", {"a": 9.0}, dict(s(20.0, 21.0), Mode="EMPTY")),
                     ("ACCELERATE", {"a": 9.0}, dict(s(48.0, 22.0), Mode="NORMAL"))])])
    code, _, err = run(capsys, "replay", str(path), "--shield", str(shield))
    assert code == 2 and f"{path}, episode 0, step 1: Mode is of type MODES in Acc, but it " \
                         "is 'EMPTY'" in " ".join(err.split())
