"""What a state shows, for every picture of it (the HTML viewer, Foxglove scenes): a road of
vehicles (the highway), a grid world, or nothing to draw."""

from __future__ import annotations

from ..b.values import format_value

__all__ = ["scene_kind", "grid_cells", "vehicles", "DANGER"]

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
