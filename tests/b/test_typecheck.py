"""Type inference: types shown by check-model, and each kind of type error."""

from __future__ import annotations

import pytest

from tracecheck.b.machine import load_machine_text
from tracecheck.errors import BScopeError, BTypeError


def machine(body: str):
    return load_machine_text(f"MACHINE T\n{body}\nEND", file="T.mch")


def test_types_are_inferred(table1):
    assert table1.types["VehiclesX"] == "POW(Vehicles*REAL)"
    assert table1.types["PresentVehicles"] == "POW(Vehicles)"
    assert table1.types["Crash"] == "BOOL"
    assert table1.types["EgoVehicle"] == "Vehicles"


def test_nested_types():
    m = machine("VARIABLES r, s INVARIANT r : INTEGER <-> (BOOL * REAL) & s = dom(r)")
    assert m.types == {"r": "POW(INTEGER*(BOOL*REAL))", "s": "POW(INTEGER)"}


@pytest.mark.parametrize("body,exc,fragment", [
    ("VARIABLES x INVARIANT x : REAL & x > 0", BTypeError,
     "type mismatch in `x > 0`: REAL vs INTEGER"),
    ("VARIABLES x INVARIANT x : BOOL & x + 1 = 2", BTypeError, "expected a number: BOOL"),
    ("VARIABLES x INVARIANT x : INTEGER & x : {TRUE}", BTypeError,
     "type mismatch in `x : {TRUE}`: POW(INTEGER) vs POW(BOOL)"),
    ("VARIABLES x INVARIANT x : INTEGER & y = 1", BScopeError, "unknown identifier y"),
    ("VARIABLES x INVARIANT x = x", BTypeError, "cannot infer the type of the variable x"),
    ("VARIABLES f INVARIANT f : INTEGER --> REAL & f(TRUE) = 1.0", BTypeError,
     "function and argument"),
    ("VARIABLES x INVARIANT x : INTEGER INITIALISATION x := 1.5", BTypeError,
     "assignment: INTEGER vs REAL"),
    ("VARIABLES x INVARIANT x : INTEGER & {1, TRUE} = {}", BTypeError, "set elements differ"),
    ("VARIABLES x INVARIANT x : INTEGER & floor(x) = 1", BTypeError, "INTEGER vs REAL"),
])
def test_type_errors(body, exc, fragment):
    with pytest.raises(exc) as info:
        machine(body)
    assert fragment in info.value.message
    assert info.value.file == "T.mch"


@pytest.mark.parametrize("body,where", [
    ("VARIABLES x INVARIANT x : REAL & x > 0", (2, 34)),  # an integer where a real is
    ("VARIABLES x INVARIANT x : INTEGER & x > 1.0", (2, 37)),  # and the other way round
])
def test_integer_real_hint(body, where):
    """The hint fits either mistake: it does not tell a user who wrote 1.0 to write 1.0."""
    with pytest.raises(BTypeError) as info:
        machine(body)
    assert info.value.hint == ("INTEGER and REAL do not mix in B: write 1 for an integer and "
                               "1.0 for a real, or convert with real(n) or floor(x)")
    assert (info.value.line, info.value.column) == where


def test_real_power_with_integer_exponent_is_fine():
    m = machine("VARIABLES x INVARIANT x : REAL & x ** 2 >= 0.0")
    assert m.types == {"x": "REAL"}


def test_a_misspelt_name_gets_a_suggestion():
    with pytest.raises(BScopeError) as e:
        machine("VARIABLES Gap, Speed INVARIANT Gap : REAL & Speed : REAL & Gapp > 0.0")
    assert e.value.hint == ("did you mean Gap? (else declare it as a constant or variable, or "
                            "bind it)")
    with pytest.raises(BScopeError) as e:  # nothing close: the hint alone
        machine("VARIABLES Gap INVARIANT Gap : REAL & Width > 0.0")
    assert e.value.hint == "declare it as a constant or variable, or bind it"
    m = machine("VARIABLES Gap INVARIANT Gap : REAL INITIALISATION Gap := 1.0 "
                "OPERATIONS Move_Left = skip")
    from tracecheck.errors import InputError

    with pytest.raises(InputError, match="has no operation 'Move_Lef'; it has Move_Left") as e:
        m.operation("Move_Lef")
    assert e.value.hint == "did you mean Move_Left?"
    with pytest.raises(InputError, match="gives a value for gap, which the machine T does "
                                         "not declare") as e:
        m.check_state({"gap": 1.0}, python=True)
    assert e.value.hint.startswith("did you mean Gap? name the variables as the machine does")


def test_a_state_value_of_another_type_gets_the_hint_for_its_kind():
    from tracecheck.b.state import state_from_json
    from tracecheck.errors import InputError

    m = machine("SETS MODES = {NORMAL, LOW} VARIABLES Level, Mode INVARIANT Level : REAL & "
                "Mode : MODES INITIALISATION Level, Mode := 1.0, NORMAL")
    with pytest.raises(InputError) as e:  # a new user's "\"LOW\"": a STRING
        m.check_state(state_from_json({"Level": 1.0, "Mode": "\"LOW\""}))
    assert e.value.hint == 'an element is written bare, as B writes it: "Mode": "NORMAL"'
    with pytest.raises(InputError) as e:
        m.check_state(state_from_json({"Level": 1, "Mode": "LOW"}))
    assert e.value.hint == "reals are written with a decimal point: 1.0, not 1"
    n = machine("VARIABLES k, b INVARIANT k : INTEGER & b : BOOL INITIALISATION k, b := 1, TRUE")
    with pytest.raises(InputError) as e:
        n.check_state(state_from_json({"k": 1.5, "b": True}))
    assert e.value.hint == "integers are written without a decimal point: 1, not 1.0"
    with pytest.raises(InputError) as e:  # no element to show: how B writes values
        n.check_state(state_from_json({"k": 1, "b": 1}))
    assert e.value.hint.startswith("a value is written as B writes it: TRUE or FALSE")
