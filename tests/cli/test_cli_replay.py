"""replay and diff on the command line: output, JSON, exit codes."""

from __future__ import annotations

import csv
import io
import json

import pytest

from tests.helpers import TOY, run
from tracecheck.cli import main
from tracecheck.episodes import new_header
from tracecheck.episodes.files import write_run
from tracecheck.interop import import_simb
from tracecheck.live.envs.highway import HIGHWAY


@pytest.fixture(scope="module")
def base(paper_traces, tmp_path_factory):
    path = tmp_path_factory.mktemp("runs") / "base.mcap"
    write_run(path, new_header("imported-simb"), import_simb([paper_traces / "simb" / "base"], vocab=HIGHWAY))
    return path


def test_replay_text(capsys, base):
    code, out, _ = run(capsys, "replay", str(base), "--shield", "paper")
    assert code == 0
    assert "Replay against shield paper" in out and "20 episode(s), 765 step(s)" in out
    assert "infeasible: 233 step(s) in 20 of 20 episode(s)" in out
    assert "crashes: 9, of which 9 at or after the first infeasible step" in out


def test_replay_json_and_fail_on(capsys, base):
    code, out, err = run(capsys, "replay", str(base), "--shield", "paper", "--json",
                         "--fail-on", "infeasible")
    data = json.loads(out)
    assert code == 1 and "failing: infeasible" in err
    assert (data["infeasible_steps"], data["steps"], data["episodes"]) == (233, 765, 20)
    assert data["shield"]["name"] == "paper" and data["elapsed_s"] > 0
    first = data["per_episode"][0]
    assert first["first_infeasible"] == 1 and first["action"] == "FASTER"
    assert first["enabled"] == ["LANE_LEFT", "SLOWER"]
    code, _, _ = run(capsys, "replay", str(base), "--shield", "paper", "--json",
                     "--fail-on", "deadlock", "--fail-on", "postcondition")
    assert code == 0


def test_replay_markdown(capsys, base):
    code, out, _ = run(capsys, "replay", str(base), "--shield", "none", "--format", "md")
    assert code == 0 and out.startswith("# Replay: shield `none`")
    assert "| file | episode | steps | first infeasible |" in out


def test_replay_hand_built(capsys, run_file, tmp_path):
    shield = tmp_path / "toy.mch"
    shield.write_text(TOY)
    code, out, err = run(capsys, "replay", str(run_file), "--shield", str(shield), "--json",
                         "--fail-on", "postcondition")
    data = json.loads(out)
    assert code == 1 and data["postcondition_violations"] == 1
    assert data["per_episode"][2]["alternative"] == "SLOWER"


def test_diff_cli(capsys, base):
    code, out, _ = run(capsys, "diff", str(base), "--shield", "paper", "--against", "none",
                       "--json")
    data = json.loads(out)
    assert code == 0
    assert (data["changed_steps"], data["newly_blocked"], data["newly_allowed"]) == (233, 233, 0)
    assert data["episodes_changed"] == 20
    change = data["changes"][0]
    assert {"episode", "step", "action", "enabled_shield", "enabled_against"} <= set(change)
    code, _, err = run(capsys, "diff", str(base), "--shield", "paper", "--against", "none",
                       "--fail-on-change")
    assert code == 1 and "--fail-on-change" in err
    code, out, _ = run(capsys, "diff", str(base), "--shield", "paper", "--against", "paper",
                       "--fail-on-change")
    assert code == 0 and "changed steps: 0" in out


def test_diff_two_versions_of_a_file(capsys, base, tmp_path):
    from tests.helpers import PAPER_SHIELD

    old = tmp_path / "old.mch"
    old.write_text(PAPER_SHIELD.read_text().replace("FrontWithin(40.0)", "FrontWithin(30.0)"))
    code, out, _ = run(capsys, "diff", str(base), "--shield", str(PAPER_SHIELD), "--against",
                       str(old), "--json")
    data = json.loads(out)
    assert data["newly_blocked"] > 0 and data["newly_allowed"] == 0
    assert all(c["action"] == "FASTER" for c in data["changes"])


@pytest.mark.parametrize("args,fragment", [
    (["--shield", "sturdy"], "unknown shield 'sturdy'"),
    (["--shield", "missing.mch"], "no such model file: missing.mch"),
])
def test_bad_shield(capsys, base, args, fragment):
    code, _, err = run(capsys, "replay", str(base), *args)
    assert code == 2 and fragment in err and "Traceback" not in err


