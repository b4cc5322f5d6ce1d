"""A hand-made run whose statistics are known: two highway episodes (seeds 1, 2), the second
ending in a crash."""

from __future__ import annotations

import pytest

from tests.helpers import state
from tracecheck.episodes import EpisodeWriter, new_header
from tracecheck.episodes.model import Episode, StepRecord, make_end


def _states(values):
    steps = []
    for k, (x, reward, crash) in enumerate(values):
        s = state(x, crash, reward)
        steps.append(StepRecord(k, float(k), None if k == 0 else "IDLE", s, reward, crash))
    steps = tuple(steps)
    return steps


@pytest.fixture(scope="module")
def hand_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("hand") / "hand.mcap"
    ep0 = _states([(100.0, 0.0, False), (110.0, 1.0, False), (130.0, 2.0, False)])
    ep1 = _states([(100.0, 0.0, False), (150.0, 4.0, True)])
    with EpisodeWriter(path, new_header("recorded")) as w:
        w.write(Episode(0, ep0, make_end(ep0), seed=1))
        w.write(Episode(1, ep1, make_end(ep1), seed=2))
    return path
