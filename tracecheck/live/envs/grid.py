"""Grid worlds of Gymnasium's toy text (FrozenLake, CliffWalking) as B states.

The conventions of the authors' glue code (hhu-stups/reinforcement-learning-b-models):
``x`` is the column and ``y`` the row of the agent (observation ``s = y * columns + x``),
``goal_x``/``goal_y`` the goal's, and ``field`` the map as ``(x |-> y) |-> KIND``.
"""

from __future__ import annotations

from typing import Any, Optional

from ...b.values import Elem, FuncValue
from ..adapter import EnvAdapter, gymnasium_keys, gymnasium_kinds

__all__ = ["GridAdapter"]


class GridAdapter(EnvAdapter):
    """A toy-text grid world: subclasses name the tiles to avoid and the two kinds."""

    variables = ("x", "y", "goal_x", "goal_y", "field")
    #: the map letters of the tiles to avoid (FrozenLake: H; CliffWalking's cliff: C)
    danger: bytes = b""
    #: (the kind of a safe tile, the kind of a tile to avoid)
    kinds: tuple[str, str] = ("SAFE", "DANGER")

    def config_keys(self):
        return gymnasium_keys(self.env_id)

    def config_kinds(self):
        return gymnasium_kinds(self.env_id)

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        import gymnasium as gym

        # unwrapped: no time limit of Gymnasium's own (the horizon bounds episodes)
        return gym.make(self.env_id, render_mode=render_mode, **config).unwrapped

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        base = env.unwrapped
        cached = getattr(base, "_tracecheck_grid", None)
        if cached is None:  # the map is the same in every step: built once per environment
            cached = base._tracecheck_grid = self._map(base)
        cols, field, (gx, gy) = cached
        s = int(obs)
        return {"x": s % cols, "y": s // cols, "goal_x": gx, "goal_y": gy, "field": field}

    def _map(self, base):
        desc = getattr(base, "desc", None)
        rows, cols = base.shape if desc is None else desc.shape
        safe, danger = Elem(self.kinds[0]), Elem(self.kinds[1])
        tiles = {(x, y): self._tile(base, desc, x, y) for x in range(cols) for y in range(rows)}
        field = FuncValue({k: danger if t in self.danger else safe for k, t in tiles.items()})
        goal = next((k for k, t in tiles.items() if t == b"G"), (cols - 1, rows - 1))
        return cols, field, goal

    @staticmethod
    def _tile(base, desc, x: int, y: int) -> bytes:
        if desc is not None:
            return bytes(desc[y][x])
        return b"C" if base._cliff[y, x] else b"."
