"""How a state is drawn: the built-in scenes (the highway, the grid worlds), the drawer that
asks an adapter's own ``scene`` hook first, and a scene as the viewer's JSON or a static SVG.
The shapes themselves (:class:`~tracecheck.live.scene.Scene`, ``Box``, ``Circle``, ``Line``,
``Text``) are the adapters' contract and live in :mod:`tracecheck.live.scene`.

Built-in scenes: the highway (:func:`road_scene`) and the grid worlds FrozenLake and
CliffWalking (:func:`grid_scene`), recognised by the shape of their states.
"""

from __future__ import annotations

from typing import Callable, Optional

from ..b.values import format_value
from ..errors import InputError
from ..identity import ByIdentity
from ..live.scene import (BLACK, GREEN, GREY, RED, WHITE, YELLOW, Box, Circle, Color, Line,
                          Scene, Shape)

__all__ = ["scene_kind", "grid_cells", "vehicles", "paper_zones", "road_scene", "grid_scene",
           "builtin_scene", "scene_drawer", "scene_svg", "css", "shape_json", "DANGER",
           "ROAD_CAPTION", "GRID_CAPTION"]

EGO = (0.16, 0.4, 0.9, 1.0)


def css(color: Optional[Color]) -> str:
    """A colour as CSS (``none`` for None)."""
    if color is None:
        return "none"
    r, g, b, a = color
    return f"rgba({round(r * 255)},{round(g * 255)},{round(b * 255)},{a:g})"


def shape_json(shape: Shape) -> dict:
    """A shape as the HTML viewer reads it (colours as CSS)."""
    if isinstance(shape, Box):
        return {"kind": "box", "x": shape.x, "y": shape.y, "w": shape.width,
                "h": shape.height, "fill": css(shape.fill), "stroke": css(shape.stroke),
                "sw": shape.stroke_width, "dashed": shape.dashed, "label": shape.label}
    if isinstance(shape, Circle):
        return {"kind": "circle", "x": shape.x, "y": shape.y, "r": shape.radius,
                "fill": css(shape.fill), "stroke": css(shape.stroke),
                "sw": shape.stroke_width, "label": shape.label}
    if isinstance(shape, Line):
        return {"kind": "line", "points": [list(p) for p in shape.points],
                "stroke": css(shape.color), "sw": shape.width, "dashed": shape.dashed,
                "arrow": shape.arrow, "label": shape.label}
    return {"kind": "text", "x": shape.x, "y": shape.y, "text": shape.text,
            "size": shape.size, "fill": css(shape.color)}


# ------------------------------------------------------------------ the built-in scenes

_ROAD = ("VehiclesX", "VehiclesY", "VehiclesVx", "VehiclesVy")


def scene_kind(state: dict) -> str:
    """road (the highway), grid (a grid world: x, y and a field keyed by (x, y)), or none."""
    if all(hasattr(state.get(v), "map") for v in _ROAD):
        return "road"
    field_ = state.get("field")
    if type(state.get("x")) is int and type(state.get("y")) is int and _is_map(field_):
        return "grid"
    return "none"


#: whether a value is a grid world's map, by the value (one object in every state of a run)
_MAPS: ByIdentity[bool] = ByIdentity(16)


