"""Statistics: the paper's Tables 2 and 3 on its own traces, aggregates, intervals, tests."""

from __future__ import annotations

import json

import pytest

from tests.helpers import run, strict_json
from tracecheck.episodes import EpisodeWriter, new_header
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.errors import BScopeError, BTypeError, InputError, TracecheckError
from tracecheck.interop import import_simb
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.stats.estimates import statistics
from tracecheck.stats.properties import load_properties, parse_properties

HIGHWAY_SET = load_properties("highway")


@pytest.fixture(scope="module")
def paper_runs(paper_traces, tmp_path_factory):
    folder = tmp_path_factory.mktemp("paper")
    paths = []
    for name in ("base", "base_shield"):
        path = folder / f"{name}.mcap"
        write_run(path, new_header("imported-simb", variables=list(HIGHWAY.variables)), import_simb([paper_traces / "simb" / name], vocab=HIGHWAY))
        paths.append(path)
    return paths


EXPECTED = {  # from the issue: the paper's published SimB tasks on these traces
    "base": ({"episode_length": (38.25, 25.09), "velocity": (23.53, 2.01),
              "distance": (870.60, 547.06), "right_lane": (32.95, 23.83),
              "total_reward": (30.29, 19.73)}, [55, 100, 90, 100, 100, 5]),
    "base_shield": ({"episode_length": (58.95, 4.70), "velocity": (21.48, 0.77),
                     "distance": (1265.09, 109.84), "right_lane": (40.38, 17.69),
                     "total_reward": (44.61, 3.74)}, [95, 85, 95, 100, 100, 55]),
}


def test_paper_tables_on_paper_traces(paper_runs):
    result = statistics(paper_runs, HIGHWAY_SET)
    for run_ in result["runs"]:
        metrics, saf = EXPECTED[run_["name"]]
        for name, (mean, sd) in metrics.items():
            assert round(run_["metrics"][name]["mean"], 2) == mean, name
            assert round(run_["metrics"][name]["sd"], 2) == sd, name
        assert [round(100 * run_["properties"][f"SAF{i}"]["ratio"]) for i in range(1, 7)] == saf


AGG = """
[metrics.n]
aggregate = "steps"
[metrics.avg]
expression = "Reward"
aggregate = "average"
[metrics.total]
expression = "Reward"
aggregate = "sum"
[metrics.between]
expression = "Reward"
aggregate = "sum_between_steps"
[metrics.low]
expression = "VehiclesX(EgoVehicle)"
aggregate = "min"
[metrics.high]
expression = "VehiclesX(EgoVehicle)"
aggregate = "max"
estimate = { value = 140.0, epsilon = 1.0 }
[properties.never_crash]
predicate = "Crash = FALSE"
[properties.ever_far]
predicate = "VehiclesX(EgoVehicle) > 120.0"
kind = "eventually"
[properties.ends_far]
predicate = "VehiclesX(EgoVehicle) > 140.0"
kind = "final"
test = { p = 0.9, alpha = 0.05, tail = "left" }
"""


def test_aggregates_by_hand(hand_run):
    pset = parse_properties(AGG, name="hand", file="hand.toml")
    result = statistics([hand_run], pset)
    (r,) = result["runs"]
    m, p = r["metrics"], r["properties"]
    # episode 0: rewards 0,1,2 (n=2); episode 1: rewards 0,4 (n=1)
    assert m["n"]["mean"] == 1.5
    assert m["avg"]["mean"] == pytest.approx((1.0 + 2.0) / 2)        # (1.0 + 2.0) / 2
    assert m["total"]["mean"] == pytest.approx((3.0 + 4.0) / 2)
    # between steps: ep0 (0+1)/2 + (1+2)/2 = 2.0; ep1 (0+4)/2 = 2.0
    assert m["between"]["mean"] == pytest.approx(2.0) and m["between"]["sd"] == 0.0
    assert m["low"]["mean"] == 100.0 and m["high"]["mean"] == 140.0
    assert m["high"]["estimate"]["within"] is True
    from tracecheck.render.stats_text import stats_rows

    _, rows = stats_rows(result)  # the text says the estimation check too (it was json only)
    high = next(row for row in rows if row[0].startswith("high"))
    assert high[1].endswith("; estimate 140 ± 1 (mean): within"), high
    assert (p["never_crash"]["holds"], p["ever_far"]["holds"], p["ends_far"]["holds"]) == (
        1, 2, 1)
    test = p["ends_far"]["test"]
    assert test["tail"] == "left" and 0 < test["exact_p_value"] <= 1


