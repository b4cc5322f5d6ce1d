"""A user's own environment in every command: the acc fixture (tests/fixtures/acc_env),
installed only as an entry point, or given as ``--env acc_cruise:ACC``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.helpers import ACC_SPEC, ACC_V1, ACC_V2, run
from tracecheck.episodes.reader import read_episodes


def test_the_fixture_is_an_installed_environment(acc_env, capsys):
    code, out, _ = run(capsys, "envs", "--json")
    rows = {r["name"]: r for r in json.loads(out)}
    assert code == 0 and rows["acc"]["adapter"] == ACC_SPEC
    assert rows["acc"]["actions"] == ["KEEP", "ACCEL", "BRAKE"]
    # and for a subprocess, through PYTHONPATH
    proc = subprocess.run([sys.executable, "-m", "tracecheck.cli", "envs", "--json"],
                          capture_output=True, text=True)
    assert proc.returncode == 0 and "acc_cruise:ACC" in proc.stdout


def test_without_the_fixture_acc_is_unknown(capsys):
    code, _, err = run(capsys, "envs", "--json")
    assert code == 0
    from tracecheck.live.adapter import get_adapter
    from tracecheck.errors import InputError

    with pytest.raises(InputError, match="unknown environment 'acc'"):
        get_adapter("acc")


def test_the_acc_runs(acc_runs):
    none, v2 = (list(read_episodes(acc_runs[k])) for k in ("none", "v2"))
    assert len(none) == len(v2) == 6
    assert all(e.end.crashed and e.end.steps < 30 for e in none)
    assert not any(e.end.crashed for e in v2) and all(e.end.steps == 30 for e in v2)


def test_prove_finds_the_deadlock_of_v1_only(capsys):
    code, out, _ = run(capsys, "prove", ACC_V1, "--deadlock-free")
    assert code == 1 and "counterexample" in out
    code, out, _ = run(capsys, "prove", ACC_V2, "--deadlock-free")
    assert code == 0 and "proved" in out


@pytest.mark.parametrize("command", ["stats", "report", "render", "simulate", "train",
                                     "record", "replay", "import", "export"])
def test_every_command_where_an_environment_matters_takes_env(command, capsys):
    args = {"import": ["import", "minari"], "export": ["export", "minari"]}.get(command,
                                                                              [command])
    code, out, _ = run(capsys, *args, "--help")
    assert code == 0 and "--env" in out
    assert "package.module:Class" in " ".join(out.split()) or command in ("replay", "import",
                                                                          "export")


def test_the_environments_own_time_limit_is_a_time_limit(acc_runs, acc_env, acc_agent,
                                                         tmp_path, capsys):
    """Bug 6: an episode the environment truncated at its own limit was end-of-trace."""
    assert [e.end.reason for e in read_episodes(acc_runs["v2"])] == ["time-limit"] * 6
    assert [e.end.reason for e in read_episodes(acc_runs["none"])] == ["crashed"] * 6
    out = tmp_path / "d.mcap"  # --duration before the environment's own limit: the same
    code, _, err = run(capsys, "record", "--env", ACC_SPEC, "--agent", acc_agent, "--shield",
                       ACC_V2, "-n", 1, "--duration", 5, "-o", out)
    assert code == 0, err
    (episode,) = read_episodes(out)
    assert (episode.end.steps, episode.end.reason) == (5, "time-limit")
    code, text, _ = run(capsys, "stats", acc_runs["v2"], "--json")
    assert json.loads(text)["runs"][0]["properties"]["TIME_LIMIT"]["ratio"] == 1.0


def test_end_reason_follows_gymnasium():
    from tracecheck.live.rollout import end_reason

    assert end_reason(True, True, False) == "crashed"
    assert end_reason(False, False, True) == "time-limit"
    assert end_reason(False, True, True) == "end-of-trace"  # terminated wins, as in Gymnasium
    assert end_reason(False, True, False) == "end-of-trace"


@pytest.mark.parametrize("how", ["entry point", "--env"])
def test_simulate_until_ci_width_with_an_ltl_property(acc_env, acc_agent, tmp_path, capsys,
                                                     how):
    """Bug 1: a property of kind ltl stopped simulate --until-ci-width with a traceback
    ('_Temporal' object is not callable), leaving a file with one episode."""
    props = tmp_path / "props.toml"
    props.write_text('[properties.NO_CRASH]\npredicate = "G({crashed = FALSE})"\n'
                     'kind = "ltl"\n\n[properties.SLOW]\npredicate = "EgoSpeed <= 40.0"\n')
    out = tmp_path / "sim.mcap"
    code, text, err = run(capsys, "simulate", "--env", "acc" if how == "entry point"
                          else ACC_SPEC, "--env-config", "max_steps=8", "--agent", acc_agent,
                          "--shield", ACC_V2, "-n", 40, "--until-ci-width", 0.6,
                          "--properties", props, "-o", out, "--json")
    assert code == 0, err
    data = json.loads(text)
    assert data["sequential"]["stopped_early"] and data["sequential"]["looks"] >= 1
    run_stats = data["runs"][0]
    assert run_stats["episodes"] == len(list(read_episodes(out))) < 40
    assert run_stats["properties"]["NO_CRASH"]["ratio"] == 1.0
    assert set(data["sequential"]["widths"]) == {"NO_CRASH", "SLOW"}


def test_simulate_without_properties_gives_the_generic_set(acc_env, acc_agent, tmp_path,
                                                           capsys):
    out = tmp_path / "sim.mcap"
    code, text, err = run(capsys, "simulate", "--env", "acc", "--env-config", "max_steps=5",
                          "--agent", acc_agent, "-n", 3, "-o", out, "--json")
    assert code == 0, err
    data = json.loads(text)
    assert data["properties_set"] == "generic+acc"
    assert data["runs"][0]["properties"]["CRASH"]["holds"] + \
        data["runs"][0]["properties"]["TIME_LIMIT"]["holds"] == 3
