"""Statistics of continuous actions (tracecheck.stats.continuous): intervention rate, projection
distances, boundary and fallback shares, on a hand-made run whose numbers are counted by hand."""

from __future__ import annotations

import csv
import io
import math

import pytest

from tests.helpers import run, strict_json
from tests.stats.continuous_run import continuous_episode, continuous_header, write_hand_run
from tracecheck.episodes import EpisodeWriter, new_header
from tracecheck.episodes.columns import read_columns
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.episodes.reader import read_episodes
from tracecheck.stats.continuous import continuous_steps, continuous_summary
from tracecheck.stats.estimates import statistics
from tracecheck.stats.properties import GENERIC_SET

# tests/stats/continuous_run.py's EPISODES, counted by hand: 8 steps; intervened 5 (E0 s2, s3; E1 s1, s2, s5); on the boundary 4
# (E0 s2, s3; E1 s2, s5); fallback 1; distances sum 9.0 (mean 1.125, max 6), over the
# intervened 9.0 / 5 = 1.8
# Wilson 95 % by its formula, z = 1.959963984540054: (k + z²/2)/(n + z²) ∓ z/(n + z²)·
# sqrt(k(n−k)/n + z²/4) — 5 of 8: [0.305742, 0.863156]; 4 of 8: [0.215216, 0.784784];
# 1 of 8: [0.022417, 0.470888]


@pytest.fixture(scope="module")
def hand_run(tmp_path_factory):
    return write_hand_run(tmp_path_factory.mktemp("continuous") / "hand.mcap",
                          action_low=[-4.0], action_high=[2.0], shield_mode="project",
                          projection_scale=[1.0])


@pytest.fixture(scope="module")
def discrete_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("discrete") / "discrete.mcap"
    steps = tuple(StepRecord(k, float(k), None if k == 0 else "KEEP", {"x": float(k)}, 1.0,
                             False) for k in range(3))
    with EpisodeWriter(path, new_header("recorded", actions=["KEEP"], variables=["x"])) as w:
        w.write(Episode(0, steps, make_end(steps, "time-limit"), seed=1))
    return path


def _close(pair, expected):
    assert pair == pytest.approx(list(expected), abs=1e-6)


def test_the_step_statistics_are_the_hand_counted_ones(hand_run):
    c = statistics([hand_run], GENERIC_SET)["runs"][0]["continuous"]
    assert c["parameters"] == ["a"] and c["steps"] == 8
    assert {k: c["interventions"][k] for k in ("count", "steps", "ratio", "method")} == \
        {"count": 5, "steps": 8, "ratio": 5 / 8, "method": "wilson"}
    _close(c["interventions"]["ci95"], (0.305742, 0.863156))
    assert (c["boundary"]["count"], c["boundary"]["steps"]) == (4, 8)
    _close(c["boundary"]["ci95"], (0.215216, 0.784784))
    assert c["boundary"]["tolerance"] == 1e-5
    assert (c["fallback"]["count"], c["fallback"]["steps"]) == (1, 8)
    _close(c["fallback"]["ci95"], (0.022417, 0.470888))
    d = c["projection_distance"]
    assert (d["mean"], d["max"], d["steps"]) == (pytest.approx(1.125), 6.0, 8)
    assert (d["intervened"]["mean"], d["intervened"]["max"], d["intervened"]["steps"]) == \
        (pytest.approx(1.8), 6.0, 5)


def test_the_interval_method_is_the_one_asked_for(hand_run):
    from scipy import stats

    c = statistics([hand_run], GENERIC_SET, interval="clopper-pearson")["runs"][0]
    share = c["continuous"]["interventions"]
    ci = stats.binomtest(5, 8).proportion_ci(method="exact")  # Clopper–Pearson
    assert share["method"] == "clopper-pearson"
    _close(share["ci95"], (ci.low, ci.high))


def test_the_space_s_own_bounds_are_ends_only_where_the_header_does_not_name_them(
        hand_run):
    cols = read_columns(hand_run)
    steps = continuous_steps(cols, read_episodes(hand_run), header=None)
    assert int(steps.boundary.sum()) == 5  # E0 step 1 at 2.0 now counts
    assert steps.boundary.tolist() == [False, True, True, True,  # episode 0, steps 0-3
                                       False, False, True, False, False, True]
    assert continuous_summary(steps)["boundary"]["count"] == 5


def test_a_space_without_a_bound_leaves_only_the_other_out(tmp_path):
    """An unbounded side of the action space is recorded as null: no end is its bound."""
    path = write_hand_run(tmp_path / "half.mcap", action_low=[-4.0], action_high=[None])
    c = statistics([path], GENERIC_SET)["runs"][0]["continuous"]
    assert c["boundary"]["count"] == 5  # E0 step 1 at 2.0 counts: 2.0 is not the space's


def test_the_per_episode_interventions_metric_reads_the_proposals(hand_run):
    metric = statistics([hand_run], GENERIC_SET)["runs"][0]["metrics"]["interventions"]
    assert metric["mean"] == pytest.approx((2 / 3 + 3 / 5) / 2)  # 2 of 3 steps, 3 of 5


