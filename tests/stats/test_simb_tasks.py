"""SimB's tasks as tracecheck statistics: the hypothesis test's acceptance range, the
between-steps aggregates, estimation types, starting and ending conditions — against values
computed by hand (the command that computed each is in a comment)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tests.helpers import ROOT
from tracecheck.b.machine import load_machine
from tracecheck.episodes.columns import episode_columns
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.errors import InputError
from tracecheck.stats.estimates import evaluate_run, run_statistics
from tracecheck.stats.formulas import prepare
from tracecheck.stats.properties import Metric, PropertySet, parse_properties
from tracecheck.stats.simb_tasks import (FAILED, NOT_RUN, SUCCESS, SimbTask, Window,
                                         evaluate_task, simb_hypothesis, window)

CORRIDOR = ROOT / "tests" / "fixtures" / "prob2project" / "Corridor.mch"


@pytest.fixture(scope="module")
def corridor():
    return load_machine(CORRIDOR)


def walk(eid: int, cells: list[int], dt: float = 1.0) -> Episode:
    """An episode of the corridor through ``cells`` (a step every ``dt`` seconds)."""
    steps = []
    for k, pos in enumerate(cells):
        action = None if k == 0 else ("RIGHT" if pos > cells[k - 1] else "LEFT")
        steps.append(StepRecord(k, k * dt, action, {"pos": pos, "Crash": pos == 4}, 0.0,
                                pos == 4))
    steps = tuple(steps)
    return Episode(eid, steps, make_end(steps))


#: the five executions of tests/fixtures/prob2project/simb (corridor_run_1 … 5)
FIVE = [walk(0, [0, 1, 2, 3]), walk(1, [0, 1, 0]), walk(2, [0, 1, 2, 3, 4]), walk(3, [0]),
        walk(4, [0, 1, 2], dt=0.5)]


@pytest.mark.parametrize("k, n, p, alpha, tail, r, ok", [
    # python -c "from scipy.stats import norm; import math; s = math.sqrt(5*.6*.4);
    #   print([norm.cdf(-(i + .5) / s) for i in range(4)])"  -> .324 .0855 .0112: r = 2
    (4, 5, 0.6, 0.05, "left", 2, True),      # 4 >= 3 - 2
    # s = sqrt(5*.95*.05) = .487: Φ(-.5/s) = .152, Φ(-1.5/s) = .001: r = 1; 3 < 4.75 - 1
    (3, 5, 0.95, 0.05, "left", 1, False),
    # s = sqrt(1.25): 1 - (Φ(z) - Φ(-z)) for z = (i + .5)/s: .655, .180, .0253: r = 2
    (3, 5, 0.5, 0.05, "two", 2, True),
    (5, 5, 0.5, 0.05, "right", 2, False),    # 5 > 2.5 + 2
    # s = 2.179: Φ(-3.5/s) = .0541, Φ(-4.5/s) = .0195: r = 4, so 91 of 100 must hold
    (93, 100, 0.95, 0.05, "left", 4, True),
    (90, 100, 0.95, 0.05, "left", 4, False),
    (10, 10, 1.0, 0.05, "left", 0, True),    # σ = 0: every execution must hold
    (9, 10, 1.0, 0.05, "left", 0, False),
], ids=["left-ok", "left-fail", "two-ok", "right-fail", "paper-ok", "paper-fail",
        "certain-ok", "certain-fail"])
def test_simb_hypothesis_acceptance_range(k, n, p, alpha, tail, r, ok):
    result = simb_hypothesis(k, n, p, alpha, tail)
    assert (result["range"], result["success"]) == (r, ok)
    assert result["mu"] == pytest.approx(n * p)


def _values(machine, episodes, metrics):
    pset = PropertySet("t", tuple(metrics))
    cols = episode_columns(episodes, ["LEFT", "RIGHT"])
    run = evaluate_run("<t>", pset, prepare(pset, machine=machine), "t", cols)
    return run, pset


def test_between_steps_aggregates_by_hand(corridor):
    from tracecheck.b.parser import parse_formula

    node = parse_formula("pos")
    metrics = [Metric(a, a, "pos", node) for a in (
        "average_between_steps", "sum_between_steps", "min_between_steps", "max_between_steps")]
    run, _ = _values(corridor, [walk(0, [0, 1, 2, 3]), walk(1, [2])], metrics)
    # [0,1,2,3]: means of successive states .5, 1.5, 2.5: sum 4.5, average 1.5, least .5,
    # greatest 2.5; [2] has no step: average 0 (SimB), least and greatest none
    assert run.metrics["average_between_steps"].tolist() == [1.5, 0.0]
    assert run.metrics["sum_between_steps"].tolist() == [4.5, 0.0]
    assert run.metrics["min_between_steps"][0] == 0.5
    assert run.metrics["max_between_steps"][0] == 2.5
    assert math.isnan(run.metrics["min_between_steps"][1])


@pytest.mark.parametrize("kind, within", [("mean", False), ("minimum", False),
                                          ("maximum", True)])
def test_estimate_types(corridor, kind, within):
    from tracecheck.b.parser import parse_formula

    metric = Metric("m", "max", "pos", parse_formula("pos"), estimate=(2.6, 0.5),
                    estimate_type=kind)
    run, pset = _values(corridor, FIVE, [metric])
    stats = run_statistics(run, pset)["metrics"]["m"]
    assert stats["mean"] == pytest.approx(2.0)  # the greatest cells 3, 1, 4, 0, 2
    # mean: |2 − 2.6| > 0.5; minimum: 2 < 2.6 − 0.5; maximum: 2 <= 2.6 + 0.5
    assert stats["estimate"] == {"value": 2.6, "epsilon": 0.5, "type": kind, "within": within}


def test_estimate_type_in_property_files():
    text = '[metrics.m]\nexpression = "1"\naggregate = "average_between_steps"\n' \
           'estimate = { value = 1.0, epsilon = 0.5, type = "minimum" }\n'
    (m,) = parse_properties(text, name="t", file="t.toml").metrics
    assert (m.aggregate, m.estimate, m.estimate_type) == ("average_between_steps", (1.0, 0.5),
                                                          "minimum")
    with pytest.raises(InputError, match="t.toml: metric m: estimate: unknown type 'median'; "
                                         "the types are mean, minimum, maximum"):
        parse_properties(text.replace('"minimum"', '"median"'), name="t", file="t.toml")


# SimB (ProB2-UI's SimulationCheckingSimulator / SimulationPropertyChecker) counts
# transitions: after T of them it tests the starting condition and sets startAtStep = T;
# properties are judged on the transitions with index >= startAtStep. The corridor has no
# constants, so transition 0 is $initialise_machine and state j is transition j's
# destination: a condition met in the state after T transitions (state T - 1) is judged from
# state T on, and STEPS_PER_EXECUTION s ends the execution after startAtStep + s transitions.
@pytest.mark.parametrize("w, spans", [
    (Window(), [(0, 3), (0, 2), (0, 4), (0, 0), (0, 2)]),
    # T >= 1 after $initialise_machine: judged from transition 1 = state 1
    (Window(start_after_steps=1), [(1, 3), (1, 2), (1, 4), (1, 0), (1, 2)]),
    (Window(start_after_steps=3), [(3, 3), (3, 2), (3, 4), (1, 0), (3, 2)]),
    # the clock reaches 1500 ms in state 2 (T = 3): judged from state 3
    (Window(starting_time=1500), [(3, 3), (3, 2), (3, 4), (1, 0), (3, 2)]),
    (Window(starting_predicate="pos = 2"), [(3, 3), (3, 2), (3, 4), (1, 0), (3, 2)]),
    (Window(starting_predicate_activated="pos > 0"), [(2, 3), (2, 2), (2, 4), (1, 0), (2, 2)]),
    # two transitions: $initialise_machine and one operation
    (Window(steps_per_execution=2), [(0, 1), (0, 1), (0, 1), (0, 0), (0, 1)]),
    (Window(ending_predicate="pos = 1"), [(0, 1), (0, 1), (0, 1), (0, 0), (0, 1)]),
    (Window(ending_time=1000), [(0, 1), (0, 1), (0, 1), (0, 0), (0, 2)]),
    # startAtTime is the clock when the start is detected (state 0, 0 ms)
    (Window(start_after_steps=1, ending_time=1000), [(1, 1), (1, 1), (1, 1), (1, 0), (1, 2)]),
    (Window(start_after_steps=1, steps_per_execution=2), [(1, 2), (1, 2), (1, 2), (1, 0),
                                                         (1, 2)]),
], ids=["none", "after-steps", "after-3", "time", "predicate", "activated", "steps",
        "end-predicate", "end-time", "start-and-end", "start-and-steps"])
def test_window(corridor, w, spans):
    assert window(w, FIVE, corridor) == spans


CONSTANT_CORRIDOR = """MACHINE Corridor CONSTANTS far PROPERTIES far = 4
VARIABLES pos, Crash INVARIANT pos : 0..far & Crash : BOOL
INITIALISATION pos := 0 || Crash := FALSE
OPERATIONS
    LEFT = SELECT pos > 0 THEN pos := pos - 1 END;
    RIGHT = SELECT pos < far THEN pos := pos + 1 || Crash := bool(pos + 1 = far) END