def _is_map(value) -> bool:
    """A function keyed by (x, y) pairs of integers."""
    if not hasattr(value, "map") or not value.map:
        return False
    known = _MAPS.get(value)
    if known is None:
        known = _MAPS.put(value, all(isinstance(k, tuple) and len(k) == 2
                                     and all(type(c) is int for c in k) for k in value.map))
    return known


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
    bounds relative to the ego vehicle and whether a present vehicle in it blocks the action."""
    others = [v for v in cars if v["name"] != ego and v["present"]]
    return [{"action": action, "x0": x0, "x1": x1, "y0": y0, "y1": y1,
             "blocking": any(x0 < v["x"] <= x1 and y0 < v["y"] < y1 and _BLOCKS[which](v["vx"])
                             for v in others)}
            for action, x0, x1, y0, y1, which in _PAPER_ZONES]


ROAD_CAPTION = ("Positions are vehicle centres; vehicles are drawn as 5 m × 2 m boxes; the ego "
                "vehicle is blue (red once crashed), the others grey, absent ones dashed; arrows show "
                "velocity (1 s of travel, relative speeds for others). Shaded: the zones the "
                "paper shield's guards test; red: a zone holding a vehicle, blocking an action.")
GRID_CAPTION = ("The grid world from above: dark cells are holes or cliffs, the yellow square "
                "the goal, the green disc the agent (red once it fell).")
_ZONE, _BLOCKING = (1.0, 0.84, 0.31, 0.18), (1.0, 0.32, 0.32, 0.3)
_EDGE, _LANE, _ASPHALT = (1.0, 1.0, 1.0, 1.0), (0.93, 0.93, 0.93, 1.0), (0.36, 0.36, 0.36, 1.0)


def road_scene(state: dict, crashed: bool = False, zones: bool = False,
               ego: str = "EgoVehicle") -> Scene:
    """The highway around the ego vehicle (at x = 0): three lanes, every vehicle as a
    5 m × 2 m box with its velocity arrow, and with ``zones`` the paper shield's zones."""
    cars = vehicles(state)
    me = next((v for v in cars if v["name"] == ego), None)
    ey = me["y"] if me is not None else 0.0
    shapes: list[Shape] = [Line(((-60.0, y), (140.0, y)), _EDGE, 0.3, group="road")
                           for y in (-2.0, 10.0)]
    shapes += [Line(((-60.0, y), (140.0, y)), _LANE, 0.15, dashed=True, group="road")
               for y in (2.0, 6.0)]
    if zones and me is not None:
        for z in paper_zones(cars, ego):
            color = _BLOCKING if z["blocking"] else _ZONE
            shapes.append(Box((z["x0"] + z["x1"]) / 2, ey + (z["y0"] + z["y1"]) / 2,
                              z["x1"] - z["x0"], z["y1"] - z["y0"], fill=color,
                              stroke=color[:3] + (1.0,),
                              label=z["action"] + (": blocked" if z["blocking"] else ""),
                              group="shield zones"))
    for v in cars:
        is_ego = v["name"] == ego
        x, y = (0.0, v["y"]) if is_ego else (v["x"], ey + v["y"])
        fill = (RED if crashed else EGO) if is_ego else GREY if v["present"] else None
        shapes.append(Box(x, y, 5.0, 2.0, fill=fill, stroke=(0.07, 0.07, 0.2, 1.0)
                          if v["present"] else GREY, dashed=not v["present"],
                          label=f"{v['name']}: x {v['x']:.1f}, y {v['y']:.1f}, vx {v['vx']:.1f}",
                          group=v["name"], depth=1.5))
        if v["present"] and (abs(v["vx"]) > 0.1 or abs(v["vy"]) > 0.1):
            shapes.append(Line(((x, y), (x + v["vx"], y + v["vy"])), WHITE, 0.2, arrow=True,
                               group=v["name"]))
    return Scene(tuple(shapes), (-60.0, -4.0, 200.0, 16.0), _ASPHALT, ROAD_CAPTION)


#: a map's tiles and size, drawn once for the map (one object in every state of a run)
_TILES: ByIdentity[tuple[tuple[Shape, ...], float, float]] = ByIdentity(16)


def _tiles(field_) -> tuple[tuple[Shape, ...], float, float]:
    """The tiles of a grid world's map, its columns and rows."""
    drawn = _TILES.get(field_)
    if drawn is None:
        grid = grid_cells({"field": field_})
        drawn = _TILES.put(field_, (tuple(
            Box(x + 0.5, y + 0.5, 1.0, 1.0, fill=(0.15, 0.2, 0.22, 1.0) if danger
                else (0.87, 0.94, 0.98, 1.0), stroke=WHITE, stroke_width=0.04,
                label=f"({x}, {y}): {label}", group="map", depth=0.05)
            for x, y, danger, label in grid["cells"]), float(grid["cols"]),
            float(grid["rows"])))
    return drawn


def grid_scene(state: dict, crashed: bool = False) -> Scene:
    """A grid world: one tile per cell (holes and cliffs dark), the goal, the agent."""
    tiles, cols, rows = _tiles(state["field"])
    shapes: list[Shape] = list(tiles)
    if "goal_x" in state and "goal_y" in state:
        shapes.append(Box(state["goal_x"] + 0.5, state["goal_y"] + 0.5, 0.6, 0.6, fill=YELLOW,
                          label="goal", group="goal", depth=0.1))
    shapes.append(Circle(state["x"] + 0.5, state["y"] + 0.5, 0.3,
                         fill=RED if crashed else GREEN, stroke=BLACK,
                         label=f"agent at ({state['x']}, {state['y']})", group="agent"))
    return Scene(tuple(shapes), (0.0, 0.0, cols, rows), None, GRID_CAPTION, scale=40.0)


