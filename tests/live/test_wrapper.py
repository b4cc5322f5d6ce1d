"""ShieldWrapper: masks, decisions in info, fail-closed deadlock handling."""

from __future__ import annotations

import numpy as np
import pytest

from tracecheck.errors import InputError
from tracecheck.live.envs.highway import ACTIONS, make_env
from tracecheck.checking.shield import load_shield
from tracecheck.live.wrapper import ShieldWrapper, choose

NOTHING = """
MACHINE Nothing
SETS Vehicles
CONSTANTS EgoVehicle
PROPERTIES card(Vehicles) = 5 & EgoVehicle : Vehicles
VARIABLES Crash
INVARIANT Crash : BOOL
INITIALISATION Crash :: BOOL
OPERATIONS
    IDLE = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    LANE_LEFT = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    LANE_RIGHT = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    FASTER = SELECT Crash = TRUE & Crash = FALSE THEN skip END;
    SLOWER = SELECT Crash = TRUE & Crash = FALSE THEN skip END
END
"""


def test_choose():
    assert choose([0.1, 0.9, 0.5, 0.2, 0.3], [True, False, True, False, True], 4) == (2, False)
    assert choose([0.1, 0.9, 0.5, 0.2, 0.3], [False] * 5, 4) == (4, True)


def test_masks_and_info():
    env = ShieldWrapper(make_env(), load_shield("paper"))
    obs, info = env.reset(seed=5)
    masks = env.action_masks()
    assert masks.dtype == bool and masks.shape == (5,)
    assert info["shield"]["allowed"] == [a for a, ok in zip(ACTIONS, masks) if ok]
    assert info["shield"]["name"] == "paper" and info["shield"]["decision_us"] > 0
    assert set(info["b_state"]) >= {"VehiclesX", "Crash"}
    allowed = int(np.flatnonzero(masks)[0])
    obs, reward, *_, info = env.step(allowed)
    assert info["shield"]["replaced"] is False and info["shield"]["taken"] == ACTIONS[allowed]


def test_disallowed_action_is_replaced_and_reported():
    env = ShieldWrapper(make_env(), load_shield("paper"))
    env.reset(seed=5)
    for _ in range(20):
        masks = env.action_masks()
        if not masks.all():
            break
        env.step(1)
    blocked = int(np.flatnonzero(~masks)[0])
    *_, info = env.step(blocked)
    assert info["shield"]["replaced"] is True
    assert info["shield"]["requested"] == ACTIONS[blocked]
    assert masks[ACTIONS.index(info["shield"]["taken"])]


def test_deadlock_fails_closed(tmp_path):
    path = tmp_path / "nothing.mch"
    path.write_text(NOTHING)
    env = ShieldWrapper(make_env(), load_shield(path), fallback="IDLE")
    _, info = env.reset(seed=1)
    # in a deadlock the mask holds the fallback alone: what the wrapper takes, and never an
    # empty mask for a masked learner
    assert info["shield"]["deadlock"] and info["shield"]["allowed"] == []
    assert env.action_masks().tolist() == [a == "IDLE" for a in ACTIONS]
    *_, info = env.step(3)
    assert info["shield"]["taken"] == "IDLE"  # the fallback, never silently action 0


def test_unknown_fallback():
    with pytest.raises(InputError, match="unknown fallback action 'BRAKE'"):
        ShieldWrapper(make_env(), load_shield("none"), fallback="BRAKE")
