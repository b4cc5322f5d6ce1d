"""Every command that prints a table: --format text|md|csv|json, and text that fits 80 columns
without breaking a word."""

from __future__ import annotations

import csv
import io
import json

import pytest

from tests.cli.test_cli import run
from tests.conftest import ROOT
from tracecheck.render.tables import TableData, csv_text, fitted, markdown

NONE = str(ROOT / "sample_traces" / "base_none.mcap")
PAPER = str(ROOT / "sample_traces" / "base_paper.mcap")

# command, the CSV header, how many CSV rows
TABLES = {
    "replay": (["replay", NONE, "--shield", "paper"],
               ["file", "episode", "steps", "first infeasible", "allowed there", "shielded",
                "infeasible", "crash", "after it", "other"], 24),
    "diff": (["diff", NONE, "--shield", "strict", "--against", "paper"],
             ["file", "episode", "step", "action", "strict", "paper", "enabled by strict",
              "enabled by paper"], None),
    "stats": (["stats", NONE, PAPER],
              ["run", "file", "episodes", "name", "kind", "value", "sd", "ci95_low",
               "ci95_high", "holds", "method"], 2 * 11),
    "info": (["info", NONE, PAPER], ["file", "source", "episodes", "steps", "crashes", "model"],
             2),
    "envs": (["envs"], ["name", "environment", "actions", "variables", "shield", "installed"],
             None),
    "check-model": (["check-model", "paper"],
                    ["kind", "name", "value or type", "description or guard"], 1 + 1 + 9 + 5),
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
    assert _untimed(first) == _untimed(second)


def _untimed(data):
    """A report without its timings (they differ between runs)."""
    if isinstance(data, dict):
        return {k: _untimed(v) for k, v in data.items()
                if not (k.endswith("_s") or k.endswith("_per_s"))}
    if isinstance(data, list):
        return [_untimed(v) for v in data]
    return data


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