def test_a_discrete_run_has_no_continuous_statistics(discrete_run, hand_run, capsys):
    result = statistics([discrete_run], GENERIC_SET)
    assert "continuous" not in result["runs"][0]
    code, out, _ = run(capsys, "stats", discrete_run, "--format", "md")
    assert code == 0 and "share of steps)" in out  # the interventions metric only
    assert "Intervention rate" not in out and "boundary" not in out
    code, out, _ = run(capsys, "stats", discrete_run, "--format", "csv")
    assert code == 0 and "step share" not in out and "projection_distance" not in out
    # beside a continuous run, its cells say it has none
    code, out, _ = run(capsys, "stats", discrete_run, hand_run, "--format", "md")
    row = next(line for line in out.splitlines() if line.startswith("| Intervention rate"))
    assert row.split("|")[2].strip() == "—"
    assert row.split("|")[3].strip() == "62.5 % [30.6, 86.3] (5 of 8)"


def test_the_text_markdown_csv_and_json_outputs(hand_run, capsys):
    code, out, _ = run(capsys, "stats", hand_run, "--format", "md")
    assert code == 0
    rows = {line.split("|")[1].strip(): line.split("|")[2].strip()
            for line in out.splitlines() if line.startswith("| ")}
    assert rows["Intervention rate (share of steps)"] == "62.5 % [30.6, 86.3] (5 of 8)"
    assert rows["On the allowed set's boundary (share of steps)"] == \
        "50.0 % [21.5, 78.5] (4 of 8)"
    assert rows["Fallback taken (share of steps)"] == "12.5 % [2.2, 47.1] (1 of 8)"
    assert rows["Projection distance (all steps)"] == "mean 1.12, max 6"
    assert rows["Projection distance (intervened steps)"] == "mean 1.8, max 6"
    code, out, _ = run(capsys, "stats", hand_run, "--format", "csv")
    found = {(r["name"], r["method"]): r for r in csv.DictReader(io.StringIO(out))}
    assert found[("intervention_rate", "wilson")]["holds"] == "5"
    assert float(found[("intervention_rate", "wilson")]["value"]) == 5 / 8
    assert found[("boundary_share", "wilson")]["kind"] == "step share"
    assert float(found[("projection_distance_intervened", "mean")]["value"]) == \
        pytest.approx(1.8)
    assert float(found[("projection_distance", "max")]["value"]) == 6.0
    code, out, _ = run(capsys, "stats", hand_run, "--json")
    data = strict_json(out)["runs"][0]["continuous"]
    assert data["fallback"]["count"] == 1 and data["interventions"]["ratio"] == 5 / 8
    code, out, _ = run(capsys, "stats", hand_run)
    assert code == 0 and "Intervention rate" in out and "62.5 %" in out


def test_a_run_without_intervened_steps_says_so(tmp_path, capsys):
    path = tmp_path / "calm.mcap"
    with EpisodeWriter(path, continuous_header()) as w:
        w.write(continuous_episode(0, [(1.0, 1.0, 0.0, ((-4.0, 2.0),), None)]))
    c = statistics([path], GENERIC_SET)["runs"][0]["continuous"]
    assert c["projection_distance"]["intervened"] == {"mean": None, "max": None, "steps": 0}
    assert c["interventions"]["count"] == 0 and c["boundary"]["count"] == 0  # no space bounds
    code, out, _ = run(capsys, "stats", path, "--json")
    assert code == 0 and not math.isnan(strict_json(out)["runs"][0]["metrics"]
                                        ["interventions"]["mean"])
    code, out, _ = run(capsys, "stats", path, "--format", "md")
    assert "| Projection distance (intervened steps) | no steps |" in out


def test_a_hybrid_choice_tied_with_the_best_score_is_no_intervention():
    from types import SimpleNamespace

    import numpy as np

    from tracecheck.stats.continuous import interventions

    nan = np.nan
    cols = SimpleNamespace(n=3, parameters={"a": np.array([nan, nan, nan])},
                           proposals={"a": np.array([nan, nan, nan])},
                           values=np.array([[nan, nan], [1.0, 1.0], [1.0, 0.5]]),
                           action=np.array([-1, 1, 1]))
    judged, intervened = interventions(cols)
    assert judged.tolist() == [False, True, True]
    assert intervened.tolist() == [False, False, True]  # a tie at row 1; a lower score at 2


def test_a_hybrid_run_whose_steps_all_took_the_parameterless_fallback_has_its_rows(tmp_path):
    """Every step a deadlock whose fallback (HOVER) has no parameters: the run recorded no
    executed parameters, only the agent's proposals — its fallback share is 100 %, where
    the continuous rows used to be missing (a new user's drone)."""
    path = tmp_path / "hover.mcap"
    steps = [StepRecord(0, 0.0, None, {"x": 0.0}, 0.0, False)] + [
        StepRecord(k, float(k), "HOVER", {"x": 0.0}, 1.0, False, deadlock=True,
                   proposal={"r": 0.5}, action_values={"HOVER": -1.0, "CLIMB": 1.0},
                   preferred_action="CLIMB") for k in (1, 2, 3, 4)]
    header = new_header("recorded", actions=["HOVER", "CLIMB"], variables=["x"],
                        action_parameters={"CLIMB": ["r"]}, action_low=[0.0],
                        action_high=[3.0], shield_mode="mask", projection_scale=[1.0])
    with EpisodeWriter(path, header) as w:
        w.write(Episode(0, tuple(steps), make_end(tuple(steps), "time-limit"), seed=0))
    c = statistics([path], GENERIC_SET)["runs"][0]["continuous"]
    assert c["fallback"]["count"] == 4 and c["fallback"]["steps"] == 4
    assert c["interventions"]["count"] == 4  # the agent scored CLIMB best each time
