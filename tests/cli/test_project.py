"""``tracecheck project``: the validation table in every format, the exit codes (0 all ran
and succeeded, 1 a task failed, 3 none failed but some did not run, 2 bad input)."""

from __future__ import annotations

import csv
import io
import json

from tests.helpers import ROOT, run, strict_json

FIXTURES = ROOT / "tests" / "fixtures" / "prob2project"
OLD = FIXTURES / "Corridor.prob2project"
NEW = FIXTURES / "CorridorTasks.prob2project"


def _project(tmp_path, tasks, traces=()):
    """A project of the corridor with these SimB tasks on the fixture traces."""
    data = {"name": "Mini", "machines": [{
        "name": "Corridor", "location": str(FIXTURES / "Corridor.mch"),
        "traces": [{"location": str(FIXTURES / "traces" / t)} for t in traces],
        "simulations": [{"path": str(FIXTURES / "simb"), "simulationItems": tasks}]}]}
    path = tmp_path / "Mini.prob2project"
    path.write_text(json.dumps(data))
    return path


SAFE = {"id": "safe", "type": "HYPOTHESIS_TEST", "information": {
    "SIGNIFICANCE": 0.05, "PROBABILITY": 0.6, "PREDICATE": "Crash = FALSE",
    "HYPOTHESIS_CHECKING_TYPE": "LEFT_TAILED", "CHECKING_TYPE": "PREDICATE_INVARIANT"}}


def test_text_table_and_exit_1_when_a_task_fails(capsys):
    code, out, err = run(capsys, "project", OLD, "--no-scripts")
    assert code == 1, err
    assert "Corridor (" in out and "machine Corridor" in out
    assert "Sim_Near (failed): 3/5 hold (0.600); p=0.95, α=0.05: rejected" in out
    assert "#2 (failed): 3 steps; step 3: LEFT is not enabled (enabled: RIGHT)" in out
    assert "9 succeeded, 4 failed, 7 not run, of 20 tasks (1 more deselected in the project)" \
        in out
    assert "Traceback" not in out + err


def test_exit_0_when_every_task_ran_and_succeeded(capsys, tmp_path):
    code, out, _ = run(capsys, "project", _project(tmp_path, [SAFE], ["good.prob2trace"]))
    assert code == 0
    assert "2 succeeded, 0 failed, 0 not run, of 2 tasks" in out


def test_exit_3_when_nothing_failed_but_something_did_not_run(capsys, tmp_path):
    odd = {"type": "ESTIMATION", "information": {
        "ESTIMATION_TYPE": "MEAN", "EXPRESSION": "pos", "DESIRED_VALUE": 1.0, "EPSILON": 0.5,
        "CHECKING_TYPE": "MEDIAN"}}
    code, out, _ = run(capsys, "project", _project(tmp_path, [SAFE, odd]))
    assert code == 3
    assert "the checking type MEDIAN is not one tracecheck knows" in out
    code, out, err = run(capsys, "project", _project(tmp_path, [odd]), "--format", "json")
    assert code == 3
    assert strict_json(out)["summary"] == {"success": 0, "failed": 0, "not run": 1}
    assert "note: 0 succeeded, 0 failed, 1 not run, of 1 tasks" in err


def test_fewer_traces_than_executions_is_exit_3_never_0(capsys, tmp_path):
    asks = dict(SAFE, information=dict(SAFE["information"], EXECUTIONS=1000))
    code, out, _ = run(capsys, "project", _project(tmp_path, [asks]), "--json")
    assert code == 3
    assert strict_json(out)["tasks"][0]["reason"] == (
        "the folder has 5 timed traces; the task asks for 1000 executions — give "
        "--executions 5 to run it on them")
    code, out, _ = run(capsys, "project", _project(tmp_path, [SAFE]), "--executions", "1000")
    assert code == 3 and "asks for 1000 executions" in out
    code, _, _ = run(capsys, "project", _project(tmp_path, [asks]), "--executions", "5")
    assert code == 0