END"""


@pytest.mark.parametrize("w, spans", [
    # $setup_constants is transition 0, $initialise_machine 1 (state 0): START_AFTER_STEPS k
    # is judged from transition k = state k - 1
    (Window(start_after_steps=1), [(0, 3), (0, 2), (0, 4), (0, 0), (0, 2)]),
    (Window(start_after_steps=3), [(2, 3), (2, 2), (2, 4), (1, 0), (2, 2)]),
    # a predicate met in state j (T = j + 2) is still judged from state j + 1
    (Window(starting_predicate="pos = 2"), [(3, 3), (3, 2), (3, 4), (1, 0), (3, 2)]),
    # three transitions: $setup_constants, $initialise_machine, one operation
    (Window(steps_per_execution=3), [(0, 1), (0, 1), (0, 1), (0, 0), (0, 1)]),
], ids=["after-1", "after-3", "predicate", "steps"])
def test_window_with_constants(w, spans):
    from tracecheck.b.machine import load_machine_text

    machine = load_machine_text(CONSTANT_CORRIDOR)
    assert window(w, FIVE, machine) == spans
    # the same count without constants starts one state later
    assert window(Window(start_after_steps=3), FIVE, load_machine(CORRIDOR))[0] == (3, 3)


def test_random_steps_before_the_property_are_seeded_and_bounded(corridor):
    w = Window(max_steps_before=3)
    first = window(w, FIVE * 20, corridor, seed=7)
    assert first == window(w, FIVE * 20, corridor, seed=7)
    lengths = [len(ep.steps) for ep in FIVE * 20]
    # SimB draws the first step to judge from 0 … MAX − 1; an episode shorter than that
    # never starts (its start is its length)
    assert all(a <= 2 or a == n for (a, _), n in zip(first, lengths))
    assert {a for a, _ in first} >= {0, 1, 2}
    assert window(w, FIVE * 20, corridor, seed=8) != first


def hypothesis(checking, formula=None, **fields):
    return SimbTask("HYPOTHESIS_TEST", checking, formula, probability=0.6, significance=0.05,
                    hypothesis_type="LEFT_TAILED", **fields)


def estimation(checking, formula, value, epsilon, kind="MEAN", **fields):
    return SimbTask("ESTIMATION", checking, formula, estimation_type=kind, desired_value=value,
                    epsilon=epsilon, **fields)


@pytest.mark.parametrize("task, status, holds_or_mean", [
    (hypothesis("PREDICATE_INVARIANT", "Crash = FALSE"), SUCCESS, 4),
    (hypothesis("PREDICATE_EVENTUALLY", "pos >= 3"), SUCCESS, 2),   # 2 >= 3 - 2
    (hypothesis("PREDICATE_FINAL", "pos = 0"), SUCCESS, 2),
    (hypothesis("ALL_INVARIANTS"), SUCCESS, 5),
    (hypothesis("TIMING", time=2000), SUCCESS, 3),                  # 3 s, 2, 4, 0, 1
    # the invariant from state 1 on: [0] never starts, and SimB counts it as holding
    (hypothesis("PREDICATE_INVARIANT", "pos > 0", window=Window(start_after_steps=1)),
     SUCCESS, 4),
    (hypothesis("PREDICATE_EVENTUALLY", "pos = 0", window=Window(start_after_steps=1)),
     SUCCESS, 1),
    (estimation("AVERAGE", "pos", 1.0, 0.1), SUCCESS, (1.5 + 1 / 3 + 2 + 0 + 1) / 5),
    (estimation("SUM", "pos", 3.0, 0.5, "MAXIMUM"), FAILED, (6 + 1 + 10 + 0 + 3) / 5),
    (estimation("MINIMUM", "pos", 0.0, 0.0, "MINIMUM"), SUCCESS, 0.0),
    (estimation("SUM_MEAN_BETWEEN_STEPS", "pos", 3.5, 0.5, "MINIMUM"), SUCCESS, 3.1),
    (estimation("AVERAGE", "pos", 0.0, 1.0, window=Window(ending_time=1000)), SUCCESS,
     (0.5 + 0.5 + 0.5 + 0 + 1) / 5),
    (estimation("PREDICATE_FINAL", "pos = 0", 0.4, 0.05), SUCCESS, 2),
    (estimation("PREDICATE_EVENTUALLY", "pos >= 3", 0.2, 0.1, "MAXIMUM"), FAILED, 2),
], ids=["invariant", "eventually", "final", "all-invariants", "timing", "late-invariant",
        "late-eventually", "average", "sum-max", "minimum", "sum-between", "ending-time",
        "estimate-final", "estimate-eventually"])
def test_tasks_on_the_five_executions(corridor, task, status, holds_or_mean):
    outcome = evaluate_task(task, FIVE, corridor)
    assert outcome.status == status, outcome.reason
    assert outcome.executions == 5
    stats = outcome.details.get("properties") or outcome.details["metrics"]
    (entry,) = stats.values()
    if "holds" in entry:
        assert entry["holds"] == holds_or_mean
    else:
        assert entry["mean"] == pytest.approx(holds_or_mean)


@pytest.mark.parametrize("task, reason", [
    (SimbTask("ESTIMATION", "MEDIAN", "pos", estimation_type="MEAN", desired_value=1.0,
              epsilon=0.1), "the checking type MEDIAN is not one tracecheck knows"),
    (SimbTask("PROBABILISTIC", "AVERAGE", "pos"), "the simulation type PROBABILISTIC is not "),
    (SimbTask("HYPOTHESIS_TEST", "AVERAGE", "pos", probability=0.5, significance=0.05,
              hypothesis_type="LEFT_TAILED"), "SimB tests only predicates"),
    (hypothesis("PREDICATE_INVARIANT", "speed > 0"), "unknown identifier speed"),
    (hypothesis("PREDICATE_INVARIANT", "pos +"), "PREDICATE"),
    (hypothesis("PREDICATE_INVARIANT", "pos + 1"), "predicate"),
    (SimbTask("HYPOTHESIS_TEST", "PREDICATE_INVARIANT", "pos > 0", probability=0.5,
              significance=0.05, hypothesis_type="ONE_TAILED"), "ONE_TAILED"),
], ids=["checking-type", "simulation-type", "value-test", "unknown-name", "syntax",
        "expression-as-predicate", "tail"])
def test_what_tracecheck_cannot_run_is_not_run_with_the_reason(corridor, task, reason):
    outcome = evaluate_task(task, FIVE, corridor, where="P.prob2project: machines[0]")
    assert outcome.status == NOT_RUN
    assert reason in outcome.reason


def test_executions_and_monte_carlo(corridor):
    three = evaluate_task(hypothesis("PREDICATE_INVARIANT", "Crash = FALSE", executions=3),
                          FIVE, corridor)
    assert three.executions == 3 and three.details["properties"]["PREDICATE"]["holds"] == 2
    assert evaluate_task(SimbTask("MONTE_CARLO_SIMULATION", executions=5), FIVE,
                         corridor).status == SUCCESS
    none = evaluate_task(hypothesis("PREDICATE_INVARIANT", "pos >= 0"), [], corridor)
    assert none.status == NOT_RUN and "no executions" in none.reason


@pytest.mark.parametrize("task", [
    SimbTask("MONTE_CARLO_SIMULATION", executions=9),
    hypothesis("PREDICATE_INVARIANT", "Crash = FALSE", executions=9),
    estimation("AVERAGE", "pos", 1.0, 5.0, executions=9),
    estimation("PREDICATE_FINAL", "pos >= 0", 1.0, 0.1, executions=9),
], ids=["monte-carlo", "hypothesis", "estimation", "estimated-predicate"])
def test_fewer_executions_than_asked_is_never_a_verdict(corridor, task):
    # on the five, each of these would succeed
    assert evaluate_task(replace(task, executions=5), FIVE, corridor).status == SUCCESS
    short = evaluate_task(task, FIVE, corridor)
    assert (short.status, short.executions, short.reason) == (
        NOT_RUN, 5, "only 5 of the 9 executions the task asks for")


@pytest.mark.parametrize("checking, what, sentinel", [
    ("MINIMUM", "no state", "least value; SimB counts Double.MAX_VALUE"),
    ("MAXIMUM", "no state", "greatest value; SimB counts Double.MIN_VALUE"),
    ("MINIMUM_MEAN_BETWEEN_STEPS", "no step", "Double.MAX_VALUE"),
])
def test_least_and_greatest_without_a_state_are_not_estimated(corridor, checking, what,
                                                                sentinel):
    # pos = 3 is never met in executions 1, 3 and 4: SimB would average its sentinel in
    task = estimation(checking, "pos", 3.0, 1.0, window=Window(starting_predicate="pos = 2"))
    outcome = evaluate_task(task, FIVE, corridor)
    assert outcome.status == NOT_RUN
    assert outcome.reason.startswith(f"3 of 5 executions judge {what} (the starting "
                                     "condition is never met, or their window is empty)")
    assert sentinel in outcome.reason
    # where every execution judges a state (a step), the estimate is made
    stepping = [ep for ep in FIVE if len(ep.steps) > 1]
    assert evaluate_task(replace(task, window=Window()), stepping, corridor).status != NOT_RUN


def test_an_execution_the_run_cut_before_the_task_ended_is_not_judged(corridor):
    cut = [replace(ep, end=replace(ep.end, reason="time-limit")) for ep in FIVE]
    task = hypothesis("PREDICATE_INVARIANT", "pos < 4", window=Window(steps_per_execution=4))
    # executions 1, 3, 4 end before their 4th transition (state 3): cut by the run, where
    # SimB would go on
    outcome = evaluate_task(task, cut, corridor, run_cut=True)
    assert (outcome.status, outcome.reason.split(" (")[0]) == (
        NOT_RUN, "3 of 5 executions were cut")
    # the same episodes read from timed traces are judged as they are
    assert evaluate_task(task, cut, corridor).status == SUCCESS


def test_paper_numbers_from_the_authors_tasks(paper_traces):
    """The authors' project tasks on the paper's base traces give the paper's numbers (the
    same as tests/stats/test_stats.py's EXPECTED for these 20 traces)."""
    from tracecheck.interop.common import vocabulary_of
    from tracecheck.interop.simb import import_simb

    model = ROOT.parent / "shared" / "data" / "paper-models" / "HighwayEnvironment" / \
        "HighwayEnvironment.mch"
    if not model.is_file():
        pytest.skip(f"the authors' machines are not at {model.parent}")
    machine = load_machine(model)
    episodes = list(import_simb([paper_traces / "simb" / "base"], vocab=vocabulary_of(machine),
                                machine=machine))
    speed = "RSQRT(VehiclesVy(EgoVehicle) * VehiclesVy(EgoVehicle) + VehiclesVx(EgoVehicle) " \
            "* VehiclesVx(EgoVehicle))"
    end = Window(ending_time=60000)
    velocity = evaluate_task(estimation("AVERAGE", speed, 25.0, 5.0, window=end), episodes,
                             machine)
    reward = evaluate_task(estimation("SUM", "Reward", 40.0, 20.0, window=end), episodes,
                           machine)
    distance = evaluate_task(estimation("SUM_MEAN_BETWEEN_STEPS", "VehiclesVx(EgoVehicle)",
                                        1500.0, 300.0, window=end), episodes, machine)
    safe = evaluate_task(SimbTask("HYPOTHESIS_TEST", "PREDICATE_INVARIANT", "Crash = FALSE",
                                  window=end, probability=0.95, significance=0.01,
                                  hypothesis_type="LEFT_TAILED"), episodes, machine)
    assert velocity.details["metrics"]["EXPRESSION"]["mean"] == pytest.approx(23.53, abs=0.005)
    assert reward.details["metrics"]["EXPRESSION"]["mean"] == pytest.approx(30.29, abs=0.005)
    assert distance.details["metrics"]["EXPRESSION"]["mean"] == pytest.approx(870.60, abs=0.005)
    assert (velocity.status, reward.status, distance.status) == (SUCCESS, SUCCESS, FAILED)
    assert safe.details["properties"]["PREDICATE"]["holds"] == 11 and safe.status == FAILED
    assert np.isfinite(safe.details["properties"]["PREDICATE"]["test"]["exact_p_value"])


