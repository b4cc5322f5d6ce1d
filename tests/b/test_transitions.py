"""Successor states as ProB finds them for SimB's external simulation: the predicate's
values, the substitution's for the rest, a variable fixed by neither an error."""

from __future__ import annotations

from pathlib import Path

import pytest

from tracecheck.b import load_machine, load_machine_text
from tracecheck.b.transitions import UndeterminedError, equations, fixed_values, successor

MODELS = Path(__file__).resolve().parents[3] / "shared" / "data" / "paper-models"
DRONES = MODELS / "AutonomousDroneSwarm" / "AutonomousDroneSwarm_small_abstract.mch"

COUNTER = load_machine_text('''MACHINE Counter
CONSTANTS top
PROPERTIES top = 4
VARIABLES n, parity, mode, log
INVARIANT n : 0..top & parity : BOOL & mode : {0, 1} & log : seq(INTEGER)
INITIALISATION n :: 0..2 ; parity := bool(n mod 2 = 0) ; mode := 0 ; log := [n]
OPERATIONS
  Inc = PRE n < top THEN n := n + 1 ; parity := bool(n mod 2 = 0) ; log := log ^ [n] END;
  Flip = SELECT mode = 0 THEN mode := 1 WHEN mode = 1 THEN mode := 0 END;
  Either = CHOICE mode := 0 OR mode := 1 END;
  Pick = ANY k WHERE k : 0..top & k > n THEN n := k END;
  Reset = n, parity := 0, TRUE
END''')


def after(op, before, text):
    return successor(COUNTER, op, before, COUNTER.parse(text or "TRUE = TRUE"))


START = {"n": 1, "parity": False, "mode": 0, "log": ((1, 1),)}


def test_fixed_values_are_the_closed_equations_of_the_predicate():
    pred = COUNTER.parse("n = 3 & 2 = mode & parity = bool(n > 1) & log = [top]")
    assert fixed_values(COUNTER, pred) == {"n": 3, "mode": 2, "log": frozenset({(1, 4)})}


def test_the_initialisation_computes_what_the_predicate_leaves_out():
    first = after(None, {}, "n = 2")
    assert dict(first.state) == {"n": 2, "parity": True, "mode": 0,
                                 "log": frozenset({(1, 2)})}
    assert first.possible
    assert not after(None, {}, "n = 3").possible  # n :: 0..2


def test_a_deterministic_operation_fills_in_the_rest():
    start = dict(after(None, {}, "n = 1").state)
    nxt = after("Inc", start, "n = 2")
    assert (nxt.state["n"], nxt.state["parity"], nxt.state["log"], nxt.possible) == (
        2, True, frozenset({(1, 1), (2, 2)}), True)
    # the predicate contradicts the operation: kept as the script said, flagged impossible
    wrong = after("Inc", start, "n = 3")
    assert wrong.state["n"] == 3 and not wrong.possible
    # a conjunct beyond the equations must hold as well
    assert not after("Inc", start, "n = 2 & parity = FALSE").possible
    assert after("Inc", start, "n > 1").state["n"] == 2


def test_branches_that_decide_alike_are_one_outcome():
    start = dict(after(None, {}, "n = 1").state)
    assert after("Flip", start, "").state["mode"] == 1
    assert after("Flip", start, "mode = 1").possible
    assert not after("Flip", start, "mode = 0").possible


def test_a_choice_the_predicate_leaves_open_is_an_error():
    start = dict(after(None, {}, "n = 1").state)
    with pytest.raises(UndeterminedError, match="mode: several values fit the predicate and "
                                                "Either"):
        after("Either", start, "")
    assert after("Either", start, "mode = 1").state["mode"] == 1


def test_any_enumerates_and_the_predicate_picks():
    start = dict(after(None, {}, "n = 2").state)
    with pytest.raises(UndeterminedError, match="n: several values fit"):
        after("Pick", start, "")
    assert after("Pick", start, "n = 4").possible
    assert not after("Pick", start, "n = 1").possible


def test_a_variable_fixed_by_neither_is_an_error():
    with pytest.raises(UndeterminedError, match=r"n fixed neither by the predicate nor by the "
                                                r"operation \(its `n :: …` chooses it\)"):
        after(None, {}, "mode = 0")


def test_parallel_assignment_and_frame():
    start = dict(after(None, {}, "n = 1").state)
    reset = after("Reset", start, "")
    assert dict(reset.state) == {**start, "n": 0, "parity": True} and reset.possible


