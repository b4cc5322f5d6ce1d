"""tracecheck tune: the figures for every value of a shield's number equal replay of the machine
with that value written in; the number named by constant, definition or literal; bad input
refused, naming it."""

from __future__ import annotations

import json
from fractions import Fraction

import pytest

from tests.helpers import run
from tracecheck.b import load_machine_text
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.episodes.writer import new_header
from tracecheck.errors import InputError
from tracecheck.interop import import_simb
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.search.tune_target import check_range, resolve_target, written
from tracecheck.search.tuning import shield_with, tune, tune_grid


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory, paper_traces):
    """The paper's 40 SimB traces (20 without a shield, 20 with it) in one run file."""
    path = tmp_path_factory.mktemp("tune") / "paper.mcap"
    write_run(path, new_header("imported-simb", variables=list(HIGHWAY.variables),
                               actions=list(HIGHWAY.actions)),
              import_simb([paper_traces / "simb" / "base", paper_traces / "simb" / "base_shield"],
                          vocab=HIGHWAY))
    return path


def _replayed(path, shield) -> tuple:
    r = replay([path], shield)
    return r.infeasible_steps, r.infeasible_episodes, r.crashes_after_infeasible, \
        r.deadlock_states


def _tuple(f) -> tuple:
    return f.steps_blocked, f.episodes_blocked, f.crashes_after_blocked, f.deadlock_states


@pytest.mark.parametrize("shield,spec,low,high,n", [
    ("paper", {"literal": "FASTER:40.0"}, 0.0, 100.0, 51),
    ("paper", {"literal": "IDLE:30.0"}, 5.0, 55.0, 21),
    ("strict", {"param": "VehLen"}, 2.0, 8.0, 51),
], ids=["paper-FASTER-distance", "paper-IDLE-distance", "strict-VehLen"])
def test_every_value_of_a_grid_of_51_equals_replay_of_the_machine_with_it_written_in(
        paper_run, shield, spec, low, high, n):
    loaded = load_shield(shield)
    target = resolve_target(loaded.machine, **spec)
    grid = [low + (high - low) * k / (n - 1) for k in range(n)]
    result = tune([paper_run], loaded, target, low, high, at=grid)
    assert len(result.pieces) > 10  # the figures do change over the range
    changes = set()
    for v in grid:
        want = _replayed(paper_run, shield_with(loaded, target, v))
        piece = next(p for p in result.pieces if p.contains(Fraction(v)))
        assert _tuple(result.at[v]) == want, v
        assert _tuple(piece.figures) == want, v  # the piecewise function itself, too
        changes.add(want)
    assert len(changes) > 3
    assert _tuple(result.current) == _replayed(paper_run, loaded)


def test_the_pieces_cover_the_range_without_gaps_and_the_front_is_pareto_optimal(paper_run):
    loaded = load_shield("paper")
    result = tune([paper_run], loaded, resolve_target(loaded.machine, literal="FASTER:40.0"),
                  0.0, 100.0)
    assert result.pieces[0].low == 0 and result.pieces[0].low_closed
    assert result.pieces[-1].high == 100 and result.pieces[-1].high_closed
    for a, b in zip(result.pieces, result.pieces[1:]):
        assert a.high == b.low and a.high_closed != b.low_closed
        assert a.figures != b.figures
    points = [(p.figures.steps_blocked, result.crashes - p.figures.crashes_after_blocked)
              for p in result.pieces]
    for f in result.front:
        mine = (f.figures.steps_blocked, f.crashes_missed)
        assert not any(o[0] <= mine[0] and o[1] <= mine[1] and o != mine for o in points)
    assert result.knee in result.front