WINDOWS = [Window(), Window(starting_predicate="pos >= 1"), Window(ending_predicate="pos = 2"),
           Window(start_after_steps=1, steps_per_execution=2), Window(ending_time=1000),
           Window(starting_time=1000, ending_time=1500),
           Window(max_steps_before=3, starting_predicate_activated="pos = 1")]
TASKS = [SimbTask("HYPOTHESIS_TEST", "PREDICATE_INVARIANT", "pos < 3", probability=0.6,
                  significance=0.05, hypothesis_type="LEFT_TAILED"),
         SimbTask("HYPOTHESIS_TEST", "PREDICATE_FINAL", "pos < 3", probability=0.6,
                  significance=0.05, hypothesis_type="LEFT_TAILED"),
         SimbTask("ESTIMATION", "AVERAGE", "pos", estimation_type="MEAN", desired_value=1.0,
                  epsilon=0.5),
         SimbTask("ESTIMATION", "SUM_BETWEEN_STEPS", "pos", estimation_type="MEAN",
                  desired_value=1.0, epsilon=5.0),
         SimbTask("ESTIMATION", "MAXIMUM", "pos", estimation_type="MEAN", desired_value=2.0,
                  epsilon=1.0, executions=3)]


@pytest.mark.parametrize("w", range(len(WINDOWS)))
def test_columns_built_once_give_every_task_the_same_outcome(corridor, w):
    """A project builds the executions' columns once and cuts them by row for each task:
    the outcome is the one of columns built from the cut executions."""
    from tracecheck.stats.simb_tasks import task_columns

    columns = task_columns(FIVE)
    for task in TASKS:
        task = replace(task, window=WINDOWS[w])
        alone = evaluate_task(task, FIVE, corridor, seed=3)
        shared = evaluate_task(task, FIVE, corridor, seed=3, columns=columns)
        assert shared == alone
