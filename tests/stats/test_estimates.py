"""Statistics for any run: the generic set, the recorded crash flag ``crashed`` in B and LTL
properties, end reasons, interventions, and LTL properties that need the adapter's machine."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.helpers import ACC_SPEC, ROOT, run
from tracecheck.episodes.columns import episode_columns
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.errors import InputError
from tracecheck.stats.estimates import evaluate_run, interventions
from tracecheck.stats.formulas import prepare
from tracecheck.stats.properties import GENERIC_SET, parse_properties, with_generic, \
    load_properties


def test_stats_of_a_run_whose_adapter_is_not_installed(acc_runs, capsys):
    """Bug 5 (the highway's set, 'unknown identifier VehiclesVx') and bug 2 (a hint naming
    an option stats did not have): generic statistics, a note, exit 0."""
    code, out, err = run(capsys, "stats", acc_runs["none"], acc_runs["v2"], "--json")
    assert code == 0, err
    assert "VehiclesVx" not in err and "not installed here: generic statistics only" in err
    data = json.loads(out)
    none, v2 = data["runs"]
    assert data["properties_set"] == "generic"
    assert none["properties"]["CRASH"]["ratio"] == 1.0 and v2["properties"]["CRASH"]["ratio"] == 0
    assert v2["properties"]["TIME_LIMIT"]["ratio"] == 1.0  # the environment's own limit
    assert none["properties"]["TIME_LIMIT"]["ratio"] == 0.0
    assert v2["metrics"]["episode_length"]["mean"] == 30.0
    assert none["metrics"]["interventions"]["mean"] == 0.0  # no shield: nothing replaced
    assert 0 < v2["metrics"]["interventions"]["mean"] < 1
    assert "return" in none["metrics"]


@pytest.mark.parametrize("how", ["entry point", "--env"])
def test_stats_adds_the_adapters_own_set(acc_env, acc_runs, capsys, how):
    extra = ["--env", ACC_SPEC] if how == "--env" else []
    code, out, err = run(capsys, "stats", acc_runs["none"], acc_runs["v2"], "--json", *extra)
    assert code == 0, err
    data = json.loads(out)
    assert data["properties_set"] == "generic+acc" and "note" not in err
    none, v2 = data["runs"]
    assert set(none["properties"]) == {"CRASH", "TIME_LIMIT", "HEADWAY", "NO_CRASH"}
    # the LTL property over the recorded crash flag agrees with the generic crash share
    assert none["properties"]["NO_CRASH"]["ratio"] == 0.0
    assert v2["properties"]["NO_CRASH"]["ratio"] == 1.0
    assert none["metrics"]["min_gap"]["mean"] < 0 < v2["metrics"]["min_gap"]["mean"]


def test_env_must_be_the_runs_environment(acc_runs, capsys):
    code, _, err = run(capsys, "stats", acc_runs["none"], "--env", "frozenlake")
    assert code == 2
    assert "the runs come from the environment acc, but --env gives the adapter of " \
           "frozenlake" in err


def test_the_highway_default_is_generic_plus_the_papers():
    from tracecheck.stats.formulas import default_set

    pset, notes = default_set([ROOT / "sample_traces" / "base_none.mcap"])
    names = [m.name for m in pset.metrics]
    assert pset.name == "generic+highway" and not notes
    assert names[:3] == ["episode_length", "return", "interventions"] and "velocity" in names
    assert pset.metrics[0].description == "Episode length [s]"  # the highway's own, in place
    assert {p.name for p in pset.properties} >= {"CRASH", "TIME_LIMIT", "SAF1", "SAF6"}


def _episode(states, crashed_last=False, reason=None, values=None, actions=None):
    steps = []
    for k, state in enumerate(states):
        steps.append(StepRecord(k, float(k), None if k == 0 else (actions or ["L"] * 9)[k - 1],
                                state, 1.0, crashed_last and k == len(states) - 1,
                                action_values=None if k == 0 or values is None
                                else values[k - 1]))
    steps = tuple(steps)
    return Episode(0, steps, make_end(steps, reason), seed=0)


def test_crashed_is_the_recorded_flag_in_b_and_in_ltl():
    cols = episode_columns([_episode([{"x": 1}, {"x": 2}], crashed_last=True),
                            _episode([{"x": 1}, {"x": 0}])], ("L", "R"))
    pset = parse_properties("""
