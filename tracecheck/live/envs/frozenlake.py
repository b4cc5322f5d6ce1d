"""FrozenLake-v1 (8×8) in the vocabulary of the authors' FrozenLake machine.

States as in :mod:`.grid` (``field`` holds HOLE or ICE; start, frozen and goal tiles are
ICE). The actions are Gymnasium's order: 0 Move_Left, 1 Move_Down, 2 Move_Right, 3 Move_Up.
Falling into a hole ends the episode and counts as a crash. Slippery or not is the
configuration ``is_slippery`` (default: not slippery, as the authors' code; with slipping
every seed gives a different episode).
"""

from __future__ import annotations

from typing import Any

from ...checking.shield import SHIELD_DIR
from .grid import GridAdapter

__all__ = ["FrozenLakeAdapter"]


#: ``--properties frozenlake``: what ``stats`` adds to the generic set for this environment
FROZENLAKE_TOML = """
[metrics.episode_length]
aggregate = "steps"
description = "Episode length (steps)"

[metrics.return]
aggregate = "return"
description = "Return (1 for reaching the goal)"

[properties.GOAL]
predicate = "x = goal_x & y = goal_y"
kind = "eventually"
description = "reached the goal"

[properties.HOLE]
predicate = "field(x |-> y) = HOLE"
kind = "eventually"
description = "fell into a hole"
"""


class FrozenLakeAdapter(GridAdapter):
    name = "frozenlake"
    description = "Gymnasium's FrozenLake-v1, 8×8: reach the goal without falling into a hole"
    env_id = "FrozenLake-v1"
    actions = ("Move_Left", "Move_Down", "Move_Right", "Move_Up")
    model_name = "FrozenLake"
    default_shield = "frozenlake"
    shields = {"frozenlake": SHIELD_DIR / "frozenlake.mch"}
    horizon = 100
    properties = "frozenlake"
    property_sets = {"frozenlake": FROZENLAKE_TOML}
    danger = b"H"
    kinds = ("ICE", "HOLE")

    def default_config(self) -> dict[str, Any]:
        return {"map_name": "8x8", "is_slippery": False}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and reward == 0.0
