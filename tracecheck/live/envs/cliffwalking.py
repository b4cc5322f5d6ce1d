"""CliffWalking-v1 in the vocabulary of the authors' CliffWalking machine.

States as in :mod:`.grid` (``field`` holds CLIFF or GRASS; ``goal_x = 11``, ``goal_y = 3``,
as the machine's INITIALISATION sets them). The actions are Gymnasium's order: 0 Move_Up,
1 Move_Right, 2 Move_Down, 3 Move_Left. A fall off the cliff (reward -100; Gymnasium puts the
agent back at the start without ending the episode) counts as a crash and ends the recorded
episode. The environment has no time limit: the horizon bounds every episode.
"""

from __future__ import annotations

from typing import Any

from ...checking.shield import SHIELD_DIR
from .grid import GridAdapter

__all__ = ["CliffWalkingAdapter"]


#: ``--properties cliffwalking``: what ``stats`` adds to the generic set for this environment
CLIFFWALKING_TOML = """
[metrics.episode_length]
aggregate = "steps"
description = "Episode length (steps)"

[metrics.return]
aggregate = "return"
description = "Return (-1 a step, -100 a fall)"

[properties.GOAL]
predicate = "x = goal_x & y = goal_y"
kind = "eventually"
description = "reached the goal"
"""


class CliffWalkingAdapter(GridAdapter):
    name = "cliffwalking"
    description = "Gymnasium's CliffWalking-v1, 12×4: reach the goal without falling off the cliff"
    env_id = "CliffWalking-v1"
    actions = ("Move_Up", "Move_Right", "Move_Down", "Move_Left")
    model_name = "CliffWalking"
    default_shield = "cliffwalking"
    shields = {"cliffwalking": SHIELD_DIR / "cliffwalking.mch"}
    horizon = 100
    #: gymnasium's CliffWalking is always 12 columns by 4 rows
    assumptions = ("x : 0..11", "y : 0..3")
    properties = "cliffwalking"
    property_sets = {"cliffwalking": CLIFFWALKING_TOML}
    danger = b"C"
    kinds = ("GRASS", "CLIFF")

    def default_config(self) -> dict[str, Any]:
        return {"is_slippery": False}

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return reward == -100