def builtin_scene(state: dict, crashed: bool = False, zones: bool = False) -> Optional[Scene]:
    """The highway's or a grid world's scene when ``state`` is one of theirs, else None."""
    kind = scene_kind(state)
    if kind == "road":
        return road_scene(state, crashed, zones)
    if kind == "grid":
        return grid_scene(state, crashed)
    return None


def scene_drawer(environment: Optional[str] = None, adapter=None, *,
                 shield: Optional[str] = None) -> Callable[..., Optional[Scene]]:
    """A function from a step (a ``StepRecord``) to its scene: the adapter's own ``scene``
    hook where it has one (``adapter``, or the installed adapter named ``environment`` — only
    ever looked up among the installed entry points: the recorder, which has it loaded
    anyway), else the built-in scenes, with the zones of the ``paper`` shield when
    ``shield`` (a shield's name) is that one."""
    hook = _hook(adapter if adapter is not None else _installed(environment))
    zones = shield == "paper"

    def draw(step) -> Optional[Scene]:
        if hook is not None:
            scene = hook(step)
            if scene is not None and not isinstance(scene, Scene):
                raise InputError(f"the adapter's scene() returned {type(scene).__name__}, "
                                 "not a tracecheck.live.scene.Scene (or None)")
            if scene is not None:
                return scene
        return builtin_scene(step.state, bool(step.crashed), zones)
    return draw


_BUILTIN_ENVS = {None, "highway", "frozenlake", "cliffwalking"}


def _installed(environment: Optional[str]):
    """The installed adapter of that name, None when there is none (a run renders without
    its adapter) or the built-in scenes draw it (no environment package is imported)."""
    if environment in _BUILTIN_ENVS:
        return None
    from ..live.adapter import installed_adapter

    return installed_adapter(environment, required=False)


def _hook(adapter):
    from ..live.adapter import EnvAdapter

    method = getattr(type(adapter), "scene", None) if adapter is not None else None
    if method is None or method is EnvAdapter.scene:
        return None
    return adapter.scene


#: the smallest text a static picture shows, in pixels: a scene's text is sized in the
#: environment's units, and a thumbnail of a wide view would make it a few pixels high
MIN_TEXT_PX = 10.0


def scene_svg(scene: Scene, width: int = 360, max_height: int = 180,
              view: Optional[tuple[float, float, float, float]] = None) -> str:
    """A scene as a static inline SVG (the report's pictures; ``view`` instead of the
    scene's own), its texts at least :data:`MIN_TEXT_PX` high; every text escaped."""
    from html import escape

    x0, y0, w, h = view or scene.view
    width = min(width, round(max_height * w / h))
    height = max(10, round(width * h / w))
    least = MIN_TEXT_PX * w / width  # in the view's units
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0:g} {y0:g} {w:g} {h:g}" '
             f'width="{width}" height="{height}" role="img">']
    if scene.background is not None:
        parts.append(f'<rect x="{x0:g}" y="{y0:g}" width="{w:g}" height="{h:g}" '
                     f'fill="{css(scene.background)}"/>')
    for s in scene.shapes:
        title = f"<title>{escape(s.label)}</title>" if getattr(s, "label", "") else ""
        if isinstance(s, Box):
            dash = f' stroke-dasharray="{s.stroke_width * 4:g}"' if s.dashed else ""
            parts.append(f'<rect x="{s.x - s.width / 2:g}" y="{s.y - s.height / 2:g}" '
                         f'width="{s.width:g}" height="{s.height:g}" fill="{css(s.fill)}" '
                         f'stroke="{css(s.stroke)}" stroke-width="{s.stroke_width:g}"{dash}>'
                         f'{title}</rect>')
        elif isinstance(s, Circle):
            parts.append(f'<circle cx="{s.x:g}" cy="{s.y:g}" r="{s.radius:g}" '
                         f'fill="{css(s.fill)}" stroke="{css(s.stroke)}" '
                         f'stroke-width="{s.stroke_width:g}">{title}</circle>')
        elif isinstance(s, Line):
            points = " ".join(f"{x:g},{y:g}" for x, y in s.points)
            dash = f' stroke-dasharray="{s.width * 4:g}"' if s.dashed else ""
            parts.append(f'<polyline points="{points}" fill="none" stroke="{css(s.color)}" '
                         f'stroke-width="{s.width:g}"{dash}>{title}</polyline>')
        else:
            parts.append(f'<text x="{s.x:g}" y="{s.y:g}" font-size="{max(s.size, least):g}" '
                         f'fill="{css(s.color)}" text-anchor="middle" '
                         f'dominant-baseline="middle">{escape(s.text)}</text>')
    parts.append("</svg>")
    return "".join(parts)