@pytest.mark.skipif(not DRONES.exists(), reason="the authors' machines are not in ../shared")
def test_the_drone_swarm_computes_visited_and_whose_turn():
    m = load_machine(DRONES)

    def pred(p1, p2):
        return m.check_formula(f"drone_positions = {{1 |-> {p1}, 2 |-> {p2}}}", file="test")

    s0 = m.successor(None, {}, pred("(0 |-> 1)", "(3 |-> 2)"))
    assert s0.possible and s0.state["current_drone"] == 1
    assert s0.state["visited"] == frozenset({(0, 1), (3, 2)})
    s1 = m.successor("Move_Right", s0.state, pred("(1 |-> 1)", "(3 |-> 2)"))
    assert s1.possible and s1.state["current_drone"] == 2
    assert s1.state["visited"] == frozenset({(0, 1), (3, 2), (1, 1)})
    assert m.invariant(s1.state)
    assert "Move_Right" not in m.enabled(s1.state)  # drone 2 is at the edge
    # the script moves drone 2 right anyway and the grid keeps it: no transition does that
    s2 = m.successor("Move_Right", s1.state, pred("(1 |-> 1)", "(3 |-> 2)"))
    assert not s2.possible and s2.state["current_drone"] == 1
    assert s2.state["visited"] == s1.state["visited"] and m.invariant(s2.state)
    assert m.check_after("Move_Right", s0.state, s1.state)


LITERALS = load_machine_text('''MACHINE Literals
SETS GROUND = {ICE, HOLE}
CONSTANTS k
PROPERTIES k = 2
VARIABLES n, r, b, field, pos, s, name
INVARIANT n : INTEGER & r : REAL & b : BOOL & field : (0..1) * (0..1) --> GROUND &
  pos : 1..2 --> INTEGER * INTEGER & s : seq(INTEGER) & name : STRING
INITIALISATION n, r, b, field, pos, s, name :: INTEGER * REAL * BOOL *
  ((0..1) * (0..1) --> GROUND) * (1..2 --> INTEGER * INTEGER) * seq(INTEGER) * STRING
OPERATIONS Skip = skip END''')


@pytest.mark.parametrize("text", [
    "n = -3 & r = 2.5 & b = TRUE",
    "field = {(0 |-> 0) |-> ICE, (0 |-> 1) |-> HOLE, (1 |-> 0) |-> ICE, (1 |-> 1) |-> ICE}",
    "pos = {1 |-> (0 |-> 1), 2 |-> (3 |-> 2)} & s = [3, 1, 2]",
    'name = "a & b" & n = 1',
    "s = [] & b = FALSE",
])
def test_the_fast_reading_of_equations_agrees_with_the_grammar(text):
    fast = equations(LITERALS, text)
    assert fast is not None
    assert fast == fixed_values(LITERALS, LITERALS.check_formula(text, file="test"))


@pytest.mark.parametrize("text", [
    "n = k", "n = 1 + 1", "n = 1 or b = TRUE", "n >= 1", "n = 1 & n = 2", "b = bool(n > 1)",
    "field = {(0 |-> 0) |-> WATER}", "n = (1", 'name = "open',
])
def test_anything_else_goes_to_the_grammar(text):
    assert equations(LITERALS, text) is None


def test_a_literal_of_the_wrong_type_is_refused_and_memo_reads_a_value_once():
    from tracecheck.errors import InputError

    with pytest.raises(InputError, match="r must be of type REAL"):
        equations(LITERALS, "r = 1")
    memo: dict = {}
    first = equations(LITERALS, "n = 1 & s = [1, 2]", memo)
    assert set(memo) == {"n", "s"}
    again = equations(LITERALS, "n = 2 & s = [1, 2]", memo)
    assert again["s"] is first["s"] and again["n"] == 2


def test_an_initialisation_that_becomes_such_that():
    # the authors' highway machines: `PresentVehicles : (PresentVehicles : POW(Vehicles) & …)`
    m = load_machine_text('''MACHINE Present
SETS V = {Ego, Other}
VARIABLES present
INVARIANT present <: V
INITIALISATION present : (present : POW(V) & Ego : present)
OPERATIONS Leave = present := present - {Other} END''')
    assert m.successor(None, {}, m.parse("present = {Ego, Other}")).possible
    assert not m.successor(None, {}, m.parse("present = {Other}")).possible


def test_a_blocked_select_has_its_effect_as_a_blocked_pre_does():
    # an action the guard forbids is recorded and flagged, whichever way the guard is written
    for guard in ("SELECT floor > 0 THEN", "PRE floor > 0 THEN"):
        m = load_machine_text(f'''MACHINE Lift
VARIABLES floor, moves
INVARIANT floor : INTEGER & moves : NATURAL
INITIALISATION floor, moves := 0, 0
OPERATIONS Down = {guard} floor := floor - 1 || moves := moves + 1 END END''')
        after = m.successor("Down", {"floor": 0, "moves": 0}, m.parse("floor = -1"))
        assert dict(after.state) == {"floor": -1, "moves": 1}, guard
        assert "Down" not in m.enabled({"floor": 0, "moves": 0})
