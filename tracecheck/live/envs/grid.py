"""Grid worlds of Gymnasium's toy text (FrozenLake, CliffWalking) as B states.

The conventions of the authors' glue code (hhu-stups/reinforcement-learning-b-models):
``x`` is the column and ``y`` the row of the agent (observation ``s = y * columns + x``),
``goal_x``/``goal_y`` the goal's, and ``field`` the map as ``(x |-> y) |-> KIND``.
"""

from __future__ import annotations

from typing import Any, Optional

from ...b.values import Elem, FuncValue
from ..adapter import GymnasiumAdapter, Observer
from .grid_scene import grid_scene

__all__ = ["GridAdapter"]


class GridAdapter(GymnasiumAdapter):
    """A toy-text grid world: subclasses name the tiles to avoid and the two kinds."""

    variables = ("x", "y", "goal_x", "goal_y", "field")
    #: the map letters of the tiles to avoid (FrozenLake: H; CliffWalking's cliff: C)
    danger: bytes = b""
    #: (the kind of a safe tile, the kind of a tile to avoid)
    kinds: tuple[str, str] = ("SAFE", "DANGER")

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        return self.grid_state(obs, self.grid_map(env.unwrapped))

    def observer(self, env) -> Observer:
        return _GridObserver(self, env)

    def scene(self, step, shield: Optional[str] = None):
        """The grid from above: the tiles to avoid dark, the goal, the agent."""
        state = step.state
        if type(state.get("x")) is not int or type(state.get("y")) is not int or \
                not isinstance(state.get("field"), FuncValue) or not state["field"].map:
            return None
        return grid_scene(state, bool(step.crashed), frozenset({self.kinds[1]}))

    @staticmethod
    def grid_state(obs, grid: tuple[int, FuncValue, tuple[int, int]]) -> dict[str, Any]:
        """The B state of observation ``obs`` on ``grid`` (:meth:`grid_map`)."""
        cols, field, (gx, gy) = grid
        s = int(obs)
        return {"x": s % cols, "y": s // cols, "goal_x": gx, "goal_y": gy, "field": field}

    def grid_map(self, base) -> tuple[int, FuncValue, tuple[int, int]]:
        """The map of the unwrapped environment ``base``: its columns, ``field`` and goal."""
        desc = getattr(base, "desc", None)
        rows, cols = base.shape if desc is None else desc.shape
        # the same map as the episode before is the same object: what is remembered for it
        # (its text in the file, its tiles drawn and encoded) holds in every episode
        # (a map of bytes is known by them; one of Python objects is built again)
        known = desc is None or getattr(getattr(desc, "dtype", None), "kind", None) == "S"
        key = (rows, cols, None if desc is None else desc.tobytes()) if known else None
        last = self.__dict__.get("_last_map")
        if key is not None and last is not None and last[0] == key:
            return last[1]
        grid = self._grid_map(desc, rows, cols)
        self._last_map = (key, grid)
        return grid

    def _grid_map(self, desc, rows: int, cols: int) -> tuple[int, FuncValue, tuple[int, int]]:
        safe, danger = Elem(self.kinds[0]), Elem(self.kinds[1])
        tiles = {(x, y): _tile(desc, rows, cols, x, y) for x in range(cols) for y in range(rows)}
        field = FuncValue({k: danger if t in self.danger else safe for k, t in tiles.items()})
        goal = next((k for k, t in tiles.items() if t == b"G"), (cols - 1, rows - 1))
        return cols, field, goal


class _GridObserver(Observer):
    """One episode's states: the map, the same in every step, is built once."""

    def __init__(self, adapter: GridAdapter, env) -> None:
        super().__init__(adapter, env)
        self._grid: Optional[tuple[int, FuncValue, tuple[int, int]]] = None

    def state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        if self._grid is None:
            self._grid = self.adapter.grid_map(self.env.unwrapped)
        return self.adapter.grid_state(obs, self._grid)


def _tile(desc, rows: int, cols: int, x: int, y: int) -> bytes:
    """The map letter at (x, y): FrozenLake's ``desc``; without one (CliffWalking, whose map
    is its ``shape``) the cliff, Gymnasium's bottom row between the start and the goal."""
    if desc is not None:
        return bytes(desc[y][x])
    return b"C" if y == rows - 1 and 0 < x < cols - 1 else b"."