def test_a_number_the_guards_read_non_linearly_is_refused_with_the_grid_offered(paper_run):
    loaded = load_shield("strict")
    target = resolve_target(loaded.machine, param="AccMax")
    with pytest.raises(InputError, match=r"cannot solve for it: an IF whose condition reads "
                       r"it in `IF v0 \+ a \* ResponseTime") as info:
        tune([paper_run], loaded, target, 3.0, 6.0)
    assert "--grid" in info.value.hint
    result = tune_grid([paper_run], loaded, target, [3.0, 6.0])
    assert result.method == "grid" and set(result.at) == {3.0, 5.0, 6.0}
    for v in (3.0, 6.0):
        assert _tuple(result.at[v]) == _replayed(paper_run, shield_with(loaded, target, v))


TOY = """MACHINE Toy
CONSTANTS Limit, Big
PROPERTIES Limit = 3.0 & Big = 10 & Limit < 8.0
DEFINITIONS Tol == 0.5; Ten == 10
VARIABLES x, n
INVARIANT x : REAL & n : INTEGER
INITIALISATION x := 0.0 || n := 0
OPERATIONS
  Up = SELECT x + Tol < Limit & n < 5 THEN x := x + 1.0 END;
  Down = SELECT x > 0.0 - 2.0 * Limit or n > Ten THEN x := x - 1.0 END;
  Stay = SELECT x * x < 4.0 & n < Big THEN skip END
END"""


@pytest.fixture
def toy():
    return load_machine_text(TOY, file="toy.mch")


@pytest.mark.parametrize("spec,message", [
    ({"param": "Nope"}, r"has no constant or definition Nope"),
    ({"param": "x"}, r"has no constant or definition x"),
    ({"literal": "Up:7.0"}, r"the guard of Up has no number 7.0"),
    ({"literal": "Up"}, r"expected OPERATION:VALUE"),
    ({"literal": "Nowhere:1.0"}, r"has no operation or definition Nowhere"),
], ids=["unknown", "a-variable", "no-such-literal", "no-value", "no-scope"])
def test_a_name_that_is_not_there_is_refused_saying_what_is(toy, spec, message):
    with pytest.raises(InputError, match=message) as info:
        resolve_target(toy, **spec)
    assert info.value.hint


def test_the_numbers_a_literal_scope_has_are_listed_where_the_value_is_not_one(toy):
    with pytest.raises(InputError) as info:
        resolve_target(toy, literal="Stay:3.0")
    assert "4.0 at 11:25" in info.value.hint


def test_a_constant_a_definition_and_a_literal_are_each_found_with_their_place(toy):
    limit = resolve_target(toy, param="Limit")
    assert (limit.kind, limit.value, limit.integer, limit.line) == ("constant", 3.0, False, 3)
    assert set(limit.guards) == {"Up", "Down"}
    tol = resolve_target(toy, param="Tol")
    assert (tol.kind, tol.value, set(tol.guards)) == ("definition", 0.5, {"Up"})
    ten = resolve_target(toy, param="Ten")
    assert ten.integer and set(ten.guards) == {"Down"}
    lit = resolve_target(toy, literal="Down:2.0")
    assert written(toy.source, lit, 4.5).count("0.0 - 4.5 * Limit") == 1


def test_a_number_no_guard_reads_is_refused(toy):
    text = TOY.replace("Big = 10 &", "Big = 10 & Unused = 1.0 &").replace(
        "CONSTANTS Limit, Big", "CONSTANTS Limit, Big, Unused")
    with pytest.raises(InputError, match="Unused is read by no operation's guard"):
        resolve_target(load_machine_text(text), param="Unused")


def test_a_constant_that_is_no_number_or_not_set_by_an_equality_is_refused():
    m = load_machine_text(TOY.replace("CONSTANTS Limit, Big", "CONSTANTS Limit, Big, S")
                          .replace("Big = 10 &", "Big = 10 & S = {1, 2} &"))
    with pytest.raises(InputError, match="the constant S is not a number"):
        resolve_target(m, param="S")
    m = load_machine_text(TOY.replace("Limit = 3.0 & ", "Limit : REAL & Limit > 2.5 & "
                                      "Limit < 3.5 & Limit * 2.0 = 6.0 & "))
    with pytest.raises(InputError, match="do not give Limit by an equality with a number"):
        resolve_target(m, param="Limit")


