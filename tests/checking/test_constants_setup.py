"""Constants the PROPERTIES fix without an equality, set up by the solver as ProB's
SETUP_CONSTANTS does (tracecheck.checking.constants_setup); `check-model` shows them and
decides the ASSERTIONS over the constants."""

from __future__ import annotations

import json

import pytest

from tracecheck.b import load_machine_text
from tracecheck.checking.shield import ShieldMachine
from tracecheck.errors import EvaluationError, ModelError

from tests.helpers import run

pytest.importorskip("z3")

MACHINE = """MACHINE P
CONSTANTS n, m, q
PROPERTIES n : 1..10 & n * n = 49 & m : 1..3 & q : INTEGER & q > 100 & q mod 7 = 3 &
           q * q = 29241
ASSERTIONS n = 7; n > 8; m < 5; x >= 0
VARIABLES x
INVARIANT x : 0..n
INITIALISATION x := 0
OPERATIONS Up = SELECT x < n THEN x := x + 1 END
END"""


def shield(text: str) -> ShieldMachine:
    return load_machine_text(text, file="P.mch", kind=ShieldMachine)


def test_one_solution_gives_the_constants_their_values():
    m = shield(MACHINE)
    assert m.constants == {"n": 7, "q": 171}  # z3 for q: no small space to walk
    assert m.enabled({"x": 6}) == {"Up"} and m.enabled({"x": 7}) == set()


def test_several_solutions_leave_a_constant_without_value_and_list_them():
    m = shield(MACHINE)
    assert list(m.unset_constants) == ["m"]
    why = m.unset_constants["m"]
    assert "allow 3 solutions" in why and "m = 1" in why and "m = 3" in why
    with pytest.raises(EvaluationError, match="the constant m has no value: the PROPERTIES "
                                              "allow 3 solutions"):
        m.evaluate("m + 1", {"x": 0})


def test_properties_without_a_solution_are_an_error_at_load():
    with pytest.raises(ModelError, match="no values of the constants n satisfy") as err:
        shield("MACHINE P CONSTANTS n PROPERTIES n : 1..10 & n * n = 50 END")
    assert err.value.line == 1


def test_what_the_solver_cannot_decide_stays_without_value_with_its_reason():
    m = shield("MACHINE P CONSTANTS s PROPERTIES s <: INTEGER & card(s) = 2 END")
    assert "the solver cannot set it up" in m.unset_constants["s"]
    assert "card(" in m.unset_constants["s"]
    m = shield("MACHINE P CONSTANTS s PROPERTIES s <: INTEGER & 5 : s END")  # z3's sets
    # how many solutions z3 lists before it cannot tell depends on the machine's speed
    # (a fast machine lists six and stops; a slow one hits the solver's limit first)
    reason = m.unset_constants["s"]
    assert "solution" in reason and "(s = {" in reason and "tracecheck" not in reason[:30]
    if reason.startswith("the PROPERTIES allow more than "):
        assert reason.endswith("tracecheck does not pick one")
    else:
        assert reason.startswith("the PROPERTIES allow at least ")
        assert "the solver cannot tell whether others (" in reason


@pytest.mark.parametrize("properties, fixed, unset", [
    # an enumerated set's elements are not alike: each one is a solution
    ("c : NODE", {}, {"c": "allow 3 solutions (c = n1; c = n2; c = n3)"}),
    ("c : NODE & c = n2", {"c": "n2"}, {}),
    ("c : NODE & c /= n1", {}, {"c": "allow 2 solutions (c = n2; c = n3)"}),
    # a deferred set's are: one constant names one of them (ProB's names) ...
    ("card(PID) = 3 & a : PID", {"a": "a"}, {}),
    # ... several only where PROPERTIES says they differ; else a = b is a solution
    ("card(PID) = 3 & a : PID & b : PID & a /= b", {"a": "a", "b": "b"}, {}),
    ("card(PID) = 3 & a : PID & b : PID", {"a": "a"},
     {"b": "allow 3 solutions (b = a; b = PID2; b = PID3)"}),
    ("card(PID) = 3 & a : PID & b : PID & a = b", {"a": "a", "b": "a"}, {}),
    ("card(PID) = 1 & a : PID & b : PID", {"a": "a", "b": "a"}, {}),
    # an element PROPERTIES names breaks the likeness: the solver sets the constant
    ("card(PID) = 3 & a : PID & a /= PID1", {},
     {"a": "allow 2 solutions (a = PID2; a = PID3)"}),
])
def test_a_constant_in_a_set_takes_an_element_only_where_every_solution_agrees(
        properties, fixed, unset):
    """``c : S`` fixes nothing by itself: a constant takes an element's place only for a
    deferred set, whose elements are alike (ProB's naming), and never where another value
    is a solution (a new user's ``c : NODE`` was n1, ``a /= b`` TRUE, ``c = n2`` false)."""
    names = ", ".join(n for n in "abc" if f"{n} :" in properties)
    m = shield(f"MACHINE P SETS NODE = {{n1, n2, n3}}; PID CONSTANTS {names} "
               f"PROPERTIES {properties} END")
    assert {k: str(v) for k, v in m.constants.items() if k in fixed} == fixed
    for name, why in unset.items():
        assert why in m.unset_constants[name], m.unset_constants
    assert not set(fixed) & set(m.unset_constants)