def test_builtin_names_work_where_a_model_is_asked_for(capsys):
    code, out, _ = run(capsys, "check-model", "strict")
    assert code == 0 and "MACHINE StrictRSSShield" in out
    assert "constant BrakeMin = 4.0" in out


def test_replay_does_not_import_torch(base):
    import subprocess
    import sys

    code = ("import sys\nfrom tracecheck.cli import main\ntry:\n"
            f"    main(['replay', {str(base)!r}, '--shield', 'paper', '--json'])\n"
            "except SystemExit:\n    pass\n"
            "assert 'torch' not in sys.modules and 'gymnasium' not in sys.modules\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("kind", ["magic only", "foreign"])
def test_a_file_that_is_no_tracecheck_run_is_an_error_for_every_command(kind, tmp_path, capsys):
    """Not "0 episodes, every step feasible": a CI gate must not pass on such a file."""
    from mcap.writer import Writer

    path = tmp_path / "x.mcap"
    if kind == "magic only":
        path.write_bytes(b"\x89MCAP0\r\n")
    else:
        with open(path, "wb") as f:
            w = Writer(f)
            w.start()
            schema = w.register_schema(name="x", encoding="jsonschema", data=b"{}")
            channel = w.register_channel(topic="/x", message_encoding="json", schema_id=schema)
            w.add_message(channel_id=channel, log_time=0, data=b"{}", publish_time=0)
            w.finish()
    for args in (["replay", path, "--shield", "paper", "--fail-on", "infeasible"],
                 ["diff", path, "--shield", "paper", "--against", "none", "--fail-on-change"],
                 ["stats", path], ["info", path]):
        code, _, err = run(capsys, *map(str, args))
        assert code == 2 and "not a tracecheck run (no /tracecheck/run header)" in err, args


def test_replay_lists_the_first_episodes_that_matter_or_all(capsys, tmp_path):
    from tests.helpers import episode
    from tracecheck.episodes import EpisodeWriter, new_header

    path = tmp_path / "many.mcap"
    with EpisodeWriter(path, new_header("recorded")) as w:
        for i in range(45):
            w.write(episode(i, 2, crash_at_end=True))
    code, out, _ = run(capsys, "replay", str(path), "--shield", "paper")
    assert code == 0 and "… 5 more episode(s): --all lists them, --json gives everything" in out
    code, out, _ = run(capsys, "replay", str(path), "--shield", "paper", "--all")
    assert code == 0 and "more episode(s)" not in out
    assert all(f"\n {i} " in out or f"\n{i} " in out for i in (0, 44))


def test_a_campaign_s_episodes_are_aligned_lines_with_the_table_s_cells(capsys, tmp_path,
                                                                         monkeypatch):
    """--all over more than PLAIN_ROWS episodes: the same cells, as aligned lines (rich's
    layout of 10^4 rows took 2 s)."""
    import tracecheck.render.text as T
    from tests.helpers import episode
    from tracecheck.episodes import EpisodeWriter, new_header

    path = tmp_path / "many.mcap"
    with EpisodeWriter(path, new_header("recorded")) as w:
        for i in range(12):
            w.write(episode(i, 2, crash_at_end=True))
    code, rich_out, _ = run(capsys, "replay", str(path), "--shield", "paper", "--all")
    monkeypatch.setattr(T, "PLAIN_ROWS", 5)
    code2, out, _ = run(capsys, "replay", str(path), "--shield", "paper", "--all")
    assert code == code2 == 0
    lines = out[out.index("episodes that matter\n"):].splitlines()[1:14]
    assert lines[0].split()[:3] == ["ep.", "steps", "first"]
    assert [line.split()[0] for line in lines[1:]] == [str(i) for i in range(12)]
    starts = [line.index(lines[0].split()[1]) for line in lines[:1]]  # aligned columns
    assert all(len(line) >= starts[0] for line in lines)
    for i in range(12):  # each row's cells as rich prints them (rich wraps "other" on)
        mine = next(line for line in lines[1:] if line.split()[0] == str(i)).split()
        theirs = next(line for line in rich_out.splitlines()
                      if line.split()[:1] == [str(i)]).split()
        assert mine[:len(theirs)] == theirs and len(mine) >= 6


def test_the_replay_report_fits_80_columns_without_breaking_words(capsys):
    """The main job's output: every line within 80 columns, headers whole, actions
    abbreviated and explained once."""
    from tests.helpers import ROOT

    none = ROOT / "sample_traces" / "base_none.mcap"
    code, out, _ = run(capsys, "replay", str(none), "--shield", "paper")
    assert code == 0
    lines = out.splitlines()
    assert max(len(line) for line in lines) <= 80, max(lines, key=len)
    header = next(line for line in lines if line.strip().startswith("ep."))
    # without re-simulation the crash column says what it is, never "prevented"
    assert header.split() == ["ep.", "steps", "first", "allowed", "instead", "blocked",
                              "crash", "after", "block", "other"]
    assert "actions: F = FASTER, I = IDLE, L = LANE_LEFT, R = LANE_RIGHT, S = SLOWER" in \
        " ".join(out.split())
    for word in ("infeasib\n", "LANE_\n", "LANE_LEF\n"):
        assert word not in out


def test_action_codes_are_unique_initials():
    from tracecheck.render.text import abbreviations

    assert abbreviations(["LANE_LEFT", "IDLE", "LANE_RIGHT", "FASTER", "SLOWER"]) == {
        "LANE_LEFT": "L", "IDLE": "I", "LANE_RIGHT": "R", "FASTER": "F", "SLOWER": "S"}
    assert abbreviations(["Move_Left", "Move_Down", "Move_Right", "Move_Up"]) == {
        "Move_Left": "L", "Move_Down": "D", "Move_Right": "R", "Move_Up": "U"}
    assert abbreviations(["go_left", "go_long"]) == {"go_left": "LE", "go_long": "LO"}


def test_the_diff_report_fits_80_columns(capsys):
    from tests.helpers import ROOT

    none = ROOT / "sample_traces" / "base_none.mcap"
    code, out, _ = run(capsys, "diff", str(none), "--shield", "strict", "--against", "paper")
    lines = out.splitlines()
    assert code == 0 and max(len(line) for line in lines) <= 80, max(lines, key=len)
    assert any(line.split()[:3] == ["ep.", "step", "action"] for line in lines)
    assert "actions: F = FASTER" in out


# ------------------------------------------------------------------ one truth: the table and
# the re-simulation lines (issue 23, part 4), on the corridor of tests/live/toy.py

#: blocks everything in cell 2: the fallback (Left) is taken there, so an episode that the
#: shield blocks in cell 2 still falls into the pit — a crash after a blocked step that
#: re-simulation finds was not prevented
DEADLOCK_AT_2 = """
MACHINE CorridorShield
VARIABLES pos
INVARIANT pos : 0..5
INITIALISATION pos := 2
OPERATIONS
  Left = SELECT pos /= 2 THEN pos := pos - 1 END;
  Right = SELECT pos /= 2 & pos < 5 THEN pos := pos + 1 END
END
"""
CORRIDOR = "tests.live.toy:Corridor"


@pytest.fixture(scope="module")
def corridor(tmp_path_factory):
    """(run, agent, deadlock-at-2 shield): 12 unshielded episodes of the left-leaning agent,
    each starting in cell 1 to 4 (seeded) and falling into the pit."""
    import numpy as np

    from tests.live.toy import left_leaning_table

    folder = tmp_path_factory.mktemp("corridor")
    agent, shield, out = folder / "left.npy", folder / "stuck.mch", folder / "c.mcap"
    np.save(agent, left_leaning_table())
    shield.write_text(DEADLOCK_AT_2)
    with pytest.raises(SystemExit) as stop:
        main(["record", "--env", CORRIDOR, "--agent", str(agent), "--shield", "none",
              "-n", "12", "--seed", "0", "-o", str(out)])
    assert stop.value.code in (0, None)
    return str(out), str(agent), str(shield)


def _starts(path) -> dict[int, int]:
    from tracecheck.episodes import read_run

    return {e.id: e.steps[0].state["pos"] for e in read_run(path).episodes}


def test_the_table_says_what_resimulation_found(capsys, corridor):
    run_path, agent, shield = corridor
    starts = _starts(run_path)
    blocked = sorted(ep for ep, pos in starts.items() if pos >= 2)  # they pass cell 2
    assert blocked and len(blocked) < len(starts)  # some start in cell 1: never blocked
    args = ["replay", run_path, "--shield", shield, "--resimulate", "--agent", agent,
            "--env", CORRIDOR]
    code, out, err = run(capsys, *args)
    assert code == 0, err
    for ep in blocked:
        assert f"episode {ep} (seed {ep}): not prevented, crash at step" in out
    rows = {line.split()[0]: line for line in out.splitlines()
            if line.split() and line.split()[0].isdigit()}
    header = next(line for line in out.splitlines() if line.strip().startswith("ep."))
    assert "re-simulated" in header.split()
    for ep in blocked:  # the same words as the lines above: never "prevented" alone
        assert " not prevented " in rows[str(ep)], rows[str(ep)]
        assert " prevented" not in rows[str(ep)].replace(" not prevented", "")
    for ep in set(starts) - set(blocked):
        assert " never blocked" in rows[str(ep)] and "prevented" not in rows[str(ep)]
    code, out, _ = run(capsys, *args, "--format", "csv")
    table = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and "crash after a blocked step" not in table[0]
    assert {int(r["episode"]): r["re-simulated"] for r in table} == {
        ep: "not prevented" if ep in blocked else "never blocked" for ep in starts}
    code, out, _ = run(capsys, *args, "--format", "md")
    assert code == 0 and "| re-simulated |" in out and "| not prevented |" in out
    code, out, _ = run(capsys, *args, "--json")
    data = json.loads(out)
    assert {e["episode"]: e["resimulated"] for e in data["per_episode"]} == {
        ep: "not prevented" if ep in blocked else "never blocked" for ep in starts}
    assert {r["outcome"] for r in data["resimulation"]["per_episode"]} == {"not prevented"}
    assert data["resimulation"]["crashes_not_prevented"] == len(blocked)


def test_without_resimulation_the_column_never_says_prevented(capsys, corridor):
    run_path, _, shield = corridor
    code, out, _ = run(capsys, "replay", run_path, "--shield", shield)
    assert code == 0 and "after block" in out and "prevented" not in out
    code, out, _ = run(capsys, "replay", run_path, "--shield", shield, "--format", "csv")
    table = list(csv.DictReader(io.StringIO(out)))
    assert code == 0 and "prevented" not in out
    assert {r["crash after a blocked step"] for r in table} == {"yes", "no"}


def test_fail_on_mismatch(capsys, corridor, tmp_path):
    """Episodes that do not reproduce the recording are counted, warned of, and with
    --fail-on mismatch exit 1 (a run whose header says slip=false, recorded with slip)."""
    from tracecheck.episodes import read_run

    run_path, agent, shield = corridor
    recorded = read_run(run_path)
    header = recorded.header.model_copy(update={"environment_config": {"slip": False}})
    edited = tmp_path / "edited.mcap"
    write_run(edited, header, recorded.episodes)
    starts = _starts(run_path)
    # without slipping every episode starts in cell 2: the others do not reproduce
    wrong = sum(pos in (3, 4) for pos in starts.values())
    resimulated = sum(pos >= 2 for pos in starts.values())
    assert wrong
    args = ["replay", str(edited), "--shield", shield, "--resimulate", "--agent", agent,
            "--env", CORRIDOR]
    code, out, err = run(capsys, *args)
    assert code == 0
    assert f"{wrong} did not reproduce the recording" in " ".join(out.split())
    assert (f"warning: {wrong} of {resimulated} re-simulated episode(s) did not reproduce "
            "the recording") in " ".join(err.split())
    assert "did not reproduce" in out.split("episodes that matter")[1]  # in the table too
    code, out, err = run(capsys, *args, "--fail-on", "mismatch", "--json")
    assert code == 1 and "failing: mismatch found (--fail-on)" in err
    assert json.loads(out)["resimulation"]["mismatches"] == wrong
    code, _, err = run(capsys, "replay", run_path, "--shield", shield, "--fail-on", "mismatch")
    assert code == 2 and "--fail-on mismatch needs --resimulate" in err


def test_diff_prints_no_markup_and_names_as_they_are(capsys, tmp_path):
    """Bug 3: the headline was printed as ``[bold]Shield …[/bold]``; a shield file with
    brackets in its name is printed as it is, too."""
    from tests.helpers import PAPER_SHIELD, ROOT

    odd = tmp_path / "paper[bold]v2.mch"
    odd.write_text(PAPER_SHIELD.read_text())
    code, out, _ = run(capsys, "diff", str(ROOT / "sample_traces" / "base_none.mcap"),
                       "--shield", str(odd), "--against", "strict")
    first = out.splitlines()[0]
    assert code == 0 and first.startswith("Shield paper[bold]v2 (")
    assert " against strict (" in first and "[/bold]" not in out and "\\[" not in out


def test_diff_symbolic_names_two_versions_of_one_machine_by_file(capsys, tmp_path):
    """Bug 4: two versions of one MACHINE are named by their files; different machines by
    file and MACHINE name."""
    from tests.live.cruise import SHIELD_V1, SHIELD_V2

    v1, v2 = tmp_path / "acc_v1.mch", tmp_path / "acc_v2.mch"
    v1.write_text(SHIELD_V1)
    v2.write_text(SHIELD_V2)
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", str(v2), "--against", str(v1))
    assert code == 1
    assert f"  {v2} and {v1} decide KEEP differently: Gap = " in out
    assert "ACCShield" not in out
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", str(v2), "--against", str(v1),
                       "--json")
    keep = next(r for r in json.loads(out) if r["obligation"] == "KEEP")
    assert keep["decisions"] == {str(v2): False, str(v1): True}
    other = tmp_path / "acc_other.mch"
    other.write_text(SHIELD_V1.replace("MACHINE ACCShield", "MACHINE CruiseShield"))
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", str(v2), "--against",
                       str(other))
    assert (f"  {v2} (MACHINE ACCShield) and {other} (MACHINE CruiseShield) decide KEEP "
            "differently") in out
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", str(v1), "--against", str(v1),
                       "--json")
    assert code == 0 and {r["status"] for r in json.loads(out)} == {"equivalent"}