def test_a_range_the_properties_do_not_hold_over_is_refused_naming_the_conjunct(toy):
    target = resolve_target(toy, param="Limit")
    check_range(toy, target, 1.0, 7.5)
    with pytest.raises(InputError, match=r"the PROPERTIES are false for 8.0 <= Limit <= 9.0: "
                       r"`Limit < 8.0`"):
        check_range(toy, target, 1.0, 9.0)


def test_a_range_that_would_make_the_machine_ill_typed_is_refused(toy):
    ten = resolve_target(toy, param="Ten")
    check_range(toy, ten, 5.0, 15.0)
    with pytest.raises(InputError, match="Ten is an INTEGER; give whole numbers"):
        check_range(toy, ten, 5.5, 15.0)
    with pytest.raises(InputError, match="must be finite and go up"):
        check_range(toy, ten, 15.0, 5.0)


def test_an_integer_number_is_tuned_exactly_too(toy, tmp_path):
    from tracecheck.checking.shield import Shield, ShieldMachine

    machine = load_machine_text(TOY, kind=ShieldMachine)
    shield = Shield("toy", machine.sha256, "toy.mch", machine)
    path = tmp_path / "toy.mcap"
    states = [{"x": float(x), "n": n} for x, n in ((0, 0), (1, 3), (2, 7), (1, 12), (0, 12))]
    actions = [None, "Up", "Up", "Down", "Down"]
    steps = tuple(StepRecord(step=k, time=float(k), action=a, state=s, reward=0.0,
                             crashed=k == 4) for k, (a, s) in enumerate(zip(actions, states)))
    write_run(path, new_header("imported-simb", variables=["x", "n"], actions=["Up", "Down", "Stay"]),
              [Episode(id=0, steps=steps, end=make_end(steps), seed=1)])
    target = resolve_target(machine, param="Ten")
    result = tune([path], shield, target, 0.0, 20.0, at=[float(v) for v in range(21)])
    for v in range(21):
        assert _tuple(result.at[float(v)]) == _replayed(path, shield_with(shield, target, v))


def test_tune_on_the_command_line_prints_the_machines_figures_as_replay_does(
        paper_run, capsys, tmp_path):
    code, out, err = run(capsys, "tune", paper_run, "-s", "paper", "--literal",
                         "FASTER:40.0=20..60", "--at", "45", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["parameter"]["name"] == "FASTER:40.0" and data["method"] == "exact"
    want = replay([paper_run], load_shield("paper"))
    assert data["current"]["steps_blocked"] == want.infeasible_steps
    assert data["current"]["crashes_after_blocked"] == want.crashes_after_infeasible
    assert [a["value"] for a in data["at"]] == [40.0, 45.0]
    assert data["front"] and data["knee"] is not None
    plot = tmp_path / "tune.png"
    code, out, err = run(capsys, "tune", paper_run, "-s", "strict", "--param", "VehLen=3..7",
                         "--plot", plot, "--format", "csv")
    assert code == 0, err
    assert out.splitlines()[0].startswith("VehLen values,steps blocked")
    assert plot.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args,message", [
    (["--param", "Nope"], "has no constant or definition Nope"),
    (["--param", "VehLen=a..b"], "the range must be LO..HI with two numbers"),
    (["--param", "BrakeMin=3..6"], "the PROPERTIES are false for 5.0 < BrakeMin <= 6.0"),
    (["--param", "EgoVehicle"], "the constant EgoVehicle is not a number"),
    (["--literal", "FASTER:45.0"], "the guard of FASTER has no number 45.0"),
    ([], "give the number to tune"),
    (["--param", "VehLen", "--at", "99"], "--at 99.0: outside the range tuned"),
    (["--param", "AccMax"], "an IF whose condition reads it"),
], ids=["unknown", "not-numbers", "properties", "not-a-number", "literal", "nothing",
        "at-outside", "non-linear"])
