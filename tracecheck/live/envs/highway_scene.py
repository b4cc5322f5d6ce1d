"""How the highway is drawn: the road around the ego vehicle, every vehicle as a 5 m × 2 m
box with its velocity, and for the ``paper`` shield the zones its guards test (its Table 1),
red where a vehicle blocks an action; and the numbers Foxglove plots (speed, nearest gap)."""

from __future__ import annotations

import math

from ..scene import GREY, RED, WHITE, Box, Line, Scene, Shape

__all__ = ["vehicles", "paper_zones", "road_scene", "road_plots", "ROAD_CAPTION", "NEAR"]

EGO = (0.16, 0.4, 0.9, 1.0)
#: the road near the ego vehicle, what a thumbnail shows (the whole view is a thin strip)
NEAR = (-30.0, -4.0, 100.0, 16.0)


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
    return Scene(tuple(shapes), (-60.0, -4.0, 200.0, 16.0), _ASPHALT, ROAD_CAPTION,
                 focus=NEAR)




def road_plots(state: dict) -> dict[str, float]:
    """The ego vehicle's speed and the distance between its centre and the nearest other
    present vehicle's (none without an ego vehicle; no gap without another vehicle)."""
    if not all(hasattr(state.get(v), "map") for v in ("VehiclesX", "VehiclesY", "VehiclesVx",
                                                        "VehiclesVy")):
        return {}
    cars = vehicles(state)
    ego = next((v for v in cars if v["name"] == "EgoVehicle"), None)
    if ego is None:
        return {}
    gaps = [math.hypot(v["x"], v["y"]) for v in cars if v is not ego and v["present"]]
    return {"speed": ego["vx"], **({"nearest_gap": min(gaps)} if gaps else {})}
