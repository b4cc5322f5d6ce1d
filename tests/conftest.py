"""Shared fixtures: tiny machines, and the paper's traces from ../shared (skipped if absent)."""

from __future__ import annotations

import json
from contextlib import contextmanager
from pathlib import Path

import pytest

from tracecheck.b.machine import load_machine, load_machine_text
from tracecheck.b.notation import parse_literal

ROOT = Path(__file__).resolve().parents[1]
PAPER_SHIELD = ROOT / "models" / "shields" / "paper.mch"
PAPER_TRACES = ROOT.parent / "shared" / "data" / "paper-traces"

COIN_TOSS = """
MACHINE CoinToss
SETS Side = {Heads, Tails, None}
VARIABLES lastToss
INVARIANT lastToss ∈ Side
INITIALISATION lastToss := None
OPERATIONS
  toss = lastToss :∈ {Heads, Tails}
END
"""


@pytest.fixture(scope="session")
def table1():
    """The paper's Table 1 shield over its state vocabulary."""
    return load_machine(PAPER_SHIELD)


@pytest.fixture(scope="session")
def coin_toss():
    return load_machine_text(COIN_TOSS, file="CoinToss.mch")


@pytest.fixture(scope="session")
def paper_traces() -> Path:
    if not PAPER_TRACES.is_dir():
        pytest.skip(f"the paper's traces are not at {PAPER_TRACES}")
    return PAPER_TRACES


def simb_states(path: Path) -> list[tuple[str, dict]]:
    """(operation, state after it) for each activation of a SimB trace that has a state."""
    data = json.loads(path.read_text())
    out = []
    for act in data["activations"]:
        if act.get("fixedVariables"):
            state = {k: parse_literal(v) for k, v in act["fixedVariables"].items()}
            out.append((act["execute"], state))
    return out


# ------------------------------------------------------------------ a user's own environment

#: A user's environment package outside tracecheck (1-D adaptive cruise control): an adapter
#: ``acc_cruise:ACC`` registered as the entry point ``acc``, two shields (v1 may deadlock).
ACC_ENV = ROOT / "tests" / "fixtures" / "acc_env"
ACC_SPEC = "acc_cruise:ACC"
ACC_V1 = ACC_ENV / "acc_cruise" / "acc_v1.mch"
ACC_V2 = ACC_ENV / "acc_cruise" / "acc_v2.mch"


def _forget_acc() -> None:
    """Forget what was found of the acc package (its module, the entry points scanned)."""
    import importlib
    import sys

    from tracecheck.live import adapter

    for name in [m for m in sys.modules if m == "acc_cruise" or m.startswith("acc_cruise.")]:
        del sys.modules[name]
    importlib.invalidate_caches()
    adapter._entry_points.cache_clear()


@contextmanager
def acc_installed(monkeypatch: pytest.MonkeyPatch):
    """The acc environment installed while inside: on ``sys.path`` (its dist-info makes the
    entry point ``acc``) and on ``PYTHONPATH`` for subprocesses."""
    import os

    monkeypatch.syspath_prepend(str(ACC_ENV))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(ACC_ENV), str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    _forget_acc()
    try:
        yield
    finally:
        _forget_acc()


@pytest.fixture
def acc_env(monkeypatch):
    """The acc environment installed for one test (in process and for subprocesses); after
    it, ``acc`` is unknown again. Yields ``ACC_ENV``."""
    with acc_installed(monkeypatch):
        yield ACC_ENV
    monkeypatch.undo()
    _forget_acc()


@pytest.fixture(scope="session")
def acc_agent(tmp_path_factory) -> Path:
    """A stable-baselines3 DQN file for acc that always prefers ACCEL (unshielded it
    crashes within a few steps)."""
    path = tmp_path_factory.mktemp("acc_agent") / "accel.zip"
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        import acc_cruise

        acc_cruise.make_agent(path)
    _forget_acc()
    return path


@pytest.fixture(scope="session")
def acc_runs(acc_agent, tmp_path_factory) -> dict[str, Path]:
    """Two acc runs of the ACCEL agent, 6 episodes, seeds 0–5, the environment's own time
    limit at 30 steps: ``none`` unshielded (every episode crashes) and ``v2`` under
    acc_v2.mch (none does). Recorded with acc installed; afterwards it is not."""
    from tracecheck.cli import main

    folder = tmp_path_factory.mktemp("acc_runs")
    runs = {"none": folder / "acc_none.mcap", "v2": folder / "acc_v2.mcap"}
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        for shield, out in (("none", runs["none"]), (str(ACC_V2), runs["v2"])):
            with pytest.raises(SystemExit) as stop:
                main(["record", "--env", "acc", "--env-config", "max_steps=30", "--agent",
                      str(acc_agent), "--shield", shield, "-n", "6", "--seed", "0",
                      "-o", str(out)])
            assert stop.value.code in (0, None)
    _forget_acc()
    return runs