def test_bad_input_exits_2_naming_it(capsys, args, message):
    shield = "paper" if "FASTER" in " ".join(args) else "strict"
    code, out, err = run(capsys, "tune", "sample_traces/base_none.mcap", "-s", shield, *args)
    assert code == 2 and message in " ".join(err.split()), err
    assert "Traceback" not in err


THROTTLE = """MACHINE Throttle
CONSTANTS Margin
PROPERTIES Margin = 1.0
VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL
INITIALISATION Gap, EgoSpeed, LeadSpeed := 40.0, 20.0, 20.0
OPERATIONS
  ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 &
      Gap + LeadSpeed - Margin - (EgoSpeed + a) > EgoSpeed + a
  THEN Gap, EgoSpeed, LeadSpeed :(Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL) END
END"""


def test_a_continuous_shield_is_tuned_with_the_recorded_parameters_bound(tmp_path):
    """An operation with REAL parameters: each step's set is the number's values for which
    the guard allows the recorded acceleration; equal to replay at 51 values (deadlocks are
    not counted: whether some acceleration is allowed is not found for every value)."""
    import numpy as np

    from tracecheck.checking.shield import Shield, ShieldMachine

    machine = load_machine_text(THROTTLE, kind=ShieldMachine)
    shield = Shield("throttle", machine.sha256, "throttle.mch", machine)
    rng = np.random.default_rng(5)
    episodes = []
    for eid in range(4):
        steps = []
        for k in range(13):
            state = {"Gap": float(rng.uniform(30, 50)), "EgoSpeed": float(rng.uniform(15, 25)),
                     "LeadSpeed": float(rng.uniform(15, 25))}
            a = float(rng.uniform(-4, 2))
            steps.append(StepRecord(step=k, time=float(k), action=None if k == 0 else "ACCELERATE",
                                    state=state, reward=0.0, crashed=eid % 2 == 1 and k == 12,
                                    parameters=None if k == 0 else {"a": a}))
        steps = tuple(steps)
        episodes.append(Episode(id=eid, steps=steps, end=make_end(steps), seed=eid))
    path = tmp_path / "throttle.mcap"
    write_run(path, new_header("recorded", variables=["Gap", "EgoSpeed", "LeadSpeed"],
                               actions=["ACCELERATE"],
                               action_parameters={"ACCELERATE": ["a"]}), episodes)
    target = resolve_target(machine, param="Margin")
    grid = [-10.0 + 40.0 * k / 50 for k in range(51)]
    result = tune([path], shield, target, -10.0, 30.0, at=grid)
    assert result.deadlock_note and "ACCELERATE has parameters" in result.deadlock_note
    seen = set()
    for v in grid:
        want = _replayed(path, shield_with(shield, target, v))[:3]
        assert _tuple(result.at[v])[:3] == want, v
        seen.add(want)
    assert len(seen) > 5


def test_chosen_values_are_re_simulated_from_the_seeds_paired_with_the_machines_own(
        acc_env, acc_runs, acc_agent, capsys):
    from tests.helpers import ACC_V2

    code, out, err = run(capsys, "tune", acc_runs["none"], "-s", ACC_V2, "--literal",
                         "ACCEL:7.0=0..40", "--at", "0", "--at", "knee", "--resimulate", "3",
                         "--agent", acc_agent, "--json")
    assert code == 0, err
    data = json.loads(out)
    resim = data["resimulation"]
    assert resim["episodes"] == 3 and resim["seeds"] == [0, 1, 2]
    rows = {r["value"]: r for r in resim["values"]}
    assert list(rows)[0] == 7.0 and rows[7.0]["paired"] is None
    assert 0.0 in rows and data["knee"] in rows
    for r in rows.values():
        assert 0 <= r["crash_low"] <= r["crash_rate"] <= r["crash_high"] <= 1
        assert 0 <= r["intervention_low"] <= r["intervention_rate"] <= r["intervention_high"]
    assert "McNemar" in rows[0.0]["paired"]
    # the ACCEL agent under the machine's own shield (v2) never crashes, as recorded under it
    assert rows[7.0]["crashes"] == 0 and rows[7.0]["intervention_rate"] > 0
    code, out, err = run(capsys, "tune", acc_runs["none"], "-s", ACC_V2, "--literal",
                         "ACCEL:7.0=0..40", "--at", "0", "--resimulate", "2",
                         "--agent", acc_agent)
    assert code == 0, err
    assert "re-simulated 2 episode(s) per value" in out and "McNemar" in out
    print(out)


