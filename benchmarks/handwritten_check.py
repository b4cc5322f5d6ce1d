"""The baseline a user would write without tracecheck: read SimB traces, compute the paper
shield's guards (Table 1, as ``models/shields/paper.mch`` encodes them) state by state in
plain Python, and count the steps whose action the shield would have blocked.

    python benchmarks/handwritten_check.py FOLDER_OF_SIMB_TRACES

Prints ``steps infeasible`` (the numbers ``tracecheck replay --shield paper`` reports for
the same episodes). It imports nothing of tracecheck: it is what tracecheck is measured
against in ``benchmarks/bench_replay.py``.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

_PAIR = re.compile(r"\(([A-Za-z0-9_]+)(?:↦|\|->)(-?[0-9.eE+-]+)\)")
EGO = "EgoVehicle"


def function(text: str) -> dict[str, float]:
    return {k: float(v) for k, v in _PAIR.findall(text)}


def elements(text: str) -> set[str]:
    return {e for e in text.strip("{}").split(",") if e}


def state_of(fixed: dict) -> dict:
    return {"present": elements(fixed["PresentVehicles"]), "x": function(fixed["VehiclesX"]),
            "y": function(fixed["VehiclesY"]), "vx": function(fixed["VehiclesVx"])}


def enabled(s: dict) -> set[str]:
    x, y, vx = s["x"], s["y"], s["vx"]
    others = [v for v in s["present"] if v != EGO]

    def lane(v, dy):
        return dy - 2.0 < y[v] < dy + 2.0

    def ahead(v, lo, hi):
        return lo < x[v] <= hi

    def front_within(d, slower):
        return any(0.0 < x[v] < d + 5.0 and -3.5 < y[v] < 3.5 and (not slower or vx[v] < 0.0)
                   for v in others)

    left = y[EGO] > 1.0 and not any(
        lane(v, -4.0) and ((ahead(v, 15.0, 35.0) and vx[v] < 0.0) or ahead(v, -15.0, 15.0)
                           or (ahead(v, -25.0, -15.0) and vx[v] > 0.0)) for v in others)
    right = y[EGO] < 7.0 and not any(
        lane(v, 4.0) and ((ahead(v, 15.0, 35.0) and vx[v] < 0.0) or -15.0 < x[v] < 15.0
                          or (ahead(v, -25.0, -15.0) and vx[v] > 0.0)) for v in others)
    out = set()
    if not front_within(30.0, True):
        out.add("IDLE")
    if left:
        out.add("LANE_LEFT")
    if right:
        out.add("LANE_RIGHT")
    if EGO in vx and not front_within(40.0, False):
        out.add("FASTER")
    if not front_within(10.0, True) or (not left and not right):
        out.add("SLOWER")
    return out


def check(folder: Path) -> tuple[int, int]:
    steps = infeasible = 0
    for path in sorted(folder.glob("*.json")):
        before = None
        for act in json.loads(path.read_text())["activations"]:
            fixed = act.get("fixedVariables")
            if not fixed:
                continue
            state = state_of(fixed)
            if act["execute"] != "$initialise_machine" and before is not None:
                steps += 1
                infeasible += act["execute"] not in enabled(before)
            before = state
    return steps, infeasible


if __name__ == "__main__":
    steps, infeasible = check(Path(sys.argv[1]))
    print(steps, infeasible)
