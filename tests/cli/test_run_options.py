"""The options of the commands that run episodes are declared once (cli/run_options.py):
``record`` and ``simulate`` take the same ones, and one given where it does not apply is
refused by both, the same way (``simulate --cwd DIR`` was silently ignored)."""

from __future__ import annotations

import click
import pytest
import typer

from tests.helpers import ROOT, run
from tracecheck.cli import app
from tracecheck.cli.run_options import DECLARED, RunOptions

AGENT = ROOT / "models" / "agents" / "frozenlake.npy"
SHIELD = ROOT / "models" / "shields" / "frozenlake.mch"


def _options(command: str) -> set[str]:
    group = typer.main.get_command(app)
    found = group.get_command(click.Context(group), command)
    return {d for p in found.params for d in p.opts if d.startswith("--")}


def test_record_and_simulate_take_the_same_run_options():
    declared = {option.param_decls[0] for _, option, _ in DECLARED.values()}
    assert declared <= _options("record") and declared <= _options("simulate")
    assert "--fallback" in _options("simulate")  # it was record's alone


@pytest.mark.parametrize("command", ["record", "simulate"])
@pytest.mark.parametrize("given,refused", [
    (["--cwd", "."], "--cwd only applies to --external"),
    (["--crash", "Crash = TRUE"], "--crash only applies to --external"),
    (["--ending-time", "5"], "--ending-time only applies to --external"),
    (["--step-timeout", "3"], "--step-timeout only applies to --external"),
])
def test_an_external_option_without_external_is_refused_by_both(capsys, tmp_path, command,
                                                                given, refused):
    code, _, err = run(capsys, command, "--env", "frozenlake", "--agent", AGENT, "-n", 1,
                       "-o", tmp_path / "x.mcap", *given)
    assert code == 2 and refused in " ".join(err.split())
    assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize("command", ["record", "simulate"])
@pytest.mark.parametrize("given,refused", [
    (["--env", "frozenlake"], "--env cannot be used with it"),
    (["--shield-mode", "project"], "--shield-mode cannot be used with it"),
    (["--fallback", "Move_Up"], "--fallback cannot be used with it"),
    (["--workers", "2"], "--workers cannot be used with it"),
])
def test_an_agent_option_with_external_is_refused_by_both(capsys, tmp_path, command, given,
                                                          refused):
    code, _, err = run(capsys, command, "--external", "python3 agent.py", "--shield", SHIELD,
                       "-n", 1, "-o", tmp_path / "x.mcap", *given)
    assert code == 2 and refused in " ".join(err.split())


def test_the_defaults_are_the_declared_ones():
    options = RunOptions.given(agent=AGENT)
    assert options.mode == "agent" and options.shield == "none" and options.workers == 1
    options.check()  # nothing given that does not apply
    with pytest.raises(Exception, match="--cwd only applies to --external"):
        RunOptions.given(agent=AGENT, cwd=ROOT).check()


@pytest.mark.parametrize("given", [["--timeout", "3"], ["--counterexamples", "cx"]])
def test_the_solvers_options_on_recorded_states_are_refused(capsys, tmp_path, given):
    """diff on run files has no solver: its --timeout and --counterexamples (declared once
    with prove's) were silently ignored."""
    run_file = ROOT / "sample_traces" / "base_none.mcap"
    code, _, err = run(capsys, "diff", run_file, "--shield", "strict", "--against", "paper",
                       *given)
    assert code == 2 and "only applies to --symbolic" in err
