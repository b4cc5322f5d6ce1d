"""diff of continuous actions: a changed step says the recorded values, the values each
shield allowed in the state before and how the allowed interval moved — in text, JSON,
CSV and Markdown; a set that cannot be computed is said in its row, the rest of the diff
goes on; the rows with allowed sets are bounded."""

from __future__ import annotations

import csv
import io
import json

import pytest

from tests.helpers import run, strict_json
from tracecheck.checking.diffing import diff
from tracecheck.checking.shield import load_shield
from tracecheck.episodes import new_header
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import Episode, StepRecord, make_end

#: a car behind another: accelerate by a while the gap left stays over MARGIN; v2 lowers the
#: margin from 10 to 8.5 (a's upper end + 0.75) and allows no acceleration above 25 m/s
CAR = """MACHINE Car
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL
INITIALISATION Gap, Speed := 50.0, 20.0
OPERATIONS
  ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 & Gap - FACTOR * (Speed + a) > MARGIN EXTRA
                  THEN Gap, Speed :(Gap : REAL & Speed : REAL) END
END
"""


def car(tmp_path, name: str, margin: str, extra: str = "", factor: str = "2.0"):
    path = tmp_path / f"{name}.mch"
    path.write_text(CAR.replace("FACTOR", factor).replace("MARGIN", margin)
                    .replace("EXTRA", extra))
    return path


V2_EXTRA = "& a <= IF Speed > 25.0 THEN 0.0 ELSE 2.0 END"


def s(gap: float, speed: float) -> dict:
    return {"Gap": gap, "Speed": speed}


def make(eid: int, start: dict, moves) -> Episode:
    """From ``start``, each move (a, the state after)."""
    steps = [StepRecord(0, 0.0, None, start, 0.0, False)]
    for k, (a, after) in enumerate(moves, 1):
        steps.append(StepRecord(k, float(k), "ACCELERATE", after, 1.0, False,
                                parameters={"a": a}))
    steps = tuple(steps)
    return Episode(eid, steps, make_end(steps), seed=eid)


def record(path, episodes):
    write_run(path, new_header("recorded", actions=["ACCELERATE"],
                               action_parameters={"ACCELERATE": ["a"]}, action_low=[-4.0],
                               action_high=[2.0], shield_mode="project"), episodes)
    return path


@pytest.fixture
def versions(tmp_path):
    """(the run, v1, v2): at gap 51 and 20 m/s v1 allows a < 0.5, v2 a < 1.25 (1 newly
    allowed); at 100 and 30 v1 allows up to 2, v2 up to 0 (1 newly blocked); at 13 and 6
    v1 allows nothing, v2 a < -3.75 (-4, the fallback, newly allowed); at 60 and 20 both
    allow 0.5 (unchanged)."""
    episodes = [make(0, s(51.0, 20.0), [(1.0, s(100.0, 30.0)), (1.0, s(13.0, 6.0)),
                                        (-4.0, s(60.0, 20.0)), (0.5, s(60.0, 20.0))])]
    return (record(tmp_path / "run.mcap", episodes), car(tmp_path, "v1", "10.0"),
            car(tmp_path, "v2", "8.5", V2_EXTRA))


def flat(text: str) -> str:
    return " ".join(text.split())


def test_the_text_names_the_values_both_sets_and_how_they_moved(capsys, versions):
    path, v1, v2 = versions
    code, out, _ = run(capsys, "diff", path, "--shield", v2, "--against", v1)
    printed = flat(out)
    assert code == 0
    assert "changed steps: 3 (newly blocked 1, newly allowed 2: by v2, where v1 decided " \
        "otherwise)" in printed
    assert ("continuous actions at the changed steps — the recorded values, then what v1 "
            "allowed in the state before → what v2 allows, and how it moved:") in printed
    for line in ("episode 0, step 1: ACCELERATE(a=1) newly allowed: a ∈ [-4.0, 0.5) → "
                 "[-4.0, 1.25): upper end +0.75",
                 "episode 0, step 2: ACCELERATE(a=1) newly blocked: a ∈ [-4.0, 2.0] → "
                 "[-4.0, 0.0]: upper end -2",
                 "episode 0, step 3: ACCELERATE(a=-4) newly allowed: a ∈ ∅ → [-4.0, -3.75): "
                 "nothing was allowed"):
        assert line in printed, printed
    assert "step 4" not in printed  # allowed under both
    assert "not exactly a float" not in printed  # every end here is one