def test_intervals_and_tests_against_reference_values(hand_run):
    from tracecheck.stats.properties import HypothesisTest, Property
    from tracecheck.stats.estimates import _hypothesis, _property_stats
    import numpy as np

    holds = np.array([True] * 13 + [False] * 37)
    prop = Property("x", "TRUE = TRUE", None, test=HypothesisTest(0.5, 0.05, "left"))
    wilson = _property_stats(holds, prop, "wilson")
    exact = _property_stats(holds, prop, "clopper-pearson")
    # python -c "from scipy.stats import binomtest as b; r=b(13,50);
    #   print(r.proportion_ci(method='wilson'), r.proportion_ci(method='exact'))"
    assert wilson["ci95"] == pytest.approx([0.158715, 0.395532], abs=1e-6)
    assert exact["ci95"] == pytest.approx([0.146301, 0.403448], abs=1e-6)
    t = _hypothesis(13, 50, prop)
    # python -c "from scipy.stats import binomtest, norm; import math;
    #   z = (0.26 - 0.5) / math.sqrt(0.25 / 50); print(z, norm.cdf(z),
    #   binomtest(13, 50, 0.5, alternative='less').pvalue)"
    assert t["z"] == pytest.approx(-3.394113, abs=1e-6)
    assert t["normal_p_value"] == pytest.approx(3.4426e-4, rel=1e-4)
    assert t["exact_p_value"] == pytest.approx(4.6811e-4, rel=1e-4)
    assert t["normal_rejected"] and t["exact_rejected"]


@pytest.mark.parametrize("p,tail,k,rejected", [
    (1.0, "left", 50, False), (1.0, "left", 49, True), (0.0, "right", 0, False),
    (0.0, "right", 1, True), (1.0, "two", 49, True)])
def test_a_test_of_probability_0_or_1_is_the_exact_point_mass(p, tail, k, rejected):
    """PROBABILITY 1.0 or 0.0 divided by σ = 0 (a ZeroDivisionError traceback): the
    binomial is a point mass, decided exactly."""
    from tracecheck.stats.estimates import _hypothesis
    from tracecheck.stats.properties import HypothesisTest, Property

    t = _hypothesis(k, 50, Property("x", "TRUE = TRUE", None,
                                    test=HypothesisTest(p, 0.05, tail)))
    assert t["z"] is None and t["normal_p_value"] == t["exact_p_value"]
    assert t["exact_rejected"] is rejected and "σ = 0" in t["method"]


def test_paired_comparison_on_sample_traces():
    from tests.helpers import ROOT

    result = statistics([ROOT / "sample_traces" / "base_none.mcap",
                         ROOT / "sample_traces" / "base_paper.mcap"],
                        HIGHWAY_SET.select(["SAF1", "episode_length"]))
    (c,) = result["comparisons"]
    assert c["pairs"] == 24 and c["properties"]["SAF1"]["method"] == "exact McNemar"
    assert c["metrics"]["episode_length"]["wilcoxon_p"] is not None


def test_empty_run_is_reported_as_such(tmp_path):
    path = tmp_path / "empty.mcap"
    with EpisodeWriter(path, new_header("recorded", environment="highway")):
        pass
    (r,) = statistics([path], HIGHWAY_SET)["runs"]
    assert r["episodes"] == 0 and r["note"] == "no episodes: nothing to estimate"
    assert r["properties"] == {}


