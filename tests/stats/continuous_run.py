"""A hand-made run of continuous actions whose statistics are counted by hand (used by
tests/stats/test_continuous_stats.py and tests/render/test_viewer_continuous.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tracecheck.episodes import EpisodeWriter, new_header
from tracecheck.episodes.model import Episode, StepRecord, make_end

BELOW_ZERO = float(np.nextafter(0.0, -1.0))  # the float boundary of an open end at 0
#: (proposal, executed, distance, allowed intervals of a, deadlock); the space is [-4, 2]
EPISODES = [
    [(2.0, 2.0, 0.0, ((-4.0, 2.0),), None),  # at the space's bound: not the shield's end
     (2.0, 1.0, 1.0, ((-4.0, 1.0),), None),  # projected onto the shield's end 1.0
     (0.0, 0.5, 0.5, ((-4.0, -1.0), (0.5, 2.0)), None)],  # onto the second interval's end
    [(2.0, -4.0, 6.0, (), True),  # nothing allowed: the fallback
     (1.0, BELOW_ZERO, 1.0, ((None, 0.0),), None),  # 5e-324 from 0: on it (absolutely)
     (-2.0, -2.0, 0.0, ((-3.0, -1.0),), None),  # inside
     (1.5, 1.5, 0.0, ((-4.0, 1.5 + 1e-4),), None),  # 1e-4 below an end of 1.5: not on it
     (-3.5, -3.0 + 2e-5, 0.5, ((-3.0, 2.0),), None)],  # 2e-5 from -3: on it (relatively)
]


def continuous_episode(eid: int, rows) -> Episode:
    """An episode of ``rows`` as :data:`EPISODES` gives them."""
    state = {"x": 0.0}
    steps = [StepRecord(0, 0.0, None, state, 0.0, False)]
    for k, (proposal, executed, distance, intervals, deadlock) in enumerate(rows, 1):
        steps.append(StepRecord(k, float(k), "ACCELERATE", {"x": float(k)}, 1.0, False,
                                parameters={"a": executed}, proposal={"a": proposal},
                                projection_distance=distance,
                                allowed_intervals={"a": intervals}, deadlock=deadlock,
                                allowed_actions=() if deadlock else ("ACCELERATE",)))
    steps = tuple(steps)
    return Episode(eid, steps, make_end(steps, "time-limit"), seed=eid + 1)


def continuous_header(**more):
    """The header of a run of ACCELERATE(a) (``more``: further fields)."""
    return new_header("recorded", actions=["ACCELERATE"], variables=["x"],
                      action_parameters={"ACCELERATE": ["a"]}, **more)


def write_hand_run(path: Path, **header) -> Path:
    """:data:`EPISODES` as a run file (``header``: more run header fields)."""
    with EpisodeWriter(path, continuous_header(**header)) as w:
        for eid, rows in enumerate(EPISODES):
            w.write(continuous_episode(eid, rows))
    return path


def record_throttle(folder: Path, *, steps: int, episodes: int) -> Path:
    """``folder/v1.mcap``: episodes of an agent that always proposes full throttle (+2) in
    the throttle environment of tests/fixtures/acc_env, under throttle_v1.mch projected,
    recorded by the CLI (with Foxglove's channels, as every CLI recording)."""
    import pytest

    from tests.helpers import ACC_ENV, acc_installed, forget_acc
    from tracecheck.cli import main

    out = folder / "v1.mcap"
    with pytest.MonkeyPatch.context() as mp, acc_installed(mp):
        from acc_cruise.throttle import make_agent

        agent = make_agent(folder / "full.zip", 2.0)
        with pytest.raises(SystemExit) as stop:
            main(["record", "--env", "acc_cruise.throttle:Throttle", "--env-config",
                  f"max_steps={steps}", "--agent", str(agent), "--shield",
                  str(ACC_ENV / "acc_cruise" / "throttle_v1.mch"), "-n", str(episodes),
                  "-o", str(out)])
        assert stop.value.code in (0, None)
    forget_acc()
    return out
