"""Replay and diff: hand-built episodes with known answers, and the paper's traces."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.helpers import ROOT, TOY, VS, state
from tracecheck.b.values import FuncValue
from tracecheck.episodes import EpisodeWriter, new_header, read_columns
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.live.envs.highway import ACTIONS as HIGHWAY_ACTIONS
from tracecheck.errors import InputError, TracecheckError
from tracecheck.interop import import_simb
from tracecheck.checking.diffing import diff
from tracecheck.checking.replaying import enabled_matrix, replay
from tracecheck.checking.shield import load_shield
from tracecheck.live.envs.highway import HIGHWAY

def test_hand_built_episodes(toy, run_file):
    report = replay([run_file], toy)
    e0, e1, e2 = report.per_episode
    assert (e0.first_infeasible, e0.action, e0.infeasible_steps) == (3, "FASTER", 1)
    assert e0.enabled == ["IDLE", "LANE_LEFT", "LANE_RIGHT", "SLOWER"]
    assert e0.crashed and e0.crash_step == 4 and e0.crash_after_infeasible
    assert e1.first_infeasible == 2 and e1.deadlock_states == [1]
    assert e1.invariant_violations == [2]
    # step 2 of episode 2: FASTER from x = 200 is blocked; the agent valued SLOWER most
    # among the actions the shield allowed there
    assert e2.first_infeasible == 2 and e2.alternative == "SLOWER"
    assert e2.postcondition_violations == [3]
    assert (report.episodes, report.steps, report.infeasible_steps) == (3, 9, 3)
    assert (report.crashes, report.crashes_after_infeasible) == (1, 1)
    assert (report.deadlock_states, report.postcondition_violations,
            report.invariant_violations) == (1, 1, 1)
    assert report.feasible_episodes == 0 and report.infeasible_episodes == 3
    assert report.elapsed_s > 0
    data = report.to_json()
    for key in ("shield", "episodes", "steps", "feasible_episodes", "infeasible_episodes",
                "infeasible_steps", "crashes", "crashes_after_infeasible", "deadlock_states",
                "postcondition_violations", "invariant_violations", "elapsed_s",
                "per_episode"):
        assert key in data
    assert data["shield"]["name"] == "toy" and len(data["shield"]["sha256"]) == 64


def test_batch_and_per_state_agree(toy, run_file):
    """The vectorised replay gives what the scalar machine says state by state."""
    cols = read_columns(run_file)
    matrix, ops = enabled_matrix(toy, cols)
    for r in range(cols.n):
        assert {o for o, ok in zip(ops, matrix[r]) if ok} == toy.machine.enabled(
            cols.states.row(r))


def test_paper_shield_on_paper_traces(paper_traces, tmp_path):
    """The two facts of the paper's data: base_shield/ is feasible, base/ has 233 of 765
    steps infeasible; never a deadlock; the model agrees with every recorded step."""
    paper = load_shield("paper")
    for folder, steps, infeasible in (("base", 765, 233), ("base_shield", 1179, 0)):
        path = tmp_path / f"{folder}.mcap"
        write_run(path, new_header("imported-simb"), import_simb([paper_traces / "simb" / folder], vocab=HIGHWAY))
        report = replay([path], paper)
        assert (report.steps, report.infeasible_steps) == (steps, infeasible)
        assert report.deadlock_states == report.postcondition_violations == 0
        assert report.invariant_violations == 0
    assert report.crashes == 1 and report.crashes_after_infeasible == 0
    base = replay([tmp_path / "base.mcap"], paper)
    assert base.crashes == 9 and base.crashes_after_infeasible == 9


def test_diff(paper_traces, tmp_path):
    path = tmp_path / "base.mcap"
    write_run(path, new_header("imported-simb"), import_simb([paper_traces / "simb" / "base"], vocab=HIGHWAY))
    paper, none = load_shield("paper"), load_shield("none")
    same = diff([path], paper, paper)
    assert same.changed_steps == same.enabled_set_changes == same.episodes_changed == 0
    assert not same.anything_changed
    d = diff([path], paper, none)
    infeasible = replay([path], paper)
    assert d.newly_blocked == d.changed_steps == infeasible.infeasible_steps == 233
    assert d.newly_allowed == 0
    blocked = {(e.episode, s) for e in infeasible.per_episode for s in _infeasible_steps(e)}
    assert {(c.episode, c.step) for c in d.changes} >= blocked
    assert d.episodes_changed == 20 and d.crashes_in_changed_episodes == 9
    back = diff([path], none, paper)
    assert back.newly_allowed == 233 and back.newly_blocked == 0


def test_a_diff_lists_the_first_changes_and_counts_all(paper_traces, tmp_path, capsys,
                                                      monkeypatch):
    """Issue 28: a campaign's diff has 10^6 changed steps; the report lists the first
    ``listed`` changed steps and episodes (in file order, block by block) and counts all,
    exactly; ``--all`` lists every one."""
    from tests.helpers import run
    from tracecheck.episodes import writer as W

    monkeypatch.setattr(W, "BLOCK_ROWS", 150)  # several blocks
    path = tmp_path / "base.mcap"
    write_run(path, new_header("imported-simb"), import_simb([paper_traces / "simb" / "base"], vocab=HIGHWAY))
    paper, none = load_shield("paper"), load_shield("none")
    full = diff([path], paper, none, listed=None)
    short = diff([path, path], paper, none, listed=30)
    assert len(full.changes) == full.changed_steps == 233 and full.changes_left_out == 0
    assert short.changes == full.changes[:30] and short.changes_left_out == 2 * 233 - 30
    assert short.changed_episodes == (full.changed_episodes * 2)[:30]
    assert short.episodes_left_out == 2 * 20 - 30 and short.changed_steps == 2 * 233
    assert short.episodes_changed == 40
    command = ["diff", "--shield", "paper", "--against", "none", str(path)]
    code, text, err = run(capsys, *command, "--format", "csv")
    assert code == 0 and len(text.splitlines()) == 234 and not err
    import tracecheck.checking.diffing as D

    monkeypatch.setattr(D, "LISTED", 100)
    code, text, err = run(capsys, *command, "--format", "csv")
    assert code == 0 and len(text.splitlines()) == 101
    assert "listed the first 100 of 233 changed steps and of 20 changed episodes" in err
    code, text, err = run(capsys, *command, "--format", "csv", "--all")
    assert len(text.splitlines()) == 234 and not err
    code, text, _ = run(capsys, *command)
    assert ("… 193 more changed step(s): --format csv or json lists the first 100 (--all: "
            "every one)") in " ".join(text.split())  # 40 rows shown, 100 listed, 233 found


def test_steps_no_longer_listed_are_not_counted_as_having_values_only():
    """A part's changed steps left out of the list were counted in its details_left_out
    (values only, no allowed sets): once not listed at all, they leave that count."""
    from tracecheck.checking.diffing import ChangedStep, DiffReport, _keep_listed

    def change(k, continuous):
        return ChangedStep(file="f", episode=0, step=k, action="GO", feasible_under_shield=True,
                           feasible_under_against=False, enabled_shield=["GO"],
                           enabled_against=[], parameters={"a": 1.0} if continuous else None)

    report = DiffReport(shield={}, against={}, files=[], listed=3)
    report.changes = [change(k, k % 2 == 0) for k in range(8)]
    assert _keep_listed(report) == (5, 0, 2)  # steps 4 and 6 of those left out: values only
    assert [c.step for c in report.changes] == [0, 1, 2]


def _infeasible_steps(e):
    return [e.first_infeasible] if e.first_infeasible is not None else []


def test_strict_is_deadlock_free_on_paper_traces(paper_traces, tmp_path):
    path = tmp_path / "all.mcap"
    write_run(path, new_header("imported-simb"),
              (dataclasses.replace(e, id=i) for i, e in enumerate(
                  import_simb([paper_traces / "simb" / "base",
                               paper_traces / "simb" / "base_shield"], vocab=HIGHWAY))))
    report = replay([path], load_shield("strict"))
    assert report.deadlock_states == 0
    assert report.infeasible_steps > 233  # stricter than the paper's shield on base/


coords = st.floats(min_value=-80, max_value=80, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(xs=st.lists(coords, min_size=4, max_size=4), ys=st.lists(
    st.sampled_from([-8.0, -4.0, -2.1, 0.0, 1.9, 4.0, 8.0]), min_size=4, max_size=4),
    vxs=st.lists(st.floats(-15, 15), min_size=4, max_size=4),
    vys=st.lists(st.floats(-3, 3), min_size=4, max_size=4),
    ego=st.tuples(st.sampled_from([0.0, 4.0, 8.0]), st.floats(15, 32)),
    present=st.lists(st.booleans(), min_size=4, max_size=4))
def test_strict_always_leaves_an_action(xs, ys, vxs, vys, ego, present):
    """Relative deadlock freedom: in any state at least one action stays enabled."""
    machine = load_shield("strict").machine
    vs = machine.sets["Vehicles"]
    f = lambda e, rest: FuncValue(dict(zip(vs, [e, *rest])))  # noqa: E731
    s = {"Crash": False, "Reward": 0.0,
         "PresentVehicles": frozenset([vs[0]] + [v for v, p in zip(vs[1:], present) if p]),
         "VehiclesX": f(100.0, xs), "VehiclesY": f(ego[0], ys), "VehiclesVx": f(ego[1], vxs),
         "VehiclesVy": f(0.0, vys), "VehiclesAx": f(0.0, [0.0] * 4),
         "VehiclesAy": f(0.0, [0.0] * 4)}
    assert machine.enabled(s)


def test_strict_blocks_what_rss_forbids():
    machine = load_shield("strict").machine
    vs = machine.sets["Vehicles"]
    f = lambda *vals: FuncValue(dict(zip(vs, vals)))  # noqa: E731
    base = {"Crash": False, "Reward": 0.0, "PresentVehicles": frozenset(vs[:2]),
            "VehiclesY": f(4.0, 0.0, 0.0, 0.0, 0.0), "VehiclesVy": f(*[0.0] * 5),
            "VehiclesAx": f(*[0.0] * 5), "VehiclesAy": f(*[0.0] * 5)}
    # same speed 25 m/s: IDLE needs 25 + 625/8 - 625/10 = 40.625 m between the vehicles
    # (centres 45.625 m apart), FASTER 25 + 2.5 + 900/8 - 62.5 = 77.5 m (centres 82.5 m)
    def ahead(x):
        return {**base, "VehiclesX": f(100.0, x, 0.0, 0.0, 0.0),
                "VehiclesVx": f(25.0, 0.0, 0.0, 0.0, 0.0)}
    assert "IDLE" in machine.enabled(ahead(45.7)) and "FASTER" not in machine.enabled(ahead(45.7))
    assert "IDLE" not in machine.enabled(ahead(45.6))
    assert {"IDLE", "FASTER"} <= machine.enabled(ahead(82.6))
    assert "FASTER" not in machine.enabled(ahead(82.4))


def test_missing_variable_is_an_input_error(tmp_path):
    path = tmp_path / "thin.mcap"
    s0 = {"Crash": False, "Reward": 0.0}
    steps = (StepRecord(0, 0.0, None, s0, 0.0, False),
             StepRecord(1, 1.0, "IDLE", s0, 0.0, False))
    with EpisodeWriter(path, new_header("recorded")) as w:
        w.write(Episode(0, steps, make_end(steps)))
    with pytest.raises(InputError, match=r"thin.mcap: the states have no .*VehiclesX.* which "
                                         r"the shield paper reads \(episode 0, step 0\)") as e:
        replay([path], load_shield("paper"))
    assert e.value.hint is None  # nothing close
    near = tmp_path / "near.mcap"
    s0 = {"Gapp": 1.0, "Speed": 2.0}
    steps = (StepRecord(0, 0.0, None, s0, 0.0, False), StepRecord(1, 1.0, "Go", s0, 0.0, False))
    with EpisodeWriter(near, new_header("recorded")) as w:
        w.write(Episode(0, steps, make_end(steps)))
    shield = tmp_path / "gap.mch"
    shield.write_text("MACHINE Gap VARIABLES Gap, Speed INVARIANT Gap : REAL & Speed : REAL "
                      "INITIALISATION Gap, Speed := 1.0, 1.0 OPERATIONS Go = PRE Gap > 0.5 "
                      "THEN skip END END")
    with pytest.raises(InputError, match="the states have no Gap, which the shield gap") as e:
        replay([near], load_shield(shield))
    assert e.value.hint == "the states name another: Gap (did you mean Gapp?)"


def test_shield_loading_errors(tmp_path):
    with pytest.raises(InputError, match="unknown shield 'sturdy': give one of none, "
                                         "cliffwalking, frozenlake, highway_continuous, "
                                         "lunarlander_continuous, paper, strict or the "
                                         "path of a .mch file"):
        load_shield("sturdy")
    partial = tmp_path / "partial.mch"
    partial.write_text("MACHINE Partial OPERATIONS IDLE = skip; FASTER = skip END")
    with pytest.raises(InputError, match="Partial lacks LANE_LEFT, LANE_RIGHT, SLOWER"):
        load_shield(partial, actions=HIGHWAY_ACTIONS)
    # for replay, a shield needs operations for the actions a recording uses
    sample = ROOT / "sample_traces" / "base_none.mcap"
    with pytest.raises(InputError, match=r"base_none.mcap: the episodes use the action "
                                         r"LANE_LEFT \(114 step\(s\), the first at episode 1 "
                                         r"step 1\), which the shield partial has no operation "
                                         r"for \(its operations are IDLE, FASTER\)"):
        replay([sample], load_shield(partial))
    # so does diff, for either shield (a misspelt operation made every step "newly blocked")
    misspelt = tmp_path / "Misspelt.mch"
    misspelt.write_text((ROOT / "models" / "shields" / "paper.mch").read_text()
                        .replace("FASTER", "FASTRE"))
    for pair in ((load_shield("paper"), load_shield(misspelt)),
                 (load_shield(misspelt), load_shield("paper"))):
        with pytest.raises(InputError, match=r"the episodes use the action FASTER \(\d+ "
                                             r"step\(s\).*which the shield (misspelt|Misspelt)"
                           ) as e:
            diff([sample], *pair)
        assert e.value.hint == ("is the shield's operation FASTRE the action FASTER misspelt? "
                                "an action and its operation have one name")
    shield = load_shield("paper")
    assert shield.name == "paper" and shield.identity["sha256"] == shield.machine.sha256


def test_replay_speed_paths_agree_on_real_data(paper_traces, tmp_path):
    path = tmp_path / "base.mcap"
    write_run(path, new_header("imported-simb"), import_simb([paper_traces / "simb" / "base"], vocab=HIGHWAY))
    cols = read_columns(path)
    paper = load_shield("paper")
    matrix, ops = enabled_matrix(paper, cols)
    rows = np.arange(cols.n)
    for r in rows[::7]:
        assert {o for o, ok in zip(ops, matrix[r]) if ok} == paper.machine.enabled(
            cols.states.row(r))


def test_state_without_a_value_the_guard_needs(tmp_path):
    """A state whose VehiclesX lacks a vehicle the guard reads: the error names the file,
    episode and step."""
    path = tmp_path / "gap.mcap"
    good = state(100.0)
    holed = dict(good)
    holed["VehiclesX"] = FuncValue({k: v for k, v in good["VehiclesX"].map.items()
                                    if k != VS[0]})
    steps = (StepRecord(0, 0.0, None, good, 0.0, False),
             StepRecord(1, 1.0, "IDLE", good, 0.0, False),
             StepRecord(2, 2.0, "IDLE", holed, 0.0, False))
    with EpisodeWriter(path, new_header("recorded")) as w:
        w.write(Episode(7, steps, make_end(steps)))
    shield_path = tmp_path / "toy.mch"
    shield_path.write_text(TOY)
    with pytest.raises(TracecheckError) as info:
        replay([path], load_shield(shield_path))
    assert "gap.mcap, episode 7, step 2: EgoVehicle is not in the domain of the function" \
        in str(info.value)


@pytest.mark.parametrize("spec", ["none-for-frozenlake", "paper", "file"])
def test_a_shield_travels_to_a_worker_as_itself(spec, tmp_path):
    """What a Ray task receives (issue 23): the shield pickled as its machine's text and
    rebuilt there — ``none`` made from a run's actions stays that ``none``, a file's shield
    needs no file on the worker."""
    import pickle

    from tracecheck.checking.replaying import _replay_one

    if spec == "none-for-frozenlake":
        shield = load_shield("none", actions=("Move_Left", "Move_Down", "Move_Right",
                                              "Move_Up"))
    elif spec == "paper":
        shield = load_shield("paper")
    else:
        path = tmp_path / "mine.mch"
        path.write_text((ROOT / "models" / "shields" / "paper.mch").read_text())
        shield = load_shield(path)
    data = pickle.dumps(shield)
    if spec == "file":
        path.unlink()  # the worker never reads it
    sent = pickle.loads(data)
    assert (sent.name, sent.sha256, sent.path) == (shield.name, shield.sha256, shield.path)
    assert list(sent.machine.operations) == list(shield.machine.operations)
    if spec != "none-for-frozenlake":
        run = ROOT / "sample_traces" / "base_none.mcap"
        assert _replay_one(str(run), sent).per_episode == replay([run], shield).per_episode


def test_a_shield_changed_on_the_way_is_refused():
    from tracecheck.checking.shield import _rebuilt

    shield = load_shield("paper")
    name, sha, path, text, file = shield.__reduce__()[1]
    with pytest.raises(InputError, match="arrived changed"):
        _rebuilt(name, sha, path, text.replace("40.0", "30.0"), file)


def test_postconditions_over_views_and_copies_agree(toy, run_file, monkeypatch):
    """Postconditions are evaluated over every neighbouring pair of rows at once (views of
    the columns), the steps of each operation picked out; where that fails (a pair that is
    no step may have no value), over copies of the steps alone. Both give one answer."""
    import tracecheck.checking.replaying as R
    from tracecheck.errors import EvaluationError

    fast = replay([run_file], toy)
    assert fast.per_episode[2].postcondition_violations == [3]

    def refuse(*_):
        raise EvaluationError("a pair that is no step")

    monkeypatch.setattr(R, "shifted_pairs", refuse)
    slow = replay([run_file], toy)
    assert [e.postcondition_violations for e in slow.per_episode] == \
        [e.postcondition_violations for e in fast.per_episode]
    monkeypatch.undo()

    def no_copies(*_):
        raise AssertionError("the copies were made")
    monkeypatch.setattr(R, "step_pairs", no_copies)
    assert replay([run_file], toy).per_episode[2].postcondition_violations == [3]