@pytest.mark.parametrize("text,exc,fragment", [
    ("[metrics.x\nexpression = 1", InputError, "not valid TOML"),
    ('[properties.p]\npredicate = "Speed > 1.0"', BScopeError, "unknown identifier Speed"),
    ('[properties.p]\npredicate = "Reward + 1.0"', BTypeError, "must be a predicate"),
    ('[metrics.m]\nexpression = "Reward"\naggregate = "median"', InputError,
     "unknown aggregate 'median'; the aggregates are steps, average, sum, sum_between_steps"),
    ('[properties.p]\npredicate = "Crash = FALSE"\ntest = { p = 1.5 }', InputError,
     "p must lie strictly between 0 and 1, not 1.5"),
    ('[properties.p]\npredicate = "Crash = FALSE"\ntest = { p = 0.5, alpha = 0 }', InputError,
     "alpha must lie strictly between 0 and 1, not 0"),
    ('[properties.p]\npredicate = "Crash = FALSE"\nkind = "always"', InputError,
     "unknown kind 'always'; the kinds are invariant, eventually, final"),
    ('[properties.p]\npredicate = "Crash = "', Exception, "unexpected end"),
    ('[metrics.m]\nexpression = "Reward + 1"', BTypeError, "REAL vs INTEGER"),
    ("x = " + "[" * 30000 + "]" * 30000, InputError,
     "not a property file: its arrays or tables nest thousands of levels deep"),
])
def test_bad_property_files(tmp_path, hand_run, text, exc, fragment):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(exc) as info:
        statistics([hand_run], load_properties(path))
    assert fragment in str(info.value)


def test_unknown_names_and_interval(hand_run):
    with pytest.raises(InputError, match="has no metric or property SAF9"):
        HIGHWAY_SET.select(["SAF9"])
    with pytest.raises(InputError, match="unknown interval method 'agresti'"):
        statistics([hand_run], HIGHWAY_SET, interval="agresti")


def test_stats_cli(capsys, paper_runs, tmp_path):
    code, out, _ = run(capsys, "stats", *map(str, paper_runs), "--json")
    data = json.loads(out)
    assert code == 0 and [r["name"] for r in data["runs"]] == ["base", "base_shield"]
    saf1 = data["runs"][0]["properties"]["SAF1"]
    assert (saf1["holds"], saf1["episodes"], saf1["ratio"]) == (11, 20, 0.55)
    assert len(saf1["ci95"]) == 2 and data["runs"][0]["metrics"]["velocity"]["ci95"]
    code, out, _ = run(capsys, "stats", *map(str, paper_runs), "--format", "csv")
    assert out.splitlines()[0].startswith("run,file,episodes,name,kind,value")
    code, out, _ = run(capsys, "stats", *map(str, paper_runs), "--format", "md")
    assert "| Episode length [s] | 38.25 ± 25.09" in out
    code, _, err = run(capsys, "stats", str(paper_runs[0]), "--plot", str(tmp_path / "p"))
    assert code == 0 and (tmp_path / "p" / "properties.png").exists()
    assert (tmp_path / "p" / "properties.svg").exists()
    assert (tmp_path / "p" / "metric_velocity.svg").exists()
    code, _, err = run(capsys, "stats", str(paper_runs[0]), "--properties", "nope.toml")
    assert code == 2 and "no such property file: nope.toml" in err


def test_simulate_stops_when_intervals_are_narrow(capsys, tmp_path):
    from tests.helpers import ROOT

    out = tmp_path / "sim.mcap"
    code, text, err = run(capsys, "simulate", "--agent",
                          str(ROOT / "models" / "agents" / "base.zip"), "--shield", "paper",
                          "--episodes", "30", "--duration", "4", "--until-ci-width", "0.9",
                          "-o", str(out), "--json")
    data = json.loads(text)
    seq = data["sequential"]
    assert code == 0 and seq["stopped_early"] and seq["looks"] == 1
    assert "Bonferroni over 3 planned looks" in seq["rule"]
    assert data["runs"][0]["episodes"] == 10 < 30
    code, text, _ = run(capsys, "simulate", "--agent",
                        str(ROOT / "models" / "agents" / "base.zip"), "--episodes", "3",
                        "--duration", "3", "-o", str(out), "--force", "--json")
    data = json.loads(text)
    assert "sequential" not in data and data["runs"][0]["episodes"] == 3
    code, _, err = run(capsys, "simulate", "--agent",
                       str(ROOT / "models" / "agents" / "base.zip"), "--episodes", "3",
                       "--until-ci-width", "2", "-o", str(out))
    assert code == 2 and "must lie strictly between 0 and 1" in err


