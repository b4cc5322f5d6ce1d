"""LunarLanderContinuous-v3 (needs the ``box2d`` extra): the lander with continuous engine
throttles (the adapter ``lunarlander-continuous``).

The states are those of :mod:`tracecheck.live.envs.lunarlander` (the authors' LunarLander
vocabulary: screen coordinates, velocities, angle, legs, terrain), so its property set and
the authors' machine's variables apply unchanged. The action is one operation,
``FIRE(main, lateral)``, Gymnasium's action vector ``Box(-1, 1, (2,))``: ``main`` below 0
leaves the main engine off, from 0 to 1 it fires at 50 % to 100 % throttle; ``lateral``
between -0.5 and 0.5 leaves the side boosters off, above 0.5 fires the one that turns the
lander clockwise, below -0.5 the other, at 50 % to 100 %. Its shield is
``lunarlander_continuous`` (models/shields/lunarlander_continuous.mch). When the shield
allows nothing the lander fires its main engine at full throttle, the boosters off (the
shield's own rules never leave nothing: each bounds one parameter).
"""

from __future__ import annotations

from ...checking.shield import SHIELD_DIR
from .lunarlander import LunarLanderAdapter

__all__ = ["LunarLanderContinuousAdapter"]


class LunarLanderContinuousAdapter(LunarLanderAdapter):
    name = "lunarlander-continuous"
    description = "LunarLander with continuous thrust: main engine and lateral boosters in [-1, 1]"
    env_id = "LunarLanderContinuous-v3"
    actions = ("FIRE",)
    parameters = {"FIRE": ("main", "lateral")}
    default_shield = "lunarlander_continuous"
    shields = {"lunarlander_continuous": SHIELD_DIR / "lunarlander_continuous.mch"}
    fallback_action = (1.0, 0.0)  # full main thrust against a hard landing, boosters off

    def config_keys(self):
        """Gymnasium's settings but ``continuous``, which this environment fixes."""
        keys = super().config_keys()
        return None if keys is None else keys - {"continuous"}
