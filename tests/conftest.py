"""Shared fixtures: tiny machines, the paper's traces from ../shared (skipped if absent), the
user's own environment acc with an agent and runs, and replay's toy shield and run."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.helpers import (ACC_ENV, ACC_V2, PAPER_SHIELD, PAPER_TRACES, TOY, VS, acc_installed,
                           forget_acc, state)
from tracecheck.b.machine import load_machine, load_machine_text
from tracecheck.b.values import FuncValue
from tracecheck.checking.shield import load_shield
from tracecheck.episodes import EpisodeWriter, new_header
from tracecheck.episodes.model import Episode, StepRecord, make_end


def pytest_ignore_collect(collection_path: Path, config) -> bool | None:
    """Under tests/, only test modules and conftests are collected: helper modules (and the
    acc package of fixtures/) are imported by the tests as they are, never on their own for
    --doctest-modules (which is for the docstring examples of tracecheck/)."""
    if collection_path.suffix == ".py" and \
            not collection_path.name.startswith(("test_", "conftest")):
        return True
    return None


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


@pytest.fixture
def acc_env(monkeypatch):
    """The acc environment installed for one test (in process and for subprocesses); after
    it, ``acc`` is unknown again. Yields ``ACC_ENV``."""
    with acc_installed(monkeypatch):
        yield ACC_ENV
    monkeypatch.undo()
    forget_acc()


@pytest.fixture(scope="session")
def acc_agent(tmp_path_factory) -> Path:
    """A stable-baselines3 DQN file for acc that always prefers ACCEL (unshielded it
    crashes within a few steps)."""
    path = tmp_path_factory.mktemp("acc_agent") / "accel.zip"
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        import acc_cruise

        acc_cruise.make_agent(path)
    forget_acc()
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
    forget_acc()
    return runs


# ------------------------------------------------------------------ replay's toy shield and run


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    path = tmp_path_factory.mktemp("shield") / "toy.mch"
    path.write_text(TOY)
    return load_shield(path)


def step(k, action, x, reward=0.5, crash=False, vx=25.0, values=None):
    s = state(x, crash, reward)
    s["VehiclesVx"] = FuncValue({**s["VehiclesVx"].map, VS[0]: vx})
    return StepRecord(step=k, time=float(k), action=action, state=s, reward=reward,
                      crashed=crash, action_values=values)


def ep(eid, steps):
    steps = tuple(steps)
    return Episode(id=eid, steps=steps, end=make_end(steps))


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    q = {"IDLE": 0.1, "LANE_LEFT": 0.2, "LANE_RIGHT": 0.05, "FASTER": 0.9, "SLOWER": 0.3}
    episodes = [
        # FASTER at x = 160 (state before step 3) is infeasible; the crash comes after it
        ep(0, [step(0, None, 100.0), step(1, "FASTER", 120.0), step(2, "IDLE", 160.0),
               step(3, "FASTER", 180.0, values=None), step(4, "IDLE", 190.0, crash=True)]),
        # a deadlock state (negative reward) and an invariant violation (reward 20)
        ep(1, [step(0, None, 100.0), step(1, "IDLE", 110.0, reward=-1.0),
               step(2, "IDLE", 120.0, reward=20.0)]),
        # SLOWER that speeds up: a postcondition violation; the values that chose step 2's
        # action are recorded with step 2
        ep(2, [step(0, None, 100.0), step(1, "IDLE", 200.0),
               step(2, "FASTER", 210.0, values=q), step(3, "SLOWER", 215.0, vx=27.0)]),
    ]
    path = tmp_path_factory.mktemp("run") / "hand.mcap"
    with EpisodeWriter(path, new_header("recorded")) as w:
        for e in episodes:
            w.write(e)
    return path


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray instance on loopback with 2 CPUs, shared by the tests of a module (skipped
    where Ray is not installed)."""
    ray = pytest.importorskip("ray", reason="the ray extra is not installed (pip install "
                                            "-e '.[ray]')")
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             _node_ip_address="127.0.0.1")
    yield ray
    ray.shutdown()
