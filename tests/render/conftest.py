"""Runs to draw: the toy cruise-control environment (tests/live/toy.py, a float32 Box
observation), driven by a scripted agent that always wants to accelerate, with and without a
live shield; and a FrozenLake run recorded under its shield."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.helpers import ROOT


def cruise_run(path: Path, *, shielded: bool, episodes: int = 6) -> Path:
    """Episodes of the cruise env (seeds 0..episodes-1): the agent always prefers ACCEL; with
    ``shielded`` the live shield (tests/live/toy.py's CRUISE_SHIELD) replaces it by the first
    action it allows (KEEP, then BRAKE)."""
    from tests.live.toy import CRUISE_SHIELD, Cruise
    from tracecheck.b.machine import load_machine_text
    from tracecheck.episodes import EpisodeWriter, new_header
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    adapter = Cruise()
    machine = load_machine_text(CRUISE_SHIELD)
    header = new_header("recorded", environment="cruise", environment_id="Cruise-v0",
                        environment_config={}, shield_name="cruise" if shielded else "none",
                        model_name="CruiseShield", variables=list(adapter.variables),
                        actions=list(adapter.actions), base_seed=0, horizon=adapter.horizon)
    with EpisodeWriter(path, header) as out:
        for seed in range(episodes):
            env = adapter.make_env({})
            obs, info = env.reset(seed=seed)
            state = adapter.state(obs, info, 0.0, env, True)
            steps = [StepRecord(0, 0.0, None, state, 0.0, False)]
            for k in range(1, adapter.horizon + 1):
                allowed = tuple(a for a in adapter.actions if a in machine.enabled(state))
                action = "ACCEL"
                if shielded and action not in allowed:
                    action = next(a for a in adapter.actions if a in allowed)
                obs, reward, terminated, truncated, info = env.step(adapter.actions.index(action))
                state = adapter.state(obs, info, reward, env, False)
                steps.append(StepRecord(k, float(k), action, state, float(reward),
                                        bool(info["crashed"]), preferred_action="ACCEL",
                                        allowed_actions=allowed if shielded else None))
                if terminated or truncated:
                    break
            steps = tuple(steps)
            out.write(Episode(seed, steps, make_end(steps), seed=seed))
    return path


@pytest.fixture(scope="session")
def cruise_runs(tmp_path_factory) -> tuple[Path, Path]:
    """(unshielded, shielded) runs of the cruise env, 6 episodes each."""
    folder = tmp_path_factory.mktemp("cruise")
    return (cruise_run(folder / "cruise_none.mcap", shielded=False),
            cruise_run(folder / "cruise_shielded.mcap", shielded=True))


@pytest.fixture(scope="session")
def lake_run(tmp_path_factory) -> Path:
    """Two FrozenLake episodes recorded by the bundled Q-table under the frozenlake shield."""
    from tracecheck.live.record import RecordSettings, record

    path = tmp_path_factory.mktemp("lake") / "lake.mcap"
    record(RecordSettings(env="frozenlake", agent=str(ROOT / "models" / "agents" /
                                                      "frozenlake.npy"),
                          shield="none", episodes=4, seed=0, duration=30), path)
    return path
