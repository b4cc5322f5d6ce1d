"""Every command that prints a table: --format text|md|csv|json, and text that fits 80 columns
without breaking a word."""

from __future__ import annotations

import csv
import io
import json

import pytest

from tests.helpers import ROOT, run, untimed
from tracecheck.render.tables import TableData, csv_text, fitted, markdown

NONE = str(ROOT / "sample_traces" / "base_none.mcap")
PAPER = str(ROOT / "sample_traces" / "base_paper.mcap")

# command, the CSV header, how many CSV rows
TABLES = {
    "replay": (["replay", NONE, "--shield", "paper"],
               ["file", "episode", "steps", "first infeasible", "allowed there", "shielded",
                "infeasible", "crash", "crash after a blocked step", "other"], 24),
    "diff": (["diff", NONE, "--shield", "strict", "--against", "paper"],
             ["file", "episode", "step", "action", "strict", "paper", "enabled by strict",
              "enabled by paper"], None),
    "stats": (["stats", NONE, PAPER],
              ["run", "file", "episodes", "name", "kind", "value", "sd", "ci95_low",
               "ci95_high", "holds", "method"], 2 * 15),  # generic (5) + the paper's (11) - 1
    "info": (["info", NONE, PAPER], ["file", "source", "episodes", "steps", "crashes", "model"],
             2),
    "envs": (["envs"], ["name", "environment", "actions", "variables", "shield", "installed",
                        "description", "brings", "horizon"],
             None),
    "check-model": (["check-model", "paper"],
                    ["kind", "name", "value or type", "guard", "description"], 1 + 1 + 9 + 5),
    "guards": (["guards", "paper", "--state", str(ROOT / "models" / "examples" /
                                                  "state_approaching.json")],
               ["operation", "enabled"], 5),
    "prove": (["prove", "paper", "--deadlock-free"],
              ["obligation", "status", "reason", "reading", "decisions",
               "counterexample file"], 1),
}


@pytest.mark.parametrize("name", sorted(TABLES))
def test_csv_md_and_json_of_every_table(capsys, name):
    args, header, count = TABLES[name]
    code, out, _ = run(capsys, *args, "--format", "csv")
    rows = list(csv.reader(io.StringIO(out)))
    assert code == 0 and rows[0] == header, out[:300]
    assert count is None and len(rows) > 1 or len(rows) - 1 == count
    code, md, _ = run(capsys, *args, "--format", "md")
    assert code == 0
    assert "| " + " | ".join(header) + " |" in md or name in ("replay", "stats"), md[:300]
    assert "|---|" in md
    code, as_json, _ = run(capsys, *args, "--json")
    code2, fmt_json, _ = run(capsys, *args, "--format", "json")
    assert code == code2 == 0
    first, second = json.loads(as_json), json.loads(fmt_json)
    assert untimed(first) == untimed(second)


def test_two_formats_at_once_are_refused(capsys):
    code, _, err = run(capsys, "info", NONE, "--json", "--format", "csv")
    assert code == 2 and "--json and --format csv ask for two formats; give one" in err


