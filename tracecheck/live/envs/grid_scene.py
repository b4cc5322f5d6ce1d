"""How a grid world is drawn: one tile per cell from above (the tiles to avoid dark), the
goal, the agent."""

from __future__ import annotations

from ...b.values import format_value
from ...identity import ByIdentity
from ..scene import BLACK, GREEN, RED, WHITE, YELLOW, Box, Circle, Scene, Shape

__all__ = ["grid_cells", "grid_scene", "GRID_CAPTION"]

GRID_CAPTION = ("The grid world from above: dark cells are holes or cliffs, the yellow square "
                "the goal, the green disc the agent (red once it fell).")


def grid_cells(state: dict, danger: frozenset[str]) -> dict:
    """A map's cells (x, y, whether its kind is one of ``danger``, its kind), columns, rows."""
    cells = [[x, y, str(v) in danger, format_value(v)]
             for (x, y), v in sorted(state["field"].map.items())]
    return {"cols": max(c[0] for c in cells) + 1, "rows": max(c[1] for c in cells) + 1,
            "cells": cells}


#: a map's tiles and size, drawn once for the map (one object in every state of a run), with
#: the kinds drawn dark they were drawn for
_TILES: ByIdentity[tuple[tuple[Shape, ...], float, float, frozenset]] = ByIdentity(16)


def _tiles(field_, danger: frozenset[str]) -> tuple[tuple[Shape, ...], float, float, frozenset]:
    """The tiles of a grid world's map, its columns and rows (and ``danger``)."""
    drawn = _TILES.get(field_)
    if drawn is None or drawn[3] != danger:
        grid = grid_cells({"field": field_}, danger)
        drawn = _TILES.put(field_, (tuple(
            Box(x + 0.5, y + 0.5, 1.0, 1.0, fill=(0.15, 0.2, 0.22, 1.0) if dark
                else (0.87, 0.94, 0.98, 1.0), stroke=WHITE, stroke_width=0.04,
                label=f"({x}, {y}): {label}", group="map", depth=0.05)
            for x, y, dark, label in grid["cells"]), float(grid["cols"]),
            float(grid["rows"]), danger))
    return drawn


def grid_scene(state: dict, crashed: bool = False,
               danger: frozenset[str] = frozenset()) -> Scene:
    """A grid world: one tile per cell (those of a kind in ``danger`` dark), the goal, the
    agent."""
    tiles, cols, rows, _ = _tiles(state["field"], danger)
    goal = _goal(state["goal_x"], state["goal_y"]) if "goal_x" in state and "goal_y" in \
        state else None
    agent = _agent(state["x"], state["y"], crashed)
    # the same tiles, goal and agent: the same scene (what is remembered for it, its
    # Foxglove entities encoded, holds at every step it is drawn)
    key = (id(tiles), id(goal), id(agent))
    drawn = _SCENES.get(key)
    if drawn is not None and drawn[0] is tiles and drawn[1] is goal and drawn[2] is agent:
        return drawn[3]
    shapes = (*tiles, agent) if goal is None else (*tiles, goal, agent)
    scene = Scene(shapes, (0.0, 0.0, cols, rows), None, GRID_CAPTION, scale=40.0)
    if len(_SCENES) >= 4096:
        _SCENES.clear()
    _SCENES[key] = (tiles, goal, agent, scene)  # held: their ids are theirs while it lives
    return scene


#: the scenes drawn so far, by the ids of their tiles, goal and agent (held with them)
_SCENES: dict[tuple[int, int, int], tuple] = {}


#: the goal and agent shapes drawn so far, by where (the same object for the same place:
#: what is remembered for a shape, its Foxglove entity, holds at every step)
_PLACED: dict[tuple, Shape] = {}


def _placed(key: tuple, make) -> Shape:
    # each number by its type and its text, as the label prints it (0.0 and -0.0 differ)
    shape = _PLACED.get(key)
    if shape is None:
        if len(_PLACED) >= 4096:
            _PLACED.clear()
        shape = _PLACED[key] = make()
    return shape


def _goal(x, y) -> Shape:
    return _placed(("goal", type(x), str(x), type(y), str(y)), lambda: Box(
        x + 0.5, y + 0.5, 0.6, 0.6, fill=YELLOW, label="goal", group="goal", depth=0.1))


def _agent(x, y, crashed: bool) -> Shape:
    return _placed(("agent", type(x), str(x), type(y), str(y), crashed), lambda: Circle(
        x + 0.5, y + 0.5, 0.3, fill=RED if crashed else GREEN, stroke=BLACK,
        label=f"agent at ({x}, {y})", group="agent"))