def test_the_json_gives_the_sets_structurally(capsys, versions):
    path, v1, v2 = versions
    code, out, _ = run(capsys, "diff", path, "--shield", v2, "--against", v1, "--json")
    data = strict_json(out)
    assert code == 0 and (data["details"], data["details_left_out"]) == (100, 0)
    first, second, third = data["changes"]
    assert first["parameters"] == {"a": 1.0}
    assert first["allowed"] == {
        "shield": {"text": "a ∈ [-4.0, 1.25)", "intervals": {"a": [[-4.0, 1.25]]},
                   "note": None},
        "against": {"text": "a ∈ [-4.0, 0.5)", "intervals": {"a": [[-4.0, 0.5]]},
                    "note": None},
        "moved": "upper end +0.75"}
    assert (second["feasible_under_shield"], second["allowed"]["moved"]) == (False,
                                                                             "upper end -2")
    assert second["allowed"]["shield"]["intervals"] == {"a": [[-4.0, 0.0]]}
    assert third["parameters"] == {"a": -4.0}
    assert third["allowed"]["against"] == {"text": "a ∈ ∅", "intervals": {"a": []},
                                           "note": None}
    assert third["allowed"]["moved"] == "nothing was allowed"


def test_csv_and_markdown_have_the_columns(capsys, versions):
    path, v1, v2 = versions
    code, out, _ = run(capsys, "diff", path, "--shield", v2, "--against", v1, "--format",
                       "csv")
    rows = list(csv.reader(io.StringIO(out)))
    assert code == 0 and rows[0][-4:] == ["parameters", "allowed by v1", "allowed by v2",
                                          "moved"]
    assert rows[1][-4:] == ["a=1.0", "a ∈ [-4.0, 0.5)", "a ∈ [-4.0, 1.25)", "upper end +0.75"]
    assert rows[3][-4:] == ["a=-4.0", "a ∈ ∅", "a ∈ [-4.0, -3.75)", "nothing was allowed"]
    code, out, _ = run(capsys, "diff", path, "--shield", v2, "--against", v1, "--format",
                       "md")
    assert code == 0
    assert ("| a=1.0 | a ∈ [-4.0, 0.5) | a ∈ [-4.0, 1.25) | upper end +0.75 |"
            in out.splitlines()[2])


def test_an_end_that_is_not_a_float_is_explained(capsys, tmp_path):
    """At gap 71 and 20 m/s, 71 - 3 (20 + a) > 10 is a < 1/3; with 8.5, a < 5/6."""
    path = record(tmp_path / "run.mcap", [make(0, s(71.0, 20.0), [(0.5, s(71.0, 20.0))])])
    v1 = car(tmp_path, "v1", "10.0", factor="3.0")
    v2 = car(tmp_path, "v2", "8.5", factor="3.0")
    code, out, _ = run(capsys, "diff", path, "--shield", v2, "--against", v1)
    printed = flat(out)
    assert code == 0
    assert ("episode 0, step 1: ACCELERATE(a=0.5) newly allowed: a ∈ [-4.0, "
            "0.3333333333333333…) → [-4.0, 0.8333333333333334…): upper end +0.5") in printed
    assert ("(an end followed by … is not exactly a float: the float nearest it is shown "
            "(the allowed set is computed exactly, over the reals))") in printed
    code, out, _ = run(capsys, "diff", path, "--shield", v2, "--against", v1, "--json")
    allowed = json.loads(out)["changes"][0]["allowed"]
    assert allowed["against"]["intervals"] == {"a": [[-4.0, 1 / 3]]}
    assert allowed["shield"]["intervals"] == {"a": [[-4.0, 5 / 6]]}


def test_replay_explains_such_an_end_too(capsys, tmp_path):
    path = record(tmp_path / "run.mcap", [make(0, s(71.0, 20.0), [(0.5, s(71.0, 20.0))])])
    code, out, _ = run(capsys, "replay", path, "--shield",
                       car(tmp_path, "v1", "10.0", factor="3.0"))
    printed = flat(out)
    assert code == 0 and "a ∈ [-4.0, 0.3333333333333333…)" in printed
    assert "(an end followed by … is not exactly a float" in printed


def test_a_guard_not_linear_is_the_solvers_set(capsys, tmp_path):
    """v3's guard squares a: its allowed set is the solver's, said as such."""
    path = record(tmp_path / "run.mcap", [make(0, s(51.0, 20.0), [(1.0, s(60.0, 20.0))])])
    v1 = car(tmp_path, "v1", "10.0")
    v3 = car(tmp_path, "v3", "8.5", "& a * a <= 4.0")
    code, out, _ = run(capsys, "diff", path, "--shield", v3, "--against", v1)
    assert code == 0
    assert ("episode 0, step 1: ACCELERATE(a=1) newly allowed: a ∈ [-4.0, 0.5) → a: not "
            "linear; decided by the solver") in flat(out)


