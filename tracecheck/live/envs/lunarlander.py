"""LunarLander-v3 (needs the ``box2d`` extra) in the vocabulary of the authors' LunarLander
machine.

The conventions of their glue code (``LunarLander/LunarLander.py``): screen coordinates,
``x = (obs[0] + 1.5) · 800 / 3`` and ``y = 200 − (obs[1] + 1.5) · 200 / 3``; ``v_x``, ``v_y``,
``angle`` and ``v_angular`` as observed; the legs' ground contact as BOOL; ``surface`` the
terrain's segments ``i |-> ((x1 |-> y1) |-> (x2 |-> y2))`` in screen coordinates (the same
during an episode). Actions in Gymnasium's order: 0 Do_Nothing, 1 Fire_Left, 2 Fire_Down,
3 Fire_Right. An episode that ends with reward −100 (the lander crashed or flew off) is a
crash.
"""

from __future__ import annotations

from typing import Any, Optional

from ...b.values import FuncValue
from ..adapter import GymnasiumAdapter, Observer

__all__ = ["LunarLanderAdapter"]


def _surface(env) -> FuncValue:
    fixtures = env.unwrapped.moon.fixtures
    segments = {}
    for i in range(1, len(fixtures)):
        (x1, y1), (x2, y2) = fixtures[i].shape.vertices[0], fixtures[i].shape.vertices[1]
        segments[i] = ((float(x1) * 40.0, 200.0 - float(y1) * 10.0),
                       (float(x2) * 40.0, 200.0 - float(y2) * 10.0))
    return FuncValue(segments)


class _LanderObserver(Observer):
    surface: Optional[FuncValue] = None

    def state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        if initial or self.surface is None:
            self.surface = _surface(self.env)
        o = [float(v) for v in obs]
        return {"x": (o[0] + 1.5) * 800.0 / 3.0, "y": 200.0 - (o[1] + 1.5) * 200.0 / 3.0,
                "v_x": o[2], "v_y": o[3], "angle": o[4], "v_angular": o[5],
                "left_leg_on_ground": bool(o[6]), "right_leg_on_ground": bool(o[7]),
                "surface": self.surface}


#: ``--properties lunarlander``: what ``stats`` adds to the generic set for this environment
LUNARLANDER_TOML = """
[metrics.episode_length]
aggregate = "steps"
description = "Episode length (steps of 1/50 s)"

[metrics.return]
aggregate = "return"
description = "Return"

[properties.LANDED]
predicate = "left_leg_on_ground = TRUE & right_leg_on_ground = TRUE"
kind = "eventually"
description = "both legs on the ground at some point"
"""


class LunarLanderAdapter(GymnasiumAdapter):
    name = "lunarlander"
    description = "Gymnasium's LunarLander-v3 (Box2D): land between the flags without crashing"
    env_id = "LunarLander-v3"
    actions = ("Do_Nothing", "Fire_Left", "Fire_Down", "Fire_Right")
    variables = ("x", "y", "v_x", "v_y", "angle", "v_angular", "left_leg_on_ground",
                 "right_leg_on_ground", "surface")
    model_name = "LunarLander"
    seconds_per_step = 1.0 / 50.0
    horizon = 1000
    requires = ("gymnasium", "Box2D")
    properties = "lunarlander"
    property_sets = {"lunarlander": LUNARLANDER_TOML}

    def observer(self, env) -> Observer:
        return _LanderObserver(self, env)

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        return bool(terminated) and reward == -100