def test_replay_ltl_reads_the_recorded_crash_flag(capsys, tmp_path):
    """The README: the crash flag `crashed` is usable in every LTL formula — `replay --ltl`
    and the viewer's marks too, not only property files (it was "unknown identifier")."""
    from tests.helpers import ROOT

    sample = ROOT / "sample_traces" / "base_none.mcap"
    code, out, err = run(capsys, "replay", sample, "--shield", "paper", "--ltl",
                         "G({crashed = FALSE})", "--json")
    assert code == 0, err
    report = json.loads(out)
    ltl = report["ltl"][0]
    crashes = {e["episode"]: e["crash_step"] for e in report["per_episode"] if e["crashed"]}
    assert crashes and ltl["episodes"] == report["episodes"]
    assert ltl["satisfied"] == report["episodes"] - len(crashes)
    assert {v["episode"]: v["first_step"] for v in ltl["violations"]} == crashes
    page = tmp_path / "ep.html"
    episode = min(crashes)
    code, _, err = run(capsys, "render", sample, "-e", episode, "--shield", "paper", "--ltl",
                       "G({crashed = FALSE})", "-o", page)
    assert code == 0, err
    assert '"holds":false' in page.read_text()


def test_an_unknown_name_in_an_ltl_atom_names_what_atoms_read(capsys):
    from tests.helpers import ROOT

    code, _, err = run(capsys, "replay", ROOT / "sample_traces" / "base_none.mcap",
                       "--shield", "paper", "--ltl", "G({crashd = FALSE})")
    text = " ".join(err.split())
    assert code == 2 and "unknown identifier crashd" in text
    assert "an atom reads the names of PaperShield:" in text and "crashed" in text
    assert "--state" not in text and "--model" not in text


