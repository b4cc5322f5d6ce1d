"""Small hand-made episodes."""

from __future__ import annotations

import pytest

from tracecheck.b.values import Elem, FuncValue
from tracecheck.episodes.model import Episode, StepRecord, make_end

VS = [Elem("EgoVehicle"), Elem("Vehicles2"), Elem("Vehicles3")]


def state(x: float, crash: bool = False, reward: float = 0.0) -> dict:
    f = lambda *vals: FuncValue(dict(zip(VS, vals)))  # noqa: E731
    return {"Crash": crash, "PresentVehicles": frozenset(VS), "VehiclesX": f(x, 20.0, -10.0),
            "VehiclesY": f(4.0, 0.0, 4.0), "VehiclesVx": f(25.0, -1.0, 2.0),
            "VehiclesVy": f(0.0, 0.0, 0.0), "VehiclesAx": f(0.0, 0.0, 0.0),
            "VehiclesAy": f(0.0, 0.0, 0.0), "Reward": reward}


def episode(eid: int, n: int = 3, crash_at_end: bool = False, live: bool = False) -> Episode:
    steps = []
    for k in range(n + 1):
        crash = crash_at_end and k == n
        extra = {}
        if live and k > 0:
            extra = dict(observation=((1.0, 0.5, 0.0, 0.2, 0.0),), preferred_action="FASTER",
                         action_values={"IDLE": 0.1, "FASTER": 0.9},
                         allowed_actions=("IDLE", "SLOWER"), shield_time_us=12.5)
        steps.append(StepRecord(step=k, time=float(k), action=None if k == 0 else "IDLE",
                                state=state(100.0 + 25 * k + eid, crash, 0.5 if k else 0.0),
                                reward=0.5 if k else 0.0, crashed=crash, **extra))
    steps = tuple(steps)
    return Episode(id=eid, steps=steps, end=make_end(steps), seed=1000 + eid)


@pytest.fixture
def episodes():
    return [episode(0), episode(1, 5, crash_at_end=True, live=True), episode(2, 1)]