def test_constants_no_conjunct_links_are_solved_apart():
    """n * n = 49 fixes n, whatever the others allow: solved together, the 8 solutions of
    (n, k, w) hid it behind the first 5 ("at least 5 solutions", n without value — a new
    user's ordinary-B trial); apart, n = 7 and k, w each list their own two."""
    m = shield("MACHINE P CONSTANTS n, k, w PROPERTIES n : 1..10 & n * n = 49 & "
               "k : NATURAL & k mod 5 = 3 & k < 10 & w : INTEGER & w > 0 & w < 3 END")
    assert m.constants == {"n": 7}
    assert "allow 2 solutions (k = 3; k = 8)" in m.unset_constants["k"]
    assert "allow 2 solutions (w = 1; w = 2)" in m.unset_constants["w"]
    linked = shield("MACHINE P CONSTANTS n, k PROPERTIES n : 1..3 & k : 1..3 & n + k = 4 END")
    assert linked.constants == {} and "allow 3 solutions" in linked.unset_constants["n"]
    free = shield("MACHINE P CONSTANTS z, n PROPERTIES n : 1..10 & n * n = 49 VARIABLES x "
                  "INVARIANT x : INTEGER & x <= z INITIALISATION x := 0 END")
    assert free.constants == {"n": 7}
    assert free.unset_constants["z"].startswith("no conjunct of the PROPERTIES names it")


def test_pairwise_different_constants_more_than_the_elements_are_an_error():
    with pytest.raises(ModelError, match="PID has only 2 element.s., too few for the "
                                         "constant c, which PROPERTIES says differs from a, b"):
        shield("MACHINE P SETS PID CONSTANTS a, b, c PROPERTIES card(PID) = 2 & a : PID & "
               "b : PID & c : PID & a /= b & a /= c & b /= c END")


def test_a_plain_machine_does_not_ask_the_solver_and_says_so():
    m = load_machine_text(MACHINE, file="P.mch")
    assert m.constants == {} and set(m.unset_constants) == {"n", "m", "q"}
    with pytest.raises(EvaluationError, match="not set up with the solver"):
        m.evaluate("n", {"x": 0})


def test_check_model_shows_the_constants_and_decides_the_assertions(tmp_path, capsys):
    path = tmp_path / "P.mch"
    path.write_text(MACHINE)
    code, out, _ = run(capsys, "check-model", path)
    assert code == 1  # n > 8 is false
    assert "constant n = 7" in out and "constant q = 171" in out
    assert "constant m: no value — the PROPERTIES allow 3 solutions" in out
    assert "assertion n = 7: TRUE" in out and "assertion n > 8: FALSE" in out
    assert "assertion x >= 0: reads x: holds or not per state" in out
    data = json.loads(run(capsys, "check-model", path, "--format", "json")[1])
    assert data["constants"] == {"n": "7", "q": "171"}
    assert [a["value"] for a in data["assertions"]] == ["TRUE", "FALSE", None, None]
    path.write_text(MACHINE.replace("n = 7; n > 8; ", ""))
    assert run(capsys, "check-model", path)[0] == 3  # m < 5: m has no value
    path.write_text(MACHINE.replace("n = 7; n > 8; m < 5; ", ""))
    code, out, _ = run(capsys, "check-model", path)
    assert code == 0 and "ok: 1 operation(s)" in out