def test_the_episode_table_never_breaks_a_word_and_csv_lists_every_step(capsys, run_file,
                                                                        tmp_path):
    """A shield whose operations change nothing (`skip`) makes every step that moves a
    postcondition violation: the terminal's "other" column printed `postconditio` / `n 1, 2`
    at 80 columns, and CSV cut the steps to three."""
    import re

    skip = re.sub(r"THEN FREE \|\|.*?END", "THEN skip END", TOY, flags=re.S)
    shield = tmp_path / "skip.mch"
    shield.write_text(skip.replace("MACHINE Toy", "MACHINE Skip"))
    code, out, _ = run(capsys, "replay", run_file, "--shield", shield)
    assert code == 0 and "postcondition violations: " in out
    table = out[out.index("episodes that matter"):out.index("first: the first step")]
    words = {w for line in table.splitlines() for w in line.split()}
    assert "post" in words and not any(w.startswith("postcond") for w in words)
    assert max(len(line) for line in out.splitlines()) <= 80
    code, out, _ = run(capsys, "replay", run_file, "--shield", shield, "--format", "csv")
    rows = list(csv.DictReader(io.StringIO(out)))
    assert {r["episode"]: r["other"] for r in rows}["0"] == "postcondition 2, 4"
    # ten violations: the terminal cuts them to three, the full table lists them all
    from dataclasses import replace

    from tracecheck.checking.replaying import replay
    from tracecheck.checking.shield import load_shield
    from tracecheck.render.text import ReplayOutput

    report = replay([run_file], load_shield(shield))
    many = replace(report.per_episode[0], postcondition_violations=list(range(1, 11)))
    table = ReplayOutput(replace(report, per_episode=[many]), 40).table()
    other = table.rows[0][table.headers.index("other")]
    assert other == "postcondition " + ", ".join(str(k) for k in range(1, 11))
