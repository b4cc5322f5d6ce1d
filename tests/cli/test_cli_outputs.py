"""The output rule on the command line: every command that writes refuses to write over an
input (exit 2, the input byte for byte as it was), replaces an existing output only with
--force and only once the new one is complete, never writes through a symbolic link, and
keeps names made from input text inside its folder."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

from tests.helpers import ROOT, run

SAMPLE = ROOT / "sample_traces" / "base_none.mcap"


def _digest(path: Path) -> str:
    if path.is_dir():
        return "".join(f"{p.name}:{_digest(p)}" for p in sorted(path.iterdir()))
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def inputs(tmp_path, capsys):
    """A run file, one of its episodes as a ProB2 trace, and all as a folder of SimB traces."""
    run_file = tmp_path / "run.mcap"
    shutil.copy(SAMPLE, run_file)
    trace = tmp_path / "e0.prob2trace"
    folder = tmp_path / "simb"
    assert run(capsys, "export", "prob2trace", str(run_file), "-e", "0", "-o", str(trace))[0] == 0
    assert run(capsys, "export", "simb", str(run_file), "-o", str(folder))[0] == 0
    return {"RUN": run_file, "T": trace, "DIR": folder}


CASES = {
    "export prob2trace": (["export", "prob2trace", "RUN", "-e", "0", "-o"], "RUN", "RUN"),
    "render": (["render", "RUN", "-e", "0", "-o"], "RUN", "RUN"),
    "report": (["report", "RUN", "-o"], "RUN", "RUN"),
    "import prob2trace": (["import", "prob2trace", "T", "-o"], "T", "T"),
    "import simb": (["import", "simb", "DIR", "-o"], "DIR/Timed_Simulation_1.json", "DIR"),
    "export foxglove": (["export", "foxglove", "RUN", "-o"], "RUN", "RUN"),
}


def _path(inputs, text: str) -> Path:
    head, _, rest = text.partition("/")
    return inputs[head] / rest if rest else inputs[head]


@pytest.mark.parametrize("through_link", [False, True], ids=["same path", "through a link"])
@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_an_output_that_is_an_input_is_refused(capsys, tmp_path, inputs, case, through_link):
    args, output, source = CASES[case]
    target = _path(inputs, output)
    before = _digest(inputs[source])
    if through_link:
        link = tmp_path / "link"
        link.symlink_to(target)
        target = link
    argv = [str(inputs[a]) if a in inputs else a for a in args] + [str(target), "--force"]
    code, _, err = run(capsys, *argv)
    assert code == 2, err
    assert (" is the input " in err or "is inside the input folder" in err), err
    assert err.startswith("error: the output ")
    assert _digest(inputs[source]) == before


def test_export_prob2trace_replaces_an_existing_file_only_with_force(capsys, tmp_path, inputs):
    existing = tmp_path / "mine.prob2trace"
    existing.write_text("mine")
    argv = ["export", "prob2trace", str(inputs["RUN"]), "-e", "1", "-o"]
    code, _, err = run(capsys, *argv, str(existing))
    assert code == 2 and "mine.prob2trace exists; give another name, or --force" in err
    assert existing.read_text() == "mine"
    link = tmp_path / "link.prob2trace"
    link.symlink_to(existing)
    code, _, err = run(capsys, *argv, str(link), "--force")
    assert code == 2 and "is a symbolic link; tracecheck never writes through one" in err
    assert existing.read_text() == "mine" and link.is_symlink()
    code, _, err = run(capsys, *argv, str(existing), "--force")
    assert code == 0 and '"transitionList"' in existing.read_text()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_a_failed_export_simb_keeps_the_old_traces(capsys, tmp_path, inputs):
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an MCAP file at all")
    before = _digest(inputs["DIR"])
    code, _, err = run(capsys, "export", "simb", str(bad), "-o", str(inputs["DIR"]), "--force")
    assert code == 2 and "bad.mcap is not an MCAP file" in err
    assert _digest(inputs["DIR"]) == before and len(before) > 0
    (inputs["DIR"] / "notes.txt").write_text("mine")
    code, _, err = run(capsys, "export", "simb", str(inputs["RUN"]), "-o", str(inputs["DIR"]),
                       "--force")
    assert code == 2 and "holds notes.txt, which tracecheck does not write there" in err
    assert (inputs["DIR"] / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("command", [["import", "prob2trace", "T"], ["render", "RUN", "-e", "0"],
                                     ["report", "RUN"], ["export", "foxglove", "RUN"]],
                         ids=lambda c: " ".join(c[:2]))
def test_an_existing_output_needs_force(capsys, tmp_path, inputs, command):
    out = tmp_path / "existing"
    out.write_bytes(b"keep")
    argv = [str(inputs[a]) if a in inputs else a for a in command] + ["-o", str(out)]
    code, _, err = run(capsys, *argv)
    assert code == 2 and "existing exists; give another name, or --force" in err
    assert out.read_bytes() == b"keep"
    code, _, err = run(capsys, *argv, "--force")
    assert code == 0, err
    assert out.read_bytes() != b"keep"


def test_report_refuses_a_pages_folder_it_did_not_write(capsys, tmp_path, inputs):
    pages = tmp_path / "r_files"
    pages.mkdir()
    (pages / "mine.txt").write_text("mine")
    code, _, err = run(capsys, "report", str(inputs["RUN"]), "--shield", "paper", "-o",
                       str(tmp_path / "r.html"), "--force")
    assert code == 2 and "holds mine.txt, which tracecheck does not write there" in err
    assert not (tmp_path / "r.html").exists()


# ------------------------------------------------------------------ stats --plot
def test_stats_plot_names_made_from_metric_names_stay_inside_the_folder(capsys, tmp_path,
                                                                       inputs):
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    props = work / "p.toml"
    props.write_text('[metrics."x/../../escaped"]\nexpression = "card(PresentVehicles)"\n'
                     'aggregate = "average"\n'
                     '[metrics."x_._._escaped"]\nexpression = "1"\naggregate = "max"\n')
    plots = work / "plots"
    code, _, err = run(capsys, "stats", str(inputs["RUN"]), "-p", str(props), "--plot",
                       str(plots), "--format", "csv")
    assert code == 0, err
    assert sorted(p.name for p in plots.iterdir()) == [
        "metric_x_._._escaped-2.png", "metric_x_._._escaped-2.svg",
        "metric_x_._._escaped.png", "metric_x_._._escaped.svg"]
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == sorted(
        [p.name for p in plots.iterdir()] + ["p.toml", "run.mcap", "e0.prob2trace"]
        + [p.name for p in inputs["DIR"].iterdir()])
    code, _, err = run(capsys, "stats", str(inputs["RUN"]), "-p", str(props), "--plot",
                       str(plots))
    assert code == 2 and "plots is not empty" in err
    code, _, err = run(capsys, "stats", str(inputs["RUN"]), "-p", str(props), "--plot",
                       str(work), "--force")
    assert code == 2 and "p.toml is inside the --plot folder" in err


# ------------------------------------------------------------------ --counterexamples
LIGHTS = """
MACHINE Lights
VARIABLES speed
INVARIANT speed : INTEGER & speed >= 0
INITIALISATION speed := 0
OPERATIONS
  GO = SELECT speed < 30 THEN skip END
