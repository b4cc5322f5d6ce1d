"""Every machine of the authors' repository loads, type-checks, and has its guards computed.

The machines are read from ../shared/data/paper-models (never copied into this repository);
the tests skip where that folder is absent. The expected enabled sets were worked out by hand
from the guards.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tracecheck.b.machine import load_machine
from tracecheck.b.notation import parse_literal
from tracecheck.cli import main

MODELS = Path(__file__).resolve().parents[3] / "shared" / "data" / "paper-models"
ALL = sorted(MODELS.rglob("*.mch")) if MODELS.is_dir() else []
pytestmark = pytest.mark.skipif(not ALL, reason=f"the authors' machines are not at {MODELS}")

VEHICLES = ("EgoVehicle", "Vehicles2", "Vehicles3", "Vehicles4", "Vehicles5")


def func(**values) -> str:
    return "{" + ",".join(f"({k}|->{v})" for k, v in values.items()) + "}"


def highway(x: dict, y: dict, vx: dict) -> dict:
    """Ego vehicle in the middle lane; Vehicles2 ahead in its lane and slower, Vehicles3 in
    the left lane beside it (coordinates as given: relative or absolute)."""
    zeros = func(**{v: "0.0" for v in VEHICLES})
    return {"Crash": "FALSE", "PresentVehicles": "{EgoVehicle,Vehicles2,Vehicles3}",
            "VehiclesX": func(**x), "VehiclesY": func(**y), "VehiclesVx": func(**vx),
            "VehiclesVy": zeros, "VehiclesAx": zeros, "VehiclesAy": zeros, "Reward": "0.5",
            "ErrorMsg": '""'}


RELATIVE = highway(
    dict(EgoVehicle=100.0, Vehicles2=20.0, Vehicles3=5.0, Vehicles4=0.0, Vehicles5=0.0),
    dict(EgoVehicle=4.0, Vehicles2=0.0, Vehicles3=-4.0, Vehicles4=0.0, Vehicles5=0.0),
    dict(EgoVehicle=25.0, Vehicles2=-3.0, Vehicles3=0.0, Vehicles4=0.0, Vehicles5=0.0))
ABSOLUTE = highway(
    dict(EgoVehicle=100.0, Vehicles2=120.0, Vehicles3=105.0, Vehicles4=0.0, Vehicles5=0.0),
    dict(EgoVehicle=4.0, Vehicles2=4.0, Vehicles3=0.0, Vehicles4=0.0, Vehicles5=0.0),
    dict(EgoVehicle=25.0, Vehicles2=22.0, Vehicles3=25.0, Vehicles4=0.0, Vehicles5=0.0))


def grid(width: int, height: int, special: set, kinds: tuple[str, str]) -> str:
    return "{" + ",".join(f"({x}|->{y}|->{kinds[(x, y) in special]})"
                          for x in range(width) for y in range(height)) + "}"


FROZEN = {"x": "0", "y": "0", "goal_x": "7", "goal_y": "7",
          "field": grid(8, 8, {(2, 3), (3, 5)}, ("ICE", "HOLE"))}
CLIFF = {"x": "0", "y": "3", "goal_x": "11", "goal_y": "3",
         "field": grid(12, 4, {(x, 3) for x in range(1, 11)}, ("GRASS", "CLIFF"))}
LUNAR = {"x": "0.1", "y": "1.2", "v_x": "0.0", "v_y": "-0.5", "angle": "0.0",
         "v_angular": "0.0", "left_leg_on_ground": "FALSE", "right_leg_on_ground": "FALSE",
         "surface": "{" + ",".join(f"({i}|->(({i}.0|->0.0)|->({i}.5|->0.1)))"
                                   for i in range(1, 11)) + "}"}
DRONES = {"visited": "{(1|->(0|->0)),(2|->(3|->4))}",
          "drone_positions": "{(1|->(0|->0)),(2|->(3|->4))}", "current_drone": "1"}
DRONES_4 = dict(DRONES, drone_positions="{(1|->(0|->0)),(2|->(3|->4)),(3|->(5|->5)),"
                                        "(4|->(9|->9))}")
SMALL_DRONES = dict(DRONES, visited="{(0|->0),(3|->3)}",  # visited <: positions
                    drone_positions="{(1|->(0|->0)),(2|->(3|->3))}")

#: (state, the enabled operations where worked out by hand, else None)
CASES = {
    "FrozenLake/FrozenLake.mch": (FROZEN, {"Move_Down", "Move_Right"}),
    "CliffWalking/CliffWalking.mch": (CLIFF, {"Move_Up"}),
    "LunarLander/LunarLander.mch": (LUNAR, None),
    "AutonomousDroneSwarm/AutonomousDroneSwarm.mch": (DRONES, {"Move_Down", "Move_Right"}),
    "AutonomousDroneSwarm/AutonomousDroneSwarm_4.mch": (DRONES_4, None),
    "AutonomousDroneSwarm/AutonomousDroneSwarm_abstract.mch": (SMALL_DRONES, None),
    "AutonomousDroneSwarm/AutonomousDroneSwarm_small_abstract.mch": (SMALL_DRONES, None),
    "HighwayEnvironment/HighwayEnvironment.mch": (RELATIVE, None),
    "HighwayEnvironment/HighwayEnvironment2.mch": (RELATIVE, {"LANE_RIGHT", "SLOWER"}),
    "HighwayEnvironment/HighwayEnvironment3.mch": (RELATIVE, {"LANE_RIGHT", "SLOWER"}),
    "HighwayEnvironment/HighwayEnvironment4.mch": (RELATIVE, {"LANE_RIGHT", "SLOWER"}),
    "HighwayEnvironment/HighwayEnvironment_RSS.mch": (RELATIVE, None),
    "HighwayEnvironment/HighwayEnvironment_RSS_v2.mch": (RELATIVE, None),
    "HighwayEnvironment_v2/HighwayEnvironment.mch": (ABSOLUTE, None),
    "HighwayEnvironment_v2/HighwayEnvironment2.mch": (ABSOLUTE, {"LANE_RIGHT", "SLOWER"}),
    "HighwayEnvironment_v2/HighwayEnvironment3.mch": (ABSOLUTE, {"LANE_RIGHT", "SLOWER"}),
    "HighwayEnvironment_v2/HighwayEnvironment_RSS.mch": (ABSOLUTE, None),
    "HighwayEnvironment_v2/HighwayEnvironment_RSS_v2.mch": (ABSOLUTE, None),
}


def test_every_machine_of_the_repository_has_a_case():
    assert sorted(str(p.relative_to(MODELS)) for p in ALL) == sorted(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_check_model_accepts_it(name, capsys):
    with pytest.raises(SystemExit) as stop:
        main(["check-model", str(MODELS / name)])
    assert stop.value.code in (0, None), capsys.readouterr()
    assert "ok:" in capsys.readouterr().out


@pytest.mark.parametrize("name", sorted(CASES))
def test_guards_in_a_state(name):
    machine = load_machine(MODELS / name)
    text, expected = CASES[name]
    state = {k: parse_literal(v) for k, v in text.items() if k in machine.variables}
    machine.check_state(state)
    enabled = machine.enabled(state)
    assert enabled <= set(machine.operations)
    if expected is not None:
        assert enabled == expected


def test_cliffwalking_constants_are_the_explicit_sets():
    machine = load_machine(MODELS / "CliffWalking" / "CliffWalking.mch")
    assert machine.base_env["cliffs"] == frozenset((x, 3) for x in range(1, 11))


def test_frozenlake_invariant_holds_on_a_valid_field():
    machine = load_machine(MODELS / "FrozenLake" / "FrozenLake.mch")
    state = {k: parse_literal(v) for k, v in FROZEN.items()}
    assert machine.invariant(state)
    broken = dict(state, field=parse_literal("{(0|->0|->ICE)}"))
    assert not machine.invariant(broken)


def test_rss_error_message_is_a_formatted_template_string():
    machine = load_machine(MODELS / "HighwayEnvironment" / "HighwayEnvironment_RSS.mch")
    state = {k: parse_literal(v) for k, v in RELATIVE.items()}
    text = machine.evaluate(
        "```IDLE at x:$[2f]{VehiclesX(EgoVehicle)} y:$[2f]{VehiclesY(EgoVehicle)}```", state)
    assert text == "IDLE at x:100.00 y:4.00"


def test_import_the_authors_frozenlake_trace_typed_by_its_machine(tmp_path):
    from tracecheck.episodes.reader import read_episodes

    out = tmp_path / "frozen.mcap"
    with pytest.raises(SystemExit) as stop:
        main(["import", "prob2trace", str(MODELS / "FrozenLake" / "FrozenLake.prob2trace"),
              "--model", str(MODELS / "FrozenLake" / "FrozenLake.mch"), "-o", str(out)])
    assert stop.value.code in (0, None)
    (episode,) = read_episodes(out)
    machine = load_machine(MODELS / "FrozenLake" / "FrozenLake.mch")
    first = episode.steps[0].state
    assert first["field"].map[(2, 3)] == "HOLE" and first["x"] == 0
    for step in episode.steps:
        machine.check_state(step.state)
        assert machine.invariant(step.state)
    # The trace's field is keyed row|->column (gymnasium's map: holes at row 5, columns 1
    # and 2), but the guards read field(x |-> y): two of its moves are not enabled under the
    # authors' own machine, and every move is once the field is transposed.
    moves = list(zip(episode.steps, episode.steps[1:]))
    blocked = [after.step for before, after in moves
               if not machine.is_enabled(after.action, before.state)]
    assert blocked == [7, 10]
    for before, after in moves:
        field = before.state["field"]
        transposed = dict(before.state,
                          field=type(field)({(y, x): v for (x, y), v in field.map.items()}))
        assert machine.is_enabled(after.action, transposed), after.step


def test_the_authors_frozenlake_machine_replays_the_imported_trace(tmp_path, capsys):
    out = tmp_path / "frozen.mcap"
    machine_path = str(MODELS / "FrozenLake" / "FrozenLake.mch")
    with pytest.raises(SystemExit):
        main(["import", "prob2trace", str(MODELS / "FrozenLake" / "FrozenLake.prob2trace"),
              "--model", machine_path, "-o", str(out)])
    capsys.readouterr()
    with pytest.raises(SystemExit) as stop:
        main(["replay", str(out), "--shield", machine_path, "--json"])
    assert stop.value.code in (0, None)
    import json

    (episode,) = json.loads(capsys.readouterr().out)["per_episode"]
    assert episode["first_infeasible"] == 7 and episode["infeasible_steps"] == 2