def test_replay_csv_names_actions_in_full(capsys):
    code, out, _ = run(capsys, "replay", NONE, "--shield", "paper", "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and rows[0]["file"] == "base_none.mcap" and rows[0]["episode"] == "0"
    assert rows[1]["first infeasible"] == "2 LANE_LEFT"
    assert rows[1]["allowed there"] == "IDLE FASTER SLOWER"


@pytest.mark.parametrize("args", [
    ["stats", NONE, PAPER, PAPER],
    ["info", NONE, PAPER, str(ROOT / "sample_traces" / "base_none.mcap")],
    ["envs"],
    ["check-model", "paper"],
], ids=["stats", "info", "envs", "check-model"])
def test_text_fits_80_columns_without_breaking_words(capsys, monkeypatch, args):
    monkeypatch.setenv("COLUMNS", "80")
    code, out, _ = run(capsys, *args)
    lines = out.splitlines()
    assert code == 0 and max(len(line) for line in lines) <= 80, max(lines, key=len)
    text = " ".join(out.split())
    for whole in {"stats": ["[42.21, 57.88]", "[1129.20, 1293.35]", "base_paper", "(24 ep.)"],
                  "info": ["HighwayEnvironment", "recorded", "episodes", "crashes"],
                  "envs": ["VehiclesVx,", "PresentVehicles,", "right_leg_on_ground,",
                           "highway-fast-v0"],
                  "check-model": ["POW(Vehicles*REAL)", "PresentVehicles"]}[args[0]]:
        assert whole in text, whole


def test_a_fitted_table_cuts_only_the_column_it_may():
    table = TableData.of(["file", "n"], [["a" * 50, "12345"], ["b", "1"]])
    lines = fitted(table, 30)
    assert max(map(len, lines)) <= 30 and lines[1].endswith("…  12345")
    assert fitted(table, 200)[1] == "a" * 50 + "  12345"


def test_markdown_and_csv_escape_what_they_must():
    table = TableData.of(["a|b", "c"], [["x|y", "line\nbreak"], ['"q", r', "\\"]])
    assert markdown(table).splitlines()[2] == "| x\\|y | line<br>break |"
    assert list(csv.reader(io.StringIO(csv_text(table)))) == [
        ["a|b", "c"], ["x|y", "line\nbreak"], ['"q", r', "\\"]]
    with pytest.raises(ValueError):
        TableData.of(["a"], [["1", "2"]])


# ------------------------------------------------------------------ inert formats

def test_csv_cells_a_spreadsheet_would_evaluate_are_prefixed():
    """OWASP's rule for text cells; numbers from typed data stay numbers (-3.5 is a number
    to a spreadsheet, not a formula), a float that is not finite is text like any other."""
    from tracecheck.render.tables import csv_rows

    cells = ["=1+1", "+cmd", "-2+3", "@SUM(A1)", "\tx", "\rx", "a=b", "", -3.5, 7, -2,
             float("-inf"), None, "-3.5"]
    table = TableData.of([f"c{i}" for i in range(len(cells))], [cells])
    expected = ["'=1+1", "'+cmd", "'-2+3", "'@SUM(A1)", "'\tx", "'\rx", "a=b", "", "-3.5", "7",
                "-2", "'-inf", "", "'-3.5"]
    assert list(csv.reader(io.StringIO(csv_text(table), newline="")))[1] == expected
    assert list(csv.reader(io.StringIO(csv_rows([cells]), newline="")))[0] == expected
    assert csv_rows([["=HYPERLINK(\"x\")", True]]) == "\"'=HYPERLINK(\"\"x\"\")\",True\r\n"


def test_markdown_cells_render_as_their_text():
    table = TableData.of(["<b>h</b>"], [["<img src=x onerror=alert(1)>"], ["a `code` & b|c"],
                                         ["\\|"], ["two\r\nlines"]])
    lines = markdown(table).splitlines()
    assert lines[0] == "| &lt;b&gt;h&lt;/b&gt; |"
    assert lines[2:] == ["| &lt;img src=x onerror=alert(1)&gt; |", "| a \\`code\\` &amp; b\\|c |",
                         "| \\\\\\| |", "| two<br>lines |"]


def test_file_names_reach_csv_and_markdown_inert(capsys, tmp_path, monkeypatch):
    """A run file named like a formula, or like HTML, is text in every table."""
    import shutil

    monkeypatch.chdir(tmp_path)
    for name in ("=1+2.mcap", "<img src=x onerror=alert(1)>.mcap"):
        shutil.copy(NONE, tmp_path / name)
    code, out, _ = run(capsys, "replay", "=1+2.mcap", "--shield", "paper", "--format", "csv")
    assert code == 0 and list(csv.DictReader(io.StringIO(out)))[0]["file"] == "'=1+2.mcap"
    code, out, _ = run(capsys, "stats", "=1+2.mcap", "--format", "csv")
    row = list(csv.DictReader(io.StringIO(out)))[0]
    assert code == 0 and (row["run"], row["file"]) == ("'=1+2", "'=1+2.mcap")
    float(row["value"])  # a number, as it was
    name = "<img src=x onerror=alert(1)>.mcap"
    for args in (["replay", name, "--shield", "paper", "--ltl", "G({1 < 2})"], ["stats", name]):
        code, out, _ = run(capsys, *args, "--format", "md")
        assert code == 0 and "<img" not in out and "&lt;img src=x onerror=alert(1)&gt;" in out
    assert "G({1 &lt; 2})" in out or "stats" == args[0]


def test_stats_csv_keeps_numbers_and_makes_text_inert():
    from tracecheck.render.stats_text import StatsOutput

    result = {"runs": [{"name": "=run", "file": "@f.mcap", "episodes": 2,
                        "metrics": {"-m": {"mean": -3.5, "sd": 0.5, "ci95": [-4.0, -3.0],
                                           "method": "t"}},
                        "properties": {}}]}
    rows = list(csv.reader(io.StringIO(StatsOutput(result).csv())))
    assert rows[1] == ["'=run", "'@f.mcap", "2", "'-m", "metric", "-3.5", "0.5", "-4.0", "-3.0",
                       "", "t"]


def test_replay_csv_and_markdown_carry_the_ltl_results(capsys):
    """--format csv used to drop the LTL results; now a column per formula, as in md."""
    args = ["replay", NONE, "--shield", "paper", "--ltl", "G({Crash = FALSE})", "--ltl",
            "F [FASTER]"]
    code, out, _ = run(capsys, *args, "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(out)))
    first, second = "LTL --ltl 1: G({Crash = FALSE})", "LTL --ltl 2: F [FASTER]"
    assert code == 0 and list(rows[0])[-2:] == [first, second]  # the formula text too
    assert rows[3][first] == "violated at step 39" and rows[0][first] == "holds"
    assert {r[second] for r in rows} == {"holds", "violated"}  # F: no step to name
    code, as_json, _ = run(capsys, *args, "--json")
    violated = {v["episode"] for v in json.loads(as_json)["ltl"][0]["violations"]}
    assert violated == {int(r["episode"]) for r in rows if r[first] != "holds"}
    code, md, _ = run(capsys, *args, "--format", "md")
    assert f"| {first} | {second} |" in md and "| violated at step 39 | holds |" in md
