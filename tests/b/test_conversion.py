"""The one state conversion (issue 42): Python and numpy values to B values by the machine's
types, each refusal naming where the state came from, the variable, the type and the value."""

from __future__ import annotations

import numpy as np
import pytest

from tracecheck.b.conversion import StateTypes, convert_state
from tracecheck.b.machine import load_machine_text
from tracecheck.b.values import Elem, FuncValue, Record
from tracecheck.errors import InputError

LAVA = """
MACHINE Lava
SETS CELL = {Floor, Wall, Lava, Goal}; DIR = {East, South, West, North}
VARIABLES ahead, facing, grid, seen, path, pos, speed, count, on, label, record, world
INVARIANT ahead : CELL & facing : DIR & grid : (0..2)*(0..1) --> CELL
  & seen : POW(CELL) & path : seq(INTEGER) & pos : INTEGER * INTEGER & speed : REAL
  & count : INTEGER & on : BOOL & label : STRING & record : struct(a : INTEGER, b : BOOL)
  & world : 0..3 --> REAL
INITIALISATION ahead := Floor || facing := East || grid := (0..2)*(0..1) * {Floor}
  || seen := {} || path := [] || pos := (0 |-> 0) || speed := 0.0 || count := 0
  || on := FALSE || label := "" || record := rec(a : 0, b : FALSE) || world := (0..3) * {0.0}
OPERATIONS
  Forward = SELECT ahead /= Lava & grid(pos) /= Wall THEN skip END
END
"""


@pytest.fixture(scope="module")
def lava():
    return load_machine_text(LAVA, file="lava.mch")


def convert(machine, **state):
    return convert_state(state, StateTypes.of(machine), where="state() of the adapter lava")


def test_each_python_value_becomes_the_b_value_its_type_says(lava):
    grid = np.array([["Floor", "Wall"], ["Lava", "Floor"], ["Goal", "Floor"]])
    state = convert(lava, ahead="Lava", facing=np.str_("North"), grid=grid, seen={"Wall", "Lava"},
                    path=[3, np.int64(4)], pos=[1, 0], speed=1, count=np.int32(3),
                    on=np.bool_(True), label="hi", record={"a": 1, "b": False},
                    world=np.array([0.5, 1.0, 1.5, 2.0], dtype=np.float32))
    assert state["ahead"] == Elem("Lava") and type(state["ahead"]) is Elem
    assert type(state["facing"]) is Elem
    assert isinstance(state["grid"], FuncValue)
    assert state["grid"].map[(1, 0)] == Elem("Lava") and state["grid"].map[(0, 1)] == "Wall"
    assert all(type(v) is Elem for v in state["grid"].map.values())
    assert state["seen"] == frozenset({Elem("Wall"), Elem("Lava")})
    assert state["path"] == FuncValue({1: 3, 2: 4})
    assert state["pos"] == (1, 0) and type(state["pos"]) is tuple
    assert state["speed"] == 1.0 and type(state["speed"]) is float
    assert state["count"] == 3 and type(state["count"]) is int
    assert state["on"] is True
    assert state["record"] == Record([("a", 1), ("b", False)])
    assert state["world"].map == {0: 0.5, 1: 1.0, 2: 1.5, 3: 2.0}
    assert lava.enabled(state) == set()  # ahead is Lava
    lava.check_state(state, python=True)


def test_a_dict_is_a_function_and_a_str_an_element_in_every_path(lava):
    state = convert(lava, grid={(x, y): "Floor" for x in range(3) for y in range(2)},
                    ahead="Floor", pos=(0, 0))
    assert lava.enabled(state) == {"Forward"}
    # the machine's own boundary converts the same way (ShieldWrapper, train, record)
    assert lava.native({"ahead": "Goal"}) == {"ahead": Elem("Goal")}


def test_values_already_b_values_pass_unchanged(lava):
    state = {"ahead": Elem("Floor"), "speed": 2.5, "seen": frozenset({Elem("Wall")})}
    assert convert(lava, **state) == state
    assert convert_state(state, StateTypes.of(lava)) is state


