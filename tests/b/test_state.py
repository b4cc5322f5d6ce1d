"""numpy values at the machine's boundary (issue 23, bug 10): converted exactly, arrays only
where the B type makes them unambiguous, everything else refused naming the variable."""

from __future__ import annotations

import numpy as np
import pytest

from tests.live.cruise import SHIELD_V1
from tracecheck.b.machine import load_machine_text
from tracecheck.b.state import native_state
from tracecheck.b.values import Elem, FuncValue
from tracecheck.errors import InputError

SETS = """
MACHINE Sets
SETS V = {v1, v2}
VARIABLES speeds, flags, pairs, seq, speed
INVARIANT speeds <: REAL & flags <: BOOL & pairs : INTEGER <-> REAL & seq : seq(INTEGER)
          & speed : REAL
INITIALISATION speeds := {} || flags := {} || pairs := {} || seq := [] || speed := 0.0
OPERATIONS
  Fast = SELECT 30.0 : speeds THEN skip END;
  Paired = SELECT (1 |-> 2.5) : pairs THEN skip END
END
"""


@pytest.fixture(scope="module")
def acc():
    return load_machine_text(SHIELD_V1, file="acc_v1.mch")


@pytest.fixture(scope="module")
def sets():
    return load_machine_text(SETS, file="sets.mch")


def test_a_float32_is_the_float_it_is_not_a_rounded_decimal():
    state = native_state({"Gap": np.float32(30.1), "Lane": np.int64(2), "On": np.bool_(True),
                          "Wide": np.float64(1.5), "Name": np.str_("x")})
    assert state == {"Gap": 30.100000381469727, "Lane": 2, "On": True, "Wide": 1.5,
                     "Name": "x"}
    assert state["Gap"] == float(np.float32(30.1)) != 30.1
    assert [type(state[k]) for k in ("Gap", "Lane", "On", "Wide", "Name")] == \
        [float, int, bool, float, str]


def test_numpy_inside_sets_pairs_and_functions():
    state = native_state({"f": FuncValue({Elem("a"): np.float32(0.5)}),
                          "s": frozenset({np.int64(3)}), "p": (np.int32(1), np.float32(2.0))})
    assert type(state["f"]) is FuncValue and state["f"].map == {Elem("a"): 0.5}
    assert type(state["f"].map[Elem("a")]) is float
    assert state["s"] == frozenset({3}) and type(next(iter(state["s"]))) is int
    assert state["p"] == (1, 2.0) and type(state["p"][0]) is int


def test_a_state_without_numpy_comes_back_as_it_is():
    values = {"f": FuncValue({Elem("a"): 0.5}), "s": frozenset({1}), "x": 1.0}
    assert native_state(values) is values


def test_a_map_keyed_by_pairs_comes_back_as_the_same_object_every_step():
    """A grid world's map, ``(x |-> y) |-> KIND``: one object in every state, kept as it is
    (the file's writer formats it once per episode, not once per step: FrozenLake recorded
    5× faster), and numpy inside such a map still converted, the first time and after."""
    grid = FuncValue({(x, y): Elem("ICE") for x in range(8) for y in range(8)})
    for _ in range(3):
        assert native_state({"field": grid, "x": 1})["field"] is grid
    with_numpy = FuncValue({(np.int64(0), 0): Elem("HOLE"), (1, 0): np.float32(0.5)})
    for _ in range(2):
        converted = native_state({"field": with_numpy})["field"]
        assert converted == FuncValue({(0, 0): Elem("HOLE"), (1, 0): 0.5})
        assert {type(k[0]) for k in converted.map} == {int}
        assert type(converted.map[(1, 0)]) is float
    shared = frozenset({(np.int64(2), 3)})
    for _ in range(2):
        assert type(next(iter(native_state({"s": shared})["s"]))[0]) is int