def test_json_csv_and_markdown(capsys):
    code, out, _ = run(capsys, "project", NEW, "--json")
    data = strict_json(out)
    assert code == 1 and data["exit_code"] == 1
    assert [t["status"] for t in data["tasks"]][:4] == ["success", "failed", "success",
                                                         "failed"]
    assert data["tasks"][4]["details"]["metrics"]["EXPRESSION"]["estimate"]["within"] is True
    code, out, _ = run(capsys, "project", NEW, "--format", "csv")
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0][:6] == ["machine", "task", "type", "checks", "executions", "status"]
    assert rows[3][:6] == ["Corridor", "Sim_Safe", "HYPOTHESIS_TEST",
                           "PREDICATE_INVARIANT Crash = FALSE", "5", "success"]
    code, out, _ = run(capsys, "project", NEW, "--format", "md")
    assert "| Corridor | bounded | LTL | G({pos &lt;= 4}) |" in out
    assert out.rstrip().endswith("4 succeeded, 2 failed, 4 not run, of 10 tasks")


def test_traces_option_machine_and_executions(capsys):
    code, out, _ = run(capsys, "project", OLD, "--traces", f"Corridor.py={FIXTURES / 'simb'}",
                       "--machine", "Corridor", "-n", "2", "--format", "json")
    rows = {t["task"]: t for t in strict_json(out)["tasks"]}
    assert rows["Script_Safe"]["status"] == "success"
    assert rows["Script_Safe"]["executions"] == 2


def test_bad_input_is_exit_2_with_the_file_and_field(capsys, tmp_path):
    broken = dict(SAFE, information=dict(SAFE["information"], PROBABILITY="high"))
    path = _project(tmp_path, [broken])
    code, out, err = run(capsys, "project", path)
    assert code == 2
    assert f"{path}: machines[0].simulations[0].simulationItems[0].information.PROBABILITY: " \
           "input should be a valid number, not 'high'" in err
    code, _, err = run(capsys, "project", OLD, "--machine", "Nope")
    assert code == 2 and "has no machine 'Nope'; it has Corridor" in err
    code, _, err = run(capsys, "project", OLD, "--traces", "Corridor.py=")
    assert code == 2 and "give a folder of SimB timed traces" in err
    code, _, err = run(capsys, "project", tmp_path / "none.prob2project")
    assert code == 2 and "none.prob2project" in err
    assert "Traceback" not in err


def test_names_and_locations_from_the_project_never_drive_the_terminal(capsys, tmp_path):
    """A project's name, a task's id and a trace location with terminal escapes: shown as
    escapes in text, Markdown and CSV (they reached the terminal raw)."""
    bad = {**SAFE, "id": "safe\x1b[2J\x1b]0;owned\x07"}
    path = _project(tmp_path, [bad], ["good.prob2trace", "\x1b[31mmissing\x1b[0m.prob2trace"])
    data = json.loads(path.read_text())
    data["name"] = "Mini\x1b[5m"
    path.write_text(json.dumps(data))
    for fmt in ("text", "md", "csv"):
        code, out, err = run(capsys, "project", path, "--format", fmt)
        assert code == 3, err
        assert "\x1b" not in out + err and "\x07" not in out + err, fmt
        assert "\\x1b[2J" in out and "\\x1b[31mmissing" in out, fmt


def test_b_strings_and_warnings_never_drive_the_terminal(capsys, tmp_path):
    """A machine's string constant with an escape sequence: check-model, eval and the
    warnings of guards printed it raw."""
    model = tmp_path / "E.mch"
    model.write_text('MACHINE E\nCONSTANTS c\nPROPERTIES c = "ok\x1b[31mRED"\nVARIABLES x\n'
                     'INVARIANT x : INTEGER & c = "no\x1b[2J"\nINITIALISATION x := 0\n'
                     'OPERATIONS Go = SELECT c = "ok\x1b[31mRED" THEN skip END\nEND\n')
    state = tmp_path / "s.json"
    state.write_text('{"x": "0"}')
    for args in (("check-model", model), ("eval", "--model", model, "c"),
                 ("guards", model, "--state", state)):
        code, out, err = run(capsys, *args)
        assert code == 0, err
        assert "\x1b" not in out + err and "\\x1b" in out + err, args