def test_ltl_properties_by_hand(hand_run, tmp_path):
    """kind = "ltl": the formula holds for the episode, read in the environment's machine
    (the paper shield for the highway); the same share as the state predicate it restates,
    and a hypothesis test on it."""
    path = tmp_path / "ltl.toml"
    path.write_text('[properties.never_crash]\npredicate = "G({Crash = FALSE})"\n'
                    'kind = "ltl"\ntest = { p = 0.9, alpha = 0.05, tail = "left" }\n'
                    '[properties.far_once_moving]\n'
                    'predicate = "F({VehiclesX(EgoVehicle) > 120.0} & Y true)"\nkind = "ltl"\n'
                    '[properties.state_form]\npredicate = "Crash = FALSE"\n')
    (r,) = statistics([hand_run], load_properties(path))["runs"]
    props = r["properties"]
    assert props["never_crash"]["holds"] == props["state_form"]["holds"] == 1
    assert props["far_once_moving"]["holds"] == 2
    assert "test" in props["never_crash"]
    path.write_text('[properties.bad]\npredicate = "G({Crash = FALSE}"\nkind = "ltl"\n')
    with pytest.raises(Exception, match=r"ltl.toml: property bad:1:18: expected '\)'"):
        statistics([hand_run], load_properties(path))
    path.write_text('[properties.bad]\npredicate = 3\nkind = "ltl"\n')
    with pytest.raises(InputError, match="predicate must be a string with an LTL formula"):
        load_properties(path)
    path.write_text('[properties.bad]\npredicate = "G({Crash = FALSE})"\n'
                    'kind = "invariant"\n')  # a temporal formula of another kind
    with pytest.raises(TracecheckError) as info:
        load_properties(path)
    assert info.value.hint == 'a temporal formula: kind = "ltl" (or "stl" for its robustness)'


def test_stl_metrics_and_properties_by_hand(hand_run, tmp_path):
    """aggregate = "stl": the robustness per episode; kind = "stl": the episodes keeping it."""
    path = tmp_path / "stl.toml"
    path.write_text('[metrics.margin]\nexpression = "G({VehiclesX(EgoVehicle) >= 90.0})"\n'
                    'aggregate = "stl"\n'
                    '[properties.far]\npredicate = "F({VehiclesX(EgoVehicle) > 140.0})"\n'
                    'kind = "stl"\n')
    result = statistics([hand_run], load_properties(path))
    (r,) = result["runs"]
    assert r["metrics"]["margin"]["mean"] == 10.0 and r["metrics"]["margin"]["sd"] == 0.0
    assert r["properties"]["far"]["holds"] == 1  # ep. 0 peaks at 130 (-10), ep. 1 at 150 (+10)
    path.write_text('[properties.bad]\npredicate = "G({Crash = FALSE})"\nkind = "stl"\n')
    with pytest.raises(Exception, match=r"the atom \{Crash = FALSE\} is not a comparison"):
        statistics([hand_run], load_properties(path))


def test_an_stl_property_at_robustness_0_is_decided_by_its_truth(hand_run, tmp_path):
    """Each episode's least x is 100: G({x >= 100.0}) holds in both (robustness 0 — counted
    as broken, 0 %, where falsify said kept: a new user's battery), G({x > 100.0}) in none."""
    path = tmp_path / "edge.toml"
    path.write_text('[properties.at_least]\npredicate = "G({VehiclesX(EgoVehicle) >= 100.0})"\n'
                    'kind = "stl"\n[properties.above]\n'
                    'predicate = "G({VehiclesX(EgoVehicle) > 100.0})"\nkind = "stl"\n'
                    '[metrics.rho]\nexpression = "G({VehiclesX(EgoVehicle) >= 100.0})"\n'
                    'aggregate = "stl"\n')
    (r,) = statistics([hand_run], load_properties(path))["runs"]
    assert r["metrics"]["rho"]["mean"] == 0.0 and r["metrics"]["rho"]["sd"] == 0.0
    assert r["properties"]["at_least"]["holds"] == 2 and r["properties"]["above"]["holds"] == 0