def test_machine_questions_take_float32_observations(acc):
    """Bug 10: ``Machine.enabled({"Gap": np.float32(30.0), …})`` was a type error."""
    obs = np.array([30.0, 20.0, 18.0], dtype=np.float32)
    state = {"Gap": obs[0], "EgoSpeed": obs[1]}
    assert acc.enabled(state) == {"KEEP", "ACCEL", "BRAKE"}
    assert acc.enabled({"Gap": np.float32(15.0), "EgoSpeed": np.float32(0.0)}) == {"KEEP"}
    assert acc.invariant(state) and not acc.invariant({**state, "EgoSpeed": np.float32(-1)})
    assert acc.check_after("KEEP", state, {"Gap": np.float32(30.0), "EgoSpeed": 20.0})
    assert not acc.check_after("KEEP", state, {"Gap": np.float32(30.1), "EgoSpeed": 20.0})
    # exactly: 10.000001 as a float32 is above SafeGap = 10.0, 10.0 is not
    assert "KEEP" in acc.enabled({"Gap": np.nextafter(np.float32(10), np.float32(11)),
                                  "EgoSpeed": obs[1]})
    assert "KEEP" not in acc.enabled({"Gap": np.float32(10.0), "EgoSpeed": obs[1]})
    acc.check_state({"Gap": obs[0], "EgoSpeed": obs[1]})  # typed as REAL


def test_arrays_become_sets_where_the_type_says_so(sets):
    base = {"flags": frozenset(), "pairs": frozenset(), "seq": frozenset(), "speed": 0.0}
    state = {**base, "speeds": np.array([30.0, 12.5], dtype=np.float32)}
    assert sets.enabled(state) == {"Fast"}
    state = {**base, "speeds": frozenset(), "pairs": np.array([[1, 2.5], [2, 3.0]])}
    assert sets.enabled(state) == {"Paired"}
    assert sets.native({"flags": np.array([True, False])}) == {"flags": frozenset({True, False})}
    assert sets.native({"speed": np.array(2.5, dtype=np.float32)}) == {"speed": 2.5}  # 0-d


@pytest.mark.parametrize("name,value,fragment", [
    ("speed", np.array([2.5]), "speed is of type REAL in Sets, but it is a numpy array of "
                               "shape (1,) and dtype float64\n  hint: give one value: obs[0]"),
    ("pairs", np.array([1.0, 2.0]), "a numpy array of shape (2,) is ambiguous here; say which "
                                    "index each entry has: declare pairs : 0..1 --> …"),
    ("speeds", np.array([[1.0, 2.0]]), "speeds is of type POW(REAL) in Sets, but it is a numpy "
                                       "array of shape (1, 2)"),
    ("unknown", np.array([1.0]), "not known (not a variable of the machine)"),
    ("speed", np.float32("nan"), "speed is nan, not a B real"),
    ("speed", np.float32("inf"), "speed is inf, not a B real"),
    ("speed", np.datetime64("2024-01-01"), "a numpy datetime64 is no B value"),
], ids=["array-for-a-real", "1d-for-a-relation", "2d-for-a-set", "untyped", "nan",
        "inf", "datetime"])
def test_ambiguous_or_meaningless_numpy_values_are_refused(sets, name, value, fragment):
    with pytest.raises(InputError) as info:
        sets.native({name: value}, where="state.json")
    assert f"state.json: {name} " in info.value.render() and fragment in info.value.render()
    with pytest.raises(InputError, match=f"the state: {name} "):
        sets.enabled({name: value})


def test_a_python_nan_is_refused_as_a_numpy_one():
    """``Machine.invariant({"X": float("nan")})`` was True: a Python NaN slipped past the
    check numpy's get."""
    import math

    from tracecheck.b.machine import load_machine_text
    from tracecheck.b.values import FuncValue
    from tracecheck.errors import InputError

    m = load_machine_text("MACHINE N VARIABLES X INVARIANT X : REAL & X <= 10.0 "
                          "INITIALISATION X := 0.0 END")
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(InputError, match=f"X is {bad}, not a B real"):
            m.invariant({"X": bad})
    assert m.invariant({"X": 3.0}) is True
    for nested in (FuncValue({1: math.nan}), frozenset({(1, math.nan)}), (1.0, math.nan)):
        with pytest.raises(InputError, match="not a B real"):
            native_state({"F": nested})