def _both(shield, targets, values):
    from tracecheck.search.tune_pair import found_again

    a, b = targets
    once = shield_with(shield, b, values[1])
    return shield_with(once, found_again(once.machine, a, b, shield), values[0])


def test_two_numbers_on_a_grid_exact_along_each_line_equal_replay_where_they_cross(paper_run):
    from tracecheck.search.tune_pair import tune_pair

    paper = load_shield("paper")
    targets = [resolve_target(paper.machine, literal=s) for s in ("FASTER:40.0", "IDLE:30.0")]
    result = tune_pair([paper_run], paper, targets, [(20.0, 60.0), (10.0, 50.0)], 3)
    assert result.grids == ([20.0, 40.0, 60.0], [10.0, 30.0, 50.0])  # the machine's among them
    across = {(x, y): t.at[x] for y, t in result.along_first for x in result.grids[0]}
    down = {(x, y): t.at[y] for x, t in result.along_second for y in result.grids[1]}
    assert across == down
    for (x, y), f in across.items():
        assert _tuple(f) == _replayed(paper_run, _both(paper, targets, (x, y))), (x, y)
    assert all(len(t.pieces) > 10 for _, t in result.along_first + result.along_second)


def test_two_numbers_written_on_one_line_are_each_found_again_after_the_other_is_rewritten(
        tmp_path):
    from tracecheck.checking.shield import Shield, ShieldMachine
    from tracecheck.search.tune_pair import tune_pair

    machine = load_machine_text(TOY, kind=ShieldMachine)
    shield = Shield("toy", machine.sha256, "toy.mch", machine)
    states = [{"x": float(x), "n": n} for x, n in ((0, 0), (-3, 3), (-5, 7), (-7, 12))]
    actions = [None, "Down", "Down", "Down"]
    steps = tuple(StepRecord(step=k, time=float(k), action=a, state=s, reward=0.0,
                             crashed=k == 3) for k, (a, s) in enumerate(zip(actions, states)))
    path = tmp_path / "toy.mcap"
    write_run(path, new_header("imported-simb", variables=["x", "n"],
                               actions=["Up", "Down", "Stay"]),
              [Episode(id=0, steps=steps, end=make_end(steps), seed=1)])
    targets = [resolve_target(machine, literal=s) for s in ("Down:0.0", "Down:2.0")]
    result = tune_pair([path], shield, targets, [(-20.0, 5.0), (0.5, 4.0)], 4)
    for y, t in result.along_first:
        for x in result.grids[0]:
            assert _tuple(t.at[x]) == _replayed(path, _both(shield, targets, (x, y))), (x, y)


def test_two_numbers_on_the_command_line_need_a_grid(paper_run, capsys):
    code, out, err = run(capsys, "tune", paper_run, "-s", "paper", "--literal",
                         "FASTER:40.0=20..60", "--literal", "IDLE:30.0=10..50")
    assert code == 2 and "give --grid N" in err
    code, out, err = run(capsys, "tune", paper_run, "-s", "paper", "--literal",
                         "FASTER:40.0=20..60", "--literal", "IDLE:30.0=10..50", "--grid", "3",
                         "--format", "md")
    assert code == 0, err
    assert out.startswith("| along | fixed | values |")
    code, out, err = run(capsys, "tune", paper_run, "-s", "paper", "--literal",
                         "FASTER:40.0=20..60", "--literal", "IDLE:30.0=10..50", "--grid", "3")
    assert "where the lines cross" in out