# ------------------------------------------------------------------ inert outputs, bounds


def test_stats_json_is_strict_with_an_infinite_stl_robustness(capsys, hand_run, tmp_path):
    """G[a,b] past every episode's end has robustness +inf: the JSON said Infinity / NaN,
    which is not JSON; now null, with a note saying why."""
    path = tmp_path / "inf.toml"
    path.write_text('[metrics.late]\nexpression = "G[10,20]({VehiclesX(EgoVehicle) > 0.0})"\n'
                    'aggregate = "stl"\n[metrics.fine]\nexpression = "Reward"\n')
    code, out, err = run(capsys, "stats", str(hand_run), str(hand_run), "-p", str(path), "--json")
    assert code == 0 and "Warning" not in err, err
    data = strict_json(out)
    late = data["runs"][0]["metrics"]["late"]
    assert late["mean"] is None and late["sd"] is None and late["ci95"] == [None, None]
    assert late["mean_note"].startswith("not finite: of 2 episodes, 2 +inf (the formula has no "
                                        "sample to judge there")
    assert "G[a,b] past its end" in late["sd_note"]
    assert data["runs"][0]["metrics"]["fine"]["mean"] == pytest.approx(1.5)  # (1 + 2) / 2
    paired = data["comparisons"][0]["metrics"]["late"]
    assert paired["mean_difference"] is None and paired["wilcoxon_p"] is None
    assert "not finite" in paired["mean_difference_note"]
    code, out, _ = run(capsys, "stats", str(hand_run), "-p", str(path), "--format", "csv")
    assert code == 0 and ",late,metric,inf,nan,nan,nan,," in out


def test_stats_plots_draw_dollars_as_text(capsys, hand_run, tmp_path):
    """"$\\frac{1}$" in a description or a run's name crashed stats --plot (matplotlib read
    it as mathtext)."""
    import shutil

    path = tmp_path / "dollars.toml"
    path.write_text('[metrics.m]\nexpression = "Reward"\ndescription = "$\\\\frac{1}$"\n'
                    '[properties.p]\npredicate = "Crash = FALSE"\ndescription = "$$"\n')
    run_ = tmp_path / "$\\frac{1}$ run.mcap"
    shutil.copy(hand_run, run_)
    code, _, err = run(capsys, "stats", str(run_), "-p", str(path), "--plot",
                       str(tmp_path / "plots"))
    assert code == 0, err
    svg = (tmp_path / "plots" / "metric_m.svg").read_text()
    assert "$\\frac{1}$" in svg  # the title, as text (matplotlib keeps it in a comment)
    import matplotlib

    assert matplotlib.rcParams["text.parse_math"]  # only the plots are plain


def test_huge_stl_bounds_answer_at_once(hand_run, tmp_path):
    """G[0,100000000] looped over the bound; any bound now costs one pass."""
    import time

    path = tmp_path / "big.toml"
    path.write_text('[metrics.a]\nexpression = "G[0,100000000]({VehiclesX(EgoVehicle) >= 90.0})"'
                    '\naggregate = "stl"\n[metrics.b]\nexpression = '
                    '"G[0,99999999999999999999999]({VehiclesX(EgoVehicle) >= 90.0})"\n'
                    'aggregate = "stl"\n[metrics.c]\nexpression = "G({VehiclesX(EgoVehicle) >= 90.0})"'
                    '\naggregate = "stl"\n')
    start = time.perf_counter()
    (r,) = statistics([hand_run], load_properties(path))["runs"]
    assert time.perf_counter() - start < 10
    assert r["metrics"]["a"]["mean"] == r["metrics"]["b"]["mean"] == r["metrics"]["c"]["mean"] \
        == 10.0