@pytest.mark.parametrize("name,value,message,hint", [
    ("ahead", "Mud", "ahead is of type CELL in Lava, but it is 'Mud' (a Python str)",
     "give the name of one of its elements as a str: Floor, Wall, Lava, Goal"),
    ("count", np.float32(3.0), "count is of type INTEGER in Lava, but it is 3.0 (a Python float)",
     "give an int: int(x)"),
    ("speed", {"a": 1}, "speed is of type REAL in Lava, but it is {'a': 1} (a Python dict)",
     "give a float: float(x)"),
    ("seen", {"Floor": 1}, "seen is of type POW(CELL)", "a dict is a function; give a set"),
    ("grid", {(0, 0): "Mud"}, "grid[(0, 0)] should be of type CELL (grid : POW(INTEGER*INTEGER*CELL)"
                              " in Lava), but it is 'Mud'", "one of its elements"),
    ("grid", np.zeros((2, 3)), "grid is of type POW(INTEGER*INTEGER*CELL) in Lava, but it is a "
                               "numpy array of shape (2, 3)", "an index set of shape 3×2"),
    ("grid", np.zeros((3, 2), dtype=int), "grid[0, 0] should be of type CELL", "one of its elements"),
    ("on", 1, "on is of type BOOL in Lava, but it is 1 (a Python int)", "bool(x)"),
    ("pos", (1, 2, 3), "pos is of type INTEGER*INTEGER", "a pair is a tuple of two"),
    ("record", {"a": 1}, "record is of type struct(a:INTEGER,b:BOOL)", "a dict with the fields a, b"),
    ("speed", float("nan"), "speed is nan, not a B real", "B reals are finite numbers"),
    ("speed", 2 ** 60 + 1, "speed is of type REAL", "not a float exactly"),
], ids=["unknown-element", "float32-for-integer", "dict-for-real", "dict-for-set", "bad-cell",
        "array-shape", "codes-for-elements", "int-for-bool", "triple", "record", "nan", "big-int"])
def test_a_value_that_does_not_fit_is_refused_saying_what_to_give(lava, name, value, message, hint):
    with pytest.raises(InputError) as info:
        convert(lava, **{name: value})
    text = info.value.render()
    assert text.startswith("state() of the adapter lava: ")
    assert message in text and hint in text


def test_without_a_machine_only_the_unambiguous_converts():
    assert convert_state({"f": {1: np.float32(0.5)}}) == {"f": FuncValue({1: 0.5})}
    assert convert_state({"s": {1, 2}}) == {"s": frozenset({1, 2})}
    with pytest.raises(InputError, match="s is a list, and without the machine's type it is "
                                         "ambiguous"):
        convert_state({"s": [1, 2]})


def test_an_array_holding_a_value_twice_is_no_set():
    """A new user's elevator gave its MultiBinary call buttons [0, 1, 1, 0, 0] for
    `calls : POW(0..4)`: it was read as {0, 1}, where the calls were {1, 2}."""
    import numpy as np

    from tracecheck.b.machine import load_machine_text
    from tracecheck.errors import InputError

    m = load_machine_text("MACHINE Lift VARIABLES calls INVARIANT calls : POW(0..4) "
                          "INITIALISATION calls := {} END")
    with pytest.raises(InputError) as e:
        m.native({"calls": np.array([0, 1, 1, 0, 0])})
    assert "set(np.flatnonzero(mask).tolist())" in e.value.hint
    assert m.native({"calls": np.array([1, 2])})["calls"] == frozenset({1, 2})


def test_a_set_given_for_a_sequence_says_give_a_list():
    """A new user's queue as a Python set for `queue : seq(0..4)`: the message spoke of
    pairs ("should be of type INTEGER*INTEGER … but it is 1", "a pair is a tuple of two")."""
    from tracecheck.b.machine import load_machine_text
    from tracecheck.errors import InputError

    m = load_machine_text("MACHINE Lift VARIABLES queue INVARIANT queue : seq(0..4) "
                          "INITIALISATION queue := [] END")
    with pytest.raises(InputError) as e:
        m.native({"queue": {4, 2}})
    assert e.value.hint.startswith("a sequence is a list")
    assert m.native({"queue": [4, 2]})["queue"] == m.native({"queue": (4, 2)})["queue"]