END
"""


@pytest.fixture
def lights(tmp_path):
    pytest.importorskip("z3")
    path = tmp_path / "Lights.mch"
    path.write_text(LIGHTS)
    return path


def _prove(capsys, lights, folder, *more):
    return run(capsys, "prove", str(lights), "--deadlock-free", "--counterexamples",
               str(folder), *more)


def test_counterexamples_follow_the_output_rule(capsys, tmp_path, lights):
    folder = tmp_path / "cx"
    code, out, err = _prove(capsys, lights, folder)
    assert code == 1, err
    (state,) = folder.iterdir()
    assert state.name == "Lights-1-deadlock-free.json" and f"state: {state}" in out
    code, _, err = _prove(capsys, lights, folder)
    assert code == 2 and "the --counterexamples folder" in err and "is not empty" in err
    code, _, err = _prove(capsys, lights, folder, "--force")
    assert code == 1 and [p.name for p in folder.iterdir()] == [state.name]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["Lights.mch", "cx"]


def test_a_link_planted_where_a_counterexample_goes_is_not_followed(capsys, tmp_path, lights):
    folder = tmp_path / "cx"
    folder.mkdir()
    target = tmp_path / "precious"
    target.write_text("keep")
    (folder / "Lights-1-deadlock-free.json").symlink_to(target)
    for more in ([], ["--force"]):
        code, _, err = _prove(capsys, lights, folder, *more)
        assert code == 2, err
        assert target.read_text() == "keep"
        assert (folder / "Lights-1-deadlock-free.json").is_symlink()
    assert "holds Lights-1-deadlock-free.json, which tracecheck does not write there" in err


@pytest.mark.parametrize("where, message", [
    ("file/cx", "Lights.mch/cx: .*Lights.mch is not a folder"),
    ("file", "Lights.mch is the input"),
    ("taken", "holds Lights-1-deadlock-free.json, which tracecheck does not write there"),
    ("holds the machine", "Lights.mch is inside the --counterexamples folder"),
])
def test_a_counterexamples_folder_that_cannot_be_written_is_exit_2(capsys, tmp_path, lights,
                                                                   where, message):
    import re

    folder = {"file/cx": lights / "cx", "file": lights, "taken": tmp_path / "cx",
              "holds the machine": tmp_path}[where]
    if where == "taken":  # the counterexample's file name is a folder
        (folder / "Lights-1-deadlock-free.json").mkdir(parents=True)
    before = lights.read_text()
    code, out, err = _prove(capsys, lights, folder, "--force")
    assert code == 2 and re.search(message, err), err
    assert "Traceback" not in err and out == ""
    assert lights.read_text() == before


def test_diff_symbolic_counterexamples_follow_the_output_rule(capsys, tmp_path, lights):
    other = tmp_path / "Other.mch"
    other.write_text(LIGHTS.replace("speed < 30", "speed < 20"))
    folder = tmp_path / "cx"
    argv = ["diff", "--symbolic", "--shield", str(lights), "--against", str(other),
            "--counterexamples"]
    code, _, err = run(capsys, *argv, str(folder))
    assert code == 1, err
    assert [p.name for p in folder.iterdir()] == ["Lights-1-GO.json"]
    code, _, err = run(capsys, *argv, str(folder))
    assert code == 2 and "is not empty" in err
    code, _, err = run(capsys, *argv, str(tmp_path), "--force")
    assert code == 2 and "is inside the --counterexamples folder" in err


# ------------------------------------------------------------------ record, train
def test_record_and_train_refuse_to_write_over_their_inputs(capsys, tmp_path):
    agent = tmp_path / "agent.npy"
    shutil.copy(ROOT / "models" / "agents" / "frozenlake.npy", agent)
    before = agent.read_bytes()
    code, _, err = run(capsys, "record", "--agent", str(agent), "--env", "frozenlake", "-n", "1",
                       "-o", str(agent), "--force")
    assert code == 2 and "agent.npy is the input" in err
    assert agent.read_bytes() == before
    out = tmp_path / "q.npy"
    argv = ["train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", "50", "-o",
            str(out)]
    code, _, err = run(capsys, *argv)
    assert code == 0, err
    code, _, err = run(capsys, *argv)
    assert code == 2 and "q.npy exists; give another name, or --force" in err
    out.unlink()
    code, _, err = run(capsys, *argv)
    assert code == 2 and "q.json exists" in err  # the model card beside it counts too
    out.with_suffix(".json").write_text("old")
    code, _, err = run(capsys, *argv, "--force")
    assert code == 0 and out.exists() and '"sha256"' in out.with_suffix(".json").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["agent.npy", "q.curve.png", "q.json",
                                                          "q.npy"]