@pytest.mark.parametrize("text,fragment", [
    ('metrics = "x"', "metrics: expected tables [metrics.NAME], got the string 'x'"),
    ("properties = [1, 2]", "properties: expected tables [properties.NAME], got the array "
                            "[1, 2]"),
    ("[properties]\np = 1", "property p: expected a table (a property), got the number 1"),
    ('[metrics."a\\u0000b"]\naggregate = "steps"', "metrics.'a\\x00b': a metric name must be "
                                                  "non-empty printable text"),
    ('[properties."x\\u001b[2J"]\npredicate = "Crash = FALSE"', "a property name must be"),
    ('[metrics.""]\naggregate = "steps"', "metrics.'': a metric name must be non-empty"),
    ('[metrics.m]\nagregate = "sum"\nexpression = "Reward"',
     "metric m: unknown key 'agregate'; a metric has expression, aggregate, estimate, "
     "description"),
    ('[properties.p]\npredicate = "Crash = FALSE"\ntest = { p = 0.5, alfa = 0.1 }',
     "property p: test: unknown key 'alfa'"),
    ('[metrics.m]\naggregate = 5', "metric m: unknown aggregate 5"),
    ('[properties.p]\npredicate = "Crash = FALSE"\nkind = ["ltl"]', "unknown kind ['ltl']"),
    ('[metrics.m]\nexpression = "Reward"\nestimate = 3',
     "metric m: estimate: expected a table (an estimate {value = …, epsilon = …}), got the "
     "number 3"),
    ('[metrics.m]\nexpression = "Reward"\nestimate = { value = 1e400, epsilon = 1 }',
     "estimate value must be a finite number, not the number inf"),
    ('[metrics.m]\nexpression = "Reward"\nestimate = { value = ' + "9" * 400 + ', epsilon = 1 }',
     "estimate value must be a finite number, not the number 999"),
    ('[metrics.m]\nexpression = "Reward"\nestimate = { value = nan, epsilon = 1 }',
     "must be a finite number, not the number nan"),
    ('[metrics.m]\nexpression = "Reward"\nestimate = { value = 1, epsilon = -1 }',
     "estimate epsilon must be at least 0, not -1"),
    ('[metrics.m]\nexpression = "Reward"\ndescription = 3',
     "metric m: description must be a string, not the number 3"),
    ('[metrics.m]\nexpression = "Reward"\ndescription = "\\u001b[31mred"',
     "description holds a control character"),
    ('[properties.p]\npredicate = "Crash = FALSE"\ntest = { p = true }',
     "p must be a number, not the boolean true"),
    ('[properties.p]\npredicate = "Crash = FALSE"\n[metrics.p]\naggregate = "steps"',
     "'p' names both a metric and a property"),
    ("[properties.p]", "property p predicate must be a string with a B predicate"),
])
def test_wrongly_typed_property_files_name_the_file_and_entry(capsys, tmp_path, hand_run, text,
                                                             fragment):
    """Each was a traceback (AttributeError, OverflowError) or silently ignored (a misspelt
    key); now exit 2 naming the file and the entry."""
    path = tmp_path / "props.toml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_properties(path)
    assert f"{path}: " in str(info.value) and fragment in str(info.value)
    code, _, err = run(capsys, "stats", str(hand_run), "-p", str(path))
    assert code == 2 and err.startswith("error: ") and fragment in err
    assert "Traceback" not in err


NONE = "sample_traces/base_none.mcap"


