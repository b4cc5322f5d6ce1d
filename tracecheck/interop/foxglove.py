"""Foxglove-native channels: what Foxglove and Lichtblick draw without a plug-in.

Every step of an episode becomes, next to tracecheck's own messages:

* ``/foxglove/scene`` (``foxglove.SceneUpdate``): the vehicles of the highway as 5 m × 2 m
  cubes in the frame ``road`` (the ego vehicle at x = 0, as in tracecheck's viewer; y is the
  road's lateral position, flipped to Foxglove's left-handed-up convention), the ego vehicle
  blue (red once crashed); for the ``paper`` shield the zones its guards test, red where a
  vehicle blocks an action; a grid world as 1 × 1 tiles (holes and cliffs dark, the goal
  green) with the agent on them;
* ``/foxglove/log`` (``foxglove.Log``): one entry per shield intervention (the agent's choice
  replaced), deadlock (nothing allowed) and crash;
* ``/plot/speed``, ``/plot/reward``, ``/plot/nearest_gap``, ``/plot/allowed_actions``
  (``tracecheck.Scalar``, ``{"value": x}``): lines in a Plot panel. ``nearest_gap`` is the
  distance in metres between the ego vehicle's centre and the nearest other present vehicle's
  centre; ``allowed_actions`` the number of actions the live shield allowed.

A value a state does not have (no speed in a grid world) gives no message on that channel.
The messages are derived from the step: tracecheck itself never reads them back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterator, Optional

from ..render.scene import grid_cells, paper_zones, scene_kind, vehicles

__all__ = ["FoxgloveMessage", "step_messages", "SCHEMAS", "TOPICS", "SCALARS"]

SCENE, LOG, SCALAR = "foxglove.SceneUpdate", "foxglove.Log", "tracecheck.Scalar"
SCALARS = ("speed", "reward", "nearest_gap", "allowed_actions")
#: topic -> schema name
TOPICS = {"/foxglove/scene": SCENE, "/foxglove/log": LOG,
          **{f"/plot/{name}": SCALAR for name in SCALARS}}

_TIME = {"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0},
                                          "nsec": {"type": "integer", "minimum": 0,
                                                   "maximum": 999_999_999}},
         "required": ["sec", "nsec"]}


def _numbers(*keys: str) -> dict:
    return {"type": "object", "required": list(keys),
            "properties": {k: {"type": "number"} for k in keys}}


_ENTITY_LISTS = ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts",
                 "models")
#: The JSON schemas registered with the channels: the fields, types and required keys of
#: Foxglove's published schemas (foxglove-sdk, schemas/jsonschema) for what tracecheck writes.
SCHEMAS: dict[str, dict] = {
    SCENE: {
        "title": SCENE, "type": "object", "required": ["deletions", "entities"],
        "properties": {
            "deletions": {"type": "array", "items": {
                "type": "object", "required": ["timestamp", "type", "id"],
                "properties": {"timestamp": _TIME, "type": {"enum": [0, 1]},
                               "id": {"type": "string"}}}},
            "entities": {"type": "array", "items": {
                "type": "object",
                "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked",
                             "metadata", *_ENTITY_LISTS],
                "properties": {
                    "timestamp": _TIME, "frame_id": {"type": "string"},
                    "id": {"type": "string"}, "lifetime": _TIME,
                    "frame_locked": {"type": "boolean"},
                    "metadata": {"type": "array", "items": {
                        "type": "object", "required": ["key", "value"],
                        "properties": {"key": {"type": "string"},
                                       "value": {"type": "string"}}}},
                    "cubes": {"type": "array", "items": {
                        "type": "object", "required": ["pose", "size", "color"],
                        "properties": {
                            "pose": {"type": "object", "required": ["position", "orientation"],
                                     "properties": {"position": _numbers("x", "y", "z"),
                                                    "orientation": _numbers("x", "y", "z", "w")}},
                            "size": _numbers("x", "y", "z"),
                            "color": _numbers("r", "g", "b", "a")}}},
                    **{k: {"type": "array", "maxItems": 0} for k in _ENTITY_LISTS
                       if k != "cubes"}}}}}},
    LOG: {
        "title": LOG, "type": "object",
        "required": ["timestamp", "level", "message", "name", "file", "line"],
        "properties": {"timestamp": _TIME, "level": {"enum": [0, 1, 2, 3, 4, 5]},
                       "message": {"type": "string"}, "name": {"type": "string"},
                       "file": {"type": "string"}, "line": {"type": "integer", "minimum": 0}}},
    SCALAR: {"title": SCALAR, "type": "object", "required": ["value"],
             "properties": {"value": {"type": "number"}}},
}

WARNING, ERROR = 3, 4  # foxglove.LogLevel
_EGO, _CRASHED, _OTHER, _ABSENT = ((0.16, 0.4, 0.9, 1.0), (0.85, 0.1, 0.1, 1.0),
                                   (0.55, 0.55, 0.55, 1.0), (0.55, 0.55, 0.55, 0.25))
_ZONE, _BLOCKING = (0.95, 0.8, 0.2, 0.2), (0.9, 0.15, 0.15, 0.35)
_TILE, _DARK, _GOAL, _AGENT = ((0.85, 0.9, 0.95, 1.0), (0.15, 0.2, 0.3, 1.0),
                               (0.3, 0.75, 0.35, 1.0), (0.16, 0.4, 0.9, 1.0))
@dataclass(frozen=True)
class FoxgloveMessage:
    """One message: its topic (its schema is ``TOPICS[topic]``) and its JSON data."""

    topic: str
    data: dict[str, Any]


def _stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _cube(x: float, y: float, z: float, size: tuple, color: tuple) -> dict:
    return {"pose": {"position": {"x": float(x), "y": float(y), "z": float(z)},
                     "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
            "size": dict(zip("xyz", map(float, size))), "color": dict(zip("rgba", color))}


def _entity(ns: int, name: str, cubes: list, **metadata: str) -> dict:
    entity = {"timestamp": _stamp(ns), "frame_id": "road", "id": name,
              "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False,
              "metadata": [{"key": k, "value": v} for k, v in metadata.items()]}
    entity.update({k: [] for k in _ENTITY_LISTS})
    entity["cubes"] = cubes
    return entity


def _road(state, ns: int, crashed: bool, zones: bool
          ) -> tuple[list, Optional[float], Optional[float]]:
    """Entities of the highway, the ego vehicle's speed and the distance to the nearest other
    present vehicle."""
    cars = vehicles(state)
    ego = next((v for v in cars if v["name"] == "EgoVehicle"), None)
    if ego is None:
        return [], None, None
    entities, gaps = [], []
    for v in cars:
        is_ego = v is ego
        x, y = (0.0, ego["y"]) if is_ego else (v["x"], ego["y"] + v["y"])
        color = ((_CRASHED if crashed else _EGO) if is_ego else
                 _OTHER if v["present"] else _ABSENT)
        entities.append(_entity(ns, v["name"], [_cube(x, -y, 0.75, (5, 2, 1.5), color)],
                                vx=f"{v['vx']:.2f}", present=str(v["present"]).lower()))
        if not is_ego and v["present"]:
            gaps.append(math.hypot(v["x"], v["y"]))
    if zones:
        entities.append(_entity(ns, "shield zones", [
            _cube((z["x0"] + z["x1"]) / 2, -(ego["y"] + (z["y0"] + z["y1"]) / 2), 0.05,
                  (z["x1"] - z["x0"], z["y1"] - z["y0"], 0.1),
                  _BLOCKING if z["blocking"] else _ZONE) for z in paper_zones(cars)],
            shield="paper"))
    return entities, ego["vx"], (min(gaps) if gaps else None)


def _grid(state, ns: int) -> list:
    grid = grid_cells(state)
    goal = (state.get("goal_x"), state.get("goal_y"))
    tiles = [_cube(x, -y, 0.0, (0.96, 0.96, 0.05),
                   _DARK if danger else _GOAL if (x, y) == goal else _TILE)
             for x, y, danger, _ in grid["cells"]]
    return [_entity(ns, "map", tiles),
            _entity(ns, "agent", [_cube(state["x"], -state["y"], 0.3, (0.6, 0.6, 0.6),
                                        _AGENT)])]


def step_messages(step, *, episode: int, stamp_ns: int, zones: bool = False,
                  previous_crashed: bool = False) -> Iterator[FoxgloveMessage]:
    """The Foxglove messages of one step (a ``StepRecord``) at ``stamp_ns``; ``zones`` draws
    the paper shield's zones; ``previous_crashed`` keeps a crash from being logged twice."""
    state = step.state
    kind = scene_kind(state)
    speed = gap = None
    if kind == "road":
        entities, speed, gap = _road(state, stamp_ns, bool(step.crashed), zones)
    elif kind == "grid":
        entities = _grid(state, stamp_ns)
    else:
        entities = []
    if entities:
        yield FoxgloveMessage("/foxglove/scene", {
            "deletions": [{"timestamp": _stamp(stamp_ns), "type": 1, "id": ""}],
            "entities": entities})
    where = f"episode {episode}, step {step.step}"
    events = []
    if step.preferred_action is not None and step.action is not None \
            and step.preferred_action != step.action:
        events.append((WARNING, f"{where}: the shield replaced {step.preferred_action} by "
                                f"{step.action}"))
    if step.deadlock:
        events.append((ERROR, f"{where}: deadlock, the shield allowed no action; the "
                              "fallback was taken"))
    if step.crashed and not previous_crashed:
        events.append((ERROR, f"{where}: crash"))
    for level, message in events:
        yield FoxgloveMessage("/foxglove/log", {
            "timestamp": _stamp(stamp_ns), "level": level, "message": message,
            "name": "tracecheck", "file": f"episode {episode}", "line": step.step})
    values = {"speed": speed, "reward": step.reward, "nearest_gap": gap,
              "allowed_actions": (len(step.allowed_actions)
                                  if step.allowed_actions is not None else None)}
    for name in SCALARS:
        value = values[name]
        if value is not None and math.isfinite(value):
            yield FoxgloveMessage(f"/plot/{name}", {"value": float(value)})
