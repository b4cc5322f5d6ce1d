"""replay and diff on the command line: output, JSON, exit codes."""

from __future__ import annotations

import json

import pytest

from tests.cli.test_cli import run
from tests.checking.test_replay import TOY, run_file, toy  # noqa: F401 - fixtures
from tracecheck.episodes import new_header
from tracecheck.episodes.files import write_run
from tracecheck.interop import import_simb


@pytest.fixture(scope="module")
def base(paper_traces, tmp_path_factory):
    path = tmp_path_factory.mktemp("runs") / "base.mcap"
    write_run(path, new_header("imported-simb"), import_simb([paper_traces / "simb" / "base"]))
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


def test_replay_hand_built(capsys, run_file, tmp_path):  # noqa: F811
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
    from tests.conftest import PAPER_SHIELD

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
    from tests.episodes.conftest import episode
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


def test_the_replay_report_fits_80_columns_without_breaking_words(capsys):
    """The main job's output: every line within 80 columns, headers whole, actions
    abbreviated and explained once."""
    from tests.conftest import ROOT

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
    from tests.conftest import ROOT

    none = ROOT / "sample_traces" / "base_none.mcap"
    code, out, _ = run(capsys, "diff", str(none), "--shield", "strict", "--against", "paper")
    lines = out.splitlines()
    assert code == 0 and max(len(line) for line in lines) <= 80, max(lines, key=len)
    assert any(line.split()[:3] == ["ep.", "step", "action"] for line in lines)
    assert "actions: F = FASTER" in out