def test_a_set_that_cannot_be_computed_is_said_in_its_row(capsys, tmp_path):
    """v3's guard has a set of reals: diff decides the step with the recorded value (the
    enabled set needs no allowed set here: the recorded value, or zero, passes in every
    state), and its row says why v3's set is not known."""
    path = record(tmp_path / "run.mcap", [make(0, s(51.0, 20.0), [(1.0, s(60.0, 20.0))])])
    v1 = car(tmp_path, "v1", "10.0")
    v3 = car(tmp_path, "v3", "8.5", "& (a : {0.0, 1.0} or a < 0.0)")
    code, out, _ = run(capsys, "diff", path, "--shield", v3, "--against", v1)
    assert code == 0
    flat_out = flat(out)
    why = flat_out[flat_out.index("v3: not computed"):].split(" (an end")[0].strip()
    assert why.startswith("v3: not computed: ") and "membership" in why
    why = why[len("v3: "):]
    assert (f"episode 0, step 1: ACCELERATE(a=1) newly allowed: a ∈ [-4.0, 0.5) → v3: "
            f"{why}") in flat_out
    code, out, _ = run(capsys, "diff", path, "--shield", v3, "--against", v1, "--json")
    allowed = json.loads(out)["changes"][0]["allowed"]
    assert allowed == {"shield": {"text": None, "intervals": None, "note": why},
                       "against": {"text": "a ∈ [-4.0, 0.5)", "intervals": {"a": [[-4.0, 0.5]]},
                                   "note": None},
                       "moved": None}


def test_the_allowed_sets_are_bounded(tmp_path):
    """Only the first ``details`` changed steps get their allowed sets, over all files; the
    others keep their values and are counted."""
    episodes = [make(e, s(51.0, 20.0), [(1.0, s(51.0, 20.0))] * 3) for e in range(2)]
    paths = [record(tmp_path / f"run{k}.mcap", episodes) for k in range(2)]
    v1, v2 = load_shield(car(tmp_path, "v1", "10.0")), load_shield(car(tmp_path, "v2", "8.5"))
    report = diff(paths, v2, v1, details=4)
    assert report.changed_steps == 12
    assert [c.allowed is not None for c in report.changes] == [True] * 4 + [False] * 8
    assert all(c.parameters == {"a": 1.0} for c in report.changes)
    assert (report.details, report.details_left_out) == (4, 8)


def test_the_text_says_how_many_were_left_out(tmp_path):
    from rich.console import Console

    from tracecheck.render.text import DiffOutput

    path = record(tmp_path / "run.mcap", [make(0, s(51.0, 20.0), [(1.0, s(51.0, 20.0))] * 2)])
    report = diff([path], load_shield(car(tmp_path, "v2", "8.5")),
                  load_shield(car(tmp_path, "v1", "10.0")), details=1)
    console = Console(file=io.StringIO(), width=200)
    DiffOutput(report, 40).text(console)
    printed = flat(console.file.getvalue())
    assert "episode 0, step 1: ACCELERATE(a=1) newly allowed: a ∈ [-4.0, 0.5) → " in printed
    assert ("episode 0, step 2: ACCELERATE(a=1) newly allowed: allowed sets left out (only "
            "the first 1 are computed)") in printed
    DiffOutput(report, 1).text(console)
    printed = flat(console.file.getvalue())
    assert ("… 1 more changed step(s): --format csv or json lists them all (with the allowed "
            "sets of the first 1 of continuous actions; 1 more have their values only)"
            in printed)
    left_out = "left out (only the first 1 are computed)"
    assert DiffOutput(report, 1).table().rows[1][-4:] == ("a=1.0", left_out, left_out, "")


def test_a_discrete_diff_is_as_before(capsys):
    """No continuous lines nor columns for discrete actions."""
    from tests.helpers import ROOT

    none = ROOT / "sample_traces" / "base_none.mcap"
    code, out, _ = run(capsys, "diff", none, "--shield", "strict", "--against", "paper",
                       "--format", "csv")
    assert code == 0 and out.splitlines()[0] == (
        "file,episode,step,action,strict,paper,enabled by strict,enabled by paper")
    code, out, _ = run(capsys, "diff", none, "--shield", "strict", "--against", "paper",
                       "--json")
    change = json.loads(out)["changes"][0]
    assert (change["parameters"], change["allowed"]) == (None, None)