@pytest.mark.parametrize("expression, aggregate, fragment", [
    ("2 ** 100000", "sum", "metric m: sample_traces/base_none.mcap, episode 0, step 0: the value "
     "of `2 ** 100000`, an integer of about 30,103 digits, does not fit a float"),
    ("10 ** 400", "max", "episode 0, step 0: the value of `10 ** 400`, an integer of about 401 "
     "digits, does not fit a float"),
    ("IF card(PresentVehicles) > 4 THEN 10 ** 400 ELSE 1 END", "average",
     "does not fit a float"),
    ("{2 ** 100000 >= 1}", "stl", "metric m: sample_traces/base_none.mcap, episode 0, step 0: "
     "the value of a side of the atom {2 ** 100000 >= 1}, an integer of about 30,103 digits, "
     "does not fit a float"),
], ids=["sum", "max", "some-rows", "stl"])
def test_an_integer_too_large_for_a_float_is_an_error_naming_the_row(capsys, tmp_path,
                                                                    expression, aggregate,
                                                                    fragment):
    """B integers are exact; statistics are floats: an OverflowError traceback before,
    never infinity now. Batch and scalar rows (IF …) give the same answer."""
    from tests.helpers import ROOT

    path = tmp_path / "p.toml"
    path.write_text(f'[metrics.m]\nexpression = "{expression}"\naggregate = "{aggregate}"\n')
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(ROOT)
        code, out, err = run(capsys, "stats", NONE, "--properties", str(path))
    assert code == 2 and out == "" and "Traceback" not in err
    assert fragment in " ".join(err.split()), err
    assert f"{path}: metric m: " in " ".join(err.split())


def test_an_integer_that_fits_a_float_is_its_value(capsys, tmp_path):
    from tests.helpers import ROOT

    path = tmp_path / "p.toml"
    path.write_text('[metrics.m]\nexpression = "2 ** 1000"\naggregate = "max"\n')
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(ROOT)
        code, out, err = run(capsys, "stats", NONE, "--properties", str(path), "--json")
    assert code == 0, err
    assert json.loads(out)["runs"][0]["metrics"]["m"]["mean"] == float(2 ** 1000)


def test_an_imported_run_of_another_machine_is_not_taken_for_the_highways(tmp_path):
    """Issue 23: a file naming no environment (imported with --model) was read as the
    highway's: without --properties, the highway's set ("unknown identifier VehiclesVx")."""
    from tracecheck.stats.formulas import default_set, environment_of

    path = tmp_path / "lake.mcap"
    steps = tuple(StepRecord(k, float(k), None if k == 0 else "Move_Right", {"x": k, "y": 0},
                             0.0, False) for k in range(3))
    with EpisodeWriter(path, new_header("imported-prob2trace", model_name="FrozenLake",
                                        variables=["x", "y"],
                                        actions=["Move_Right"])) as w:
        w.write(Episode(0, steps, make_end(steps, "end-of-trace")))
    assert environment_of(path) == "FrozenLake"
    pset, notes = default_set([path])
    assert "these runs name no environment and no installed one claims their states" in notes[0]
    result = statistics([path], pset)
    assert result["runs"][0]["metrics"]["episode_length"]["mean"] == 2


def test_four_runs_at_80_columns_keep_their_labels(tmp_path):
    """Issue 42: `stats` of four runs at 80 columns collapsed the row-label column — numbers
    without names. The runs now go into as many tables as the width needs, each with the
    labels."""
    import io
    import shutil

    from rich.console import Console

    from tests.helpers import ROOT
    from tracecheck.render.stats_text import _stats_text

    runs = []
    for name in ("a", "b", "c", "d"):
        runs.append(tmp_path / f"{name}.mcap")
        shutil.copy(ROOT / "sample_traces" / "base_paper.mcap", runs[-1])
    result = statistics(runs, load_properties("highway"))
    for width, tables in ((80, 2), (200, 1)):
        stream = io.StringIO()
        _stats_text(Console(file=stream, width=width, force_terminal=False), result)
        text = stream.getvalue()
        table_lines = [line for line in text.splitlines() if line[:1] in "┃│┏┡├└"]
        assert max(len(line) for line in table_lines) <= width
        assert text.count("│ Episode length [s]") == tables  # whole, in every table
        heads = [line for line in table_lines if line.startswith("┃") and "ep.)" not in line]
        assert sorted(c.strip() for line in heads for c in line.strip("┃").split("┃")[1:]) \
            == ["a", "b", "c", "d"]