[properties.B]
predicate = "crashed = TRUE"
kind = "eventually"
[properties.NOT_YET]
predicate = "crashed = FALSE"
kind = "final"
""", name="t", file="t.toml")
    values = evaluate_run("<t>", pset, prepare(pset, "nowhere", {"x": 1}), cols=cols)
    assert values.properties["B"].tolist() == [True, False]
    assert values.properties["NOT_YET"].tolist() == [False, True]


def test_a_crashed_of_the_environments_own_wins_with_a_warning():
    cols = episode_columns([_episode([{"crashed": False}, {"crashed": False}],
                                     crashed_last=True)], ("L",))
    pset = parse_properties('[properties.C]\npredicate = "crashed = TRUE"\nkind = "final"',
                            name="t", file="t.toml")
    formulas = prepare(pset, "nowhere", {"crashed": False})
    assert formulas.warnings == ["t.toml: property C: crashed is the environment's own "
                                    "variable here, not the recorded crash flag"]
    assert evaluate_run("<t>", pset, formulas, cols=cols).properties["C"].tolist() == [False]
    plain = prepare(pset, "nowhere", {"x": 1})
    assert plain.warnings == []


def test_interventions_come_from_the_recorded_action_values():
    ep = _episode([{"x": 0}] * 4, values=[{"L": 1.0, "R": 0.0}] * 3, actions=["L", "R", "R"])
    cols = episode_columns([ep], ("L", "R"))
    assert interventions(cols).tolist() == [False, False, True, True]
    values = evaluate_run("<t>", GENERIC_SET, prepare(GENERIC_SET, "nowhere", {"x": 0}),
                          cols=cols)
    assert values.metrics["interventions"].tolist() == [pytest.approx(2 / 3)]
    # imported traces without the agent's values: not 0, but unknown (null with a note)
    bare = episode_columns([_episode([{"x": 0}] * 3)], ("L", "R"))
    values = evaluate_run("<t>", GENERIC_SET, prepare(GENERIC_SET, "nowhere", {"x": 0}),
                          cols=bare)
    assert np.isnan(values.metrics["interventions"][0])


def test_end_reasons_as_properties():
    pset = parse_properties('[properties.T]\npredicate = "time-limit"\nkind = "end"',
                            name="t", file="t.toml")
    cols = episode_columns([_episode([{"x": 0}] * 2, reason="time-limit"),
                            _episode([{"x": 0}] * 2)], ("L",))
    assert evaluate_run("<t>", pset, prepare(pset, "x", None), cols=cols
                        ).properties["T"].tolist() == [True, False]
    with pytest.raises(InputError, match="a property of kind end names an end reason "
                                         r"\(crashed, time-limit"):
        parse_properties('[properties.T]\npredicate = "timeout"\nkind = "end"', name="t",
                         file="t.toml")


def test_ltl_without_the_adapters_machine_names_the_attribute(tmp_path, capsys):
    """LTL is read in the adapter's default_shield: the message says to set it."""
    from tests.live.toy import left_leaning_table

    agent = tmp_path / "left.npy"
    np.save(agent, left_leaning_table())
    out = tmp_path / "toy.mcap"
    code, _, err = run(capsys, "record", "--env", "tests.live.toy:Corridor", "--agent", agent,
                       "-n", 2, "-o", out)
    assert code == 0, err
    props = tmp_path / "ltl.toml"
    props.write_text('[properties.L]\npredicate = "G({crashed = FALSE})"\nkind = "ltl"\n')
    code, _, err = run(capsys, "stats", out, "--env", "tests.live.toy:Corridor",
                       "--properties", props)
    assert code == 2
    assert "the environment corridor names no machine to read LTL and STL properties in: " \
           "its adapter has no default_shield" in err
    assert "set default_shield" in err and "on tests.live.toy:Corridor" in err
    # generic statistics need no machine
    code, out_text, err = run(capsys, "stats", out, "--env", "tests.live.toy:Corridor",
                              "--json")
    assert code == 0, err
    assert json.loads(out_text)["runs"][0]["properties"]["CRASH"]["ratio"] == 1.0


def test_load_properties_generic():
    assert load_properties("generic") is GENERIC_SET
    assert with_generic(None) is GENERIC_SET


def test_a_share_metrics_interval_is_cut_to_0_1():
    """A t-interval of a share near 0 over few episodes reaches below 0: it is cut to the
    share's range, and its method says so (a mean of shares is never negative)."""
    from tracecheck.stats.estimates import _metric_stats

    share = next(m for m in GENERIC_SET.metrics if m.aggregate == "interventions")
    out = _metric_stats(np.array([0.0, 0.0, 0.0, 0.5]), share)
    assert out["mean"] == pytest.approx(0.125)
    assert out["ci95"][0] == 0.0 and out["ci95"][1] == pytest.approx(0.125 + 0.397809, abs=1e-5)
    assert out["method"] == "t, cut to the metric's range [0, 1]"
    near_one = _metric_stats(np.array([1.0, 1.0, 1.0, 0.5]), share)
    assert near_one["ci95"][1] == 1.0 and near_one["ci95"][0] < 0.875
    inside = _metric_stats(np.array([0.4, 0.5, 0.6]), share)  # within: as it was
    assert inside["method"] == "t" and 0.0 < inside["ci95"][0] < inside["ci95"][1] < 1.0
    steps = next(m for m in GENERIC_SET.metrics if m.aggregate == "steps")
    few = _metric_stats(np.array([1.0, 1.0, 1.0, 30.0]), steps)
    assert few["ci95"][0] == 0.0 and few["method"] == "t, cut to the metric's range >= 0"
    ret = _metric_stats(np.array([1.0, 1.0, 1.0, 30.0]), next(
        m for m in GENERIC_SET.metrics if m.aggregate == "return"))
    assert ret["ci95"][0] < 0.0 and ret["method"] == "t"  # a return has no such range
