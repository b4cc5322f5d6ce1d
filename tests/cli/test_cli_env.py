"""A user's own environment in every command: the acc fixture (tests/fixtures/acc_env),
installed only as an entry point, or given as ``--env acc_cruise:ACC``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import ACC_SPEC, ACC_V1, ACC_V2
from tracecheck.cli import main
from tracecheck.episodes.reader import read_episodes


def run(capsys, *args):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    captured = capsys.readouterr()
    return info.value.code or 0, captured.out, captured.err


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
