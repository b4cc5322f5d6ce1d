"""B literals in ProB's notation: reading, writing, and JSON state files."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tracecheck.b.state import read_state_file
from tracecheck.b.notation import from_json, parse_literal
from tracecheck.b.values import Elem, FuncValue, format_value
from tracecheck.errors import BSyntaxError, InputError

E = Elem


@pytest.mark.parametrize("text,value", [
    ("42", 42), ("-3", -3), ("1.5", 1.5), ("-0.25", -0.25), ("1.0E-5", 1e-5),
    ("TRUE", True), ("FALSE", False), ("EgoVehicle", E("EgoVehicle")), ('"a\\"b"', 'a"b'),
    ("{}", frozenset()), ("∅", frozenset()), ("{1,2}", frozenset({1, 2})),
    ("(a↦1)", (E("a"), 1)), ("(a|->1)", (E("a"), 1)), ("(a,1)", (E("a"), 1)),
    ("{(EgoVehicle↦150.36),(Vehicles2↦21.9)}",
     FuncValue({E("EgoVehicle"): 150.36, E("Vehicles2"): 21.9})),
    ("{(a|->1),(a|->2)}", frozenset({(E("a"), 1), (E("a"), 2)})),
    ("{(a↦{1}),(b↦(1↦2))}", FuncValue({E("a"): frozenset({1}), E("b"): (1, 2)})),
    (" { EgoVehicle , Vehicles2 } ", frozenset({E("EgoVehicle"), E("Vehicles2")})),
])
def test_parse_literal(text, value):
    parsed = parse_literal(text)
    assert parsed == value


def test_function_literal_is_fast_function():
    value = parse_literal("{(EgoVehicle↦150.36),(Vehicles2↦21.9)}")
    assert isinstance(value, FuncValue) and value.map[E("Vehicles2")] == 21.9
    relation = parse_literal("{(a↦1),(a↦2)}")
    assert not isinstance(relation, FuncValue)


@pytest.mark.parametrize("value,text", [
    (True, "TRUE"), (3, "3"), (2.5, "2.5"), (1e-5, "1.0E-5"), (E("x"), "x"),
    (frozenset(), "∅"), (frozenset({2, 1}), "{1,2}"), ((E("a"), 1.0), "(a↦1.0)"),
    (FuncValue({E("Vehicles10"): 1.0, E("Vehicles2"): 2.0, E("EgoVehicle"): 0.5}),
     "{(EgoVehicle↦0.5),(Vehicles2↦2.0),(Vehicles10↦1.0)}"),
    ("s", '"s"'),
])
def test_format_value(value, text):
    assert format_value(value) == text
    assert parse_literal(text) == value


def test_format_ascii():
    assert format_value(frozenset({(1, 2)}), ascii=True) == "{(1|->2)}"


@pytest.mark.parametrize("text,col,fragment", [
    ("{1,2", 5, "expected '}'"),
    ("(a↦", 4, "expected a value but the text ended"),
    ("{1} 2", 5, "unexpected '2' after the value"),
    ("@", 1, "unexpected '@'"),
])
def test_literal_errors(text, col, fragment):
    with pytest.raises(BSyntaxError) as info:
        parse_literal(text, where="variable X")
    assert info.value.column == col
    assert fragment in info.value.message and "(variable X)" in info.value.message


def test_from_json_shapes():
    assert from_json({"a": 1.0}) == FuncValue({E("a"): 1.0})
    assert from_json([1, 2]) == frozenset({1, 2})
    assert from_json("{(a↦1)}") == FuncValue({E("a"): 1})
    assert from_json(True) is True


def test_state_file(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps({"Crash": "FALSE", "X": {"EgoVehicle": 1.5}, "n": 3}))
    assert read_state_file(path) == {"Crash": False, "X": FuncValue({E("EgoVehicle"): 1.5}),
                                     "n": 3}


def test_state_file_errors(tmp_path):
    with pytest.raises(InputError, match="no such state file"):
        read_state_file(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"a": 1,\n "b": }')
    with pytest.raises(InputError) as info:
        read_state_file(bad)
    assert info.value.line == 2 and "not valid JSON" in info.value.message
    lit = tmp_path / "lit.json"
    lit.write_text('{"VehiclesX": "{(a↦1.0"}')
    with pytest.raises(BSyntaxError) as info:
        read_state_file(lit)
    assert "variable VehiclesX" in info.value.message and info.value.file == str(lit)
    assert info.value.line is None and "at column 8 of the literal" in info.value.message
    arr = tmp_path / "arr.json"
    arr.write_text("[1, 2]")
    with pytest.raises(InputError, match="JSON object mapping variable names"):
        read_state_file(arr)


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=20))
def test_a_string_prints_as_a_literal_that_reads_back_as_itself(text):
    """Found by a new user: a newline was printed raw and could not be read back."""
    from tracecheck.b.notation import parse_literal
    from tracecheck.b.values import format_value

    try:
        back = parse_literal(format_value(text))
    except Exception as exc:  # noqa: BLE001 - only our own error is allowed
        from tracecheck.errors import TracecheckError

        assert isinstance(exc, TracecheckError), exc
        return
    assert back == text
