"""What a state shows, for every picture of it (the HTML viewer, Foxglove scenes): a road of
vehicles (the highway), a grid world, or nothing to draw."""

from __future__ import annotations

from ..b.values import format_value

__all__ = ["scene_kind", "grid_cells", "vehicles", "paper_zones", "DANGER"]

_ROAD = ("VehiclesX", "VehiclesY", "VehiclesVx", "VehiclesVy")


def scene_kind(state: dict) -> str:
    """road (the highway), grid (a grid world: x, y and a field keyed by (x, y)), or none
    (the page then shows the steps and states only)."""
    if all(hasattr(state.get(v), "map") for v in _ROAD):
        return "road"
    field = state.get("field")
    if (type(state.get("x")) is int and type(state.get("y")) is int and hasattr(field, "map")
            and all(isinstance(k, tuple) and len(k) == 2 and all(type(c) is int for c in k)
                    for k in field.map)):
        return "grid"
    return "none"


DANGER = {"HOLE", "CLIFF"}


def grid_cells(state: dict) -> dict:
    cells = [[x, y, str(v) in DANGER, format_value(v)]
             for (x, y), v in sorted(state["field"].map.items())]
    return {"cols": max(c[0] for c in cells) + 1, "rows": max(c[1] for c in cells) + 1,
            "cells": cells}


def vehicles(state: dict) -> list[dict]:
    present = {str(v) for v in state.get("PresentVehicles", ())}
    return [{"name": str(name), "present": str(name) in present, "x": x,
             "y": state["VehiclesY"].map[name], "vx": state["VehiclesVx"].map[name],
             "vy": state["VehiclesVy"].map[name]}
            for name, x in state["VehiclesX"].map.items()]


# the regions the paper shield's guards test around the ego vehicle (its Table 1): action,
# x from, x to, y from, y to (relative to the ego vehicle, m), and which vehicles there block
# the action (by their speed relative to the ego vehicle)
_PAPER_ZONES = (
    *((action, x0, x1, dy - 2, dy + 2, which)
      for action, dy in (("LANE_LEFT", -4), ("LANE_RIGHT", 4))
      for x0, x1, which in ((15, 35, "slower"), (-15, 15, "any"), (-25, -15, "faster"))),
    ("FASTER", 0, 45, -3.5, 3.5, "any"),
    ("IDLE", 0, 35, -3.5, 3.5, "slower"),
)
_BLOCKS = {"any": lambda vx: True, "slower": lambda vx: vx < 0, "faster": lambda vx: vx > 0}


def paper_zones(cars: list[dict], ego: str = "EgoVehicle") -> list[dict]:
    """The paper shield's zones for the vehicles of :func:`vehicles`: each with its action,
    bounds relative to the ego vehicle and whether a present vehicle in it blocks the action
    (drawn by the HTML viewer and in Foxglove scenes alike)."""
    others = [v for v in cars if v["name"] != ego and v["present"]]
    return [{"action": action, "x0": x0, "x1": x1, "y0": y0, "y1": y1,
             "blocking": any(x0 < v["x"] <= x1 and y0 < v["y"] < y1 and _BLOCKS[which](v["vx"])
                             for v in others)}
            for action, x0, x1, y0, y1, which in _PAPER_ZONES]
