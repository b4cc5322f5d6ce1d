"""Machines: set-up of sets and constants, guards, before-after checks, definitions."""

from __future__ import annotations

import pytest

from tests.helpers import simb_states
from tracecheck.b.machine import load_machine, load_machine_text
from tracecheck.b.values import Elem, FuncValue
from tracecheck.errors import (BScopeError, BSyntaxError, BTypeError, InputError, ModelError,
                               TracecheckError,
                               UnsupportedError)

E = Elem


# ------------------------------------------------------------------ Listing 1


def test_coin_toss_listing_1(coin_toss):
    assert coin_toss.sets["Side"] == (E("Heads"), E("Tails"), E("None"))
    assert coin_toss.enabled({"lastToss": E("None")}) == {"toss"}
    assert coin_toss.check_after("toss", {"lastToss": E("None")}, {"lastToss": E("Heads")})
    assert coin_toss.check_after("toss", {"lastToss": E("Heads")}, {"lastToss": E("Tails")})
    assert not coin_toss.check_after("toss", {"lastToss": E("Heads")}, {"lastToss": E("None")})
    assert coin_toss.invariant({"lastToss": E("Tails")})
    assert coin_toss.types == {"lastToss": "Side"}


# ------------------------------------------------------------------ Listing 2

LISTING_2 = """
MACHINE Listing2
SETS Vehicles
CONSTANTS EgoVehicle
PROPERTIES card(Vehicles) = 3 ∧ EgoVehicle ∈ Vehicles
VARIABLES Crash, PresentVehicles, VehiclesX, VehiclesY, VehiclesVx, VehiclesVy, VehiclesAx,
          VehiclesAy, Reward
INVARIANT Crash ∈ BOOL ∧ PresentVehicles ⊆ Vehicles ∧ VehiclesX ∈ Vehicles → ℝ ∧
          VehiclesY ∈ Vehicles → ℝ ∧ VehiclesVx ∈ Vehicles → ℝ ∧ VehiclesVy ∈ Vehicles → ℝ ∧
          VehiclesAx ∈ Vehicles → ℝ ∧ VehiclesAy ∈ Vehicles → ℝ ∧ Reward ∈ ℝ
INITIALISATION Crash :∈ BOOL || PresentVehicles :∈ ℙ(Vehicles) || VehiclesX :∈ Vehicles → ℝ ||
    VehiclesY :∈ Vehicles → ℝ || VehiclesVx :∈ Vehicles → ℝ || VehiclesVy :∈ Vehicles → ℝ ||
    VehiclesAx :∈ Vehicles → ℝ || VehiclesAy :∈ Vehicles → ℝ || Reward :∈ ℝ
OPERATIONS
FASTER =
PRE
  EgoVehicle ∈ dom(VehiclesVx) ∧
  ¬(∃v. (v ∈ PresentVehicles \\ {EgoVehicle} ∧
  VehiclesX(v) > 0.0 ∧ VehiclesX(v) < 45.0 ∧
  VehiclesY(v) < 3.5 ∧ VehiclesY(v) > -3.5))
THEN
  Crash :∈ BOOL ||
  PresentVehicles :| (PresentVehicles ∈ ℙ(Vehicles) ∧
  EgoVehicle : PresentVehicles) ||
  VehiclesX :∈ Vehicles → ℝ ||
  VehiclesY :∈ Vehicles → ℝ ||
  VehiclesVx :| (VehiclesVx ∈ Vehicles → ℝ ∧
  (Crash = FALSE ⇒
  VehiclesVx(EgoVehicle) ≥
  VehiclesVx'(EgoVehicle) - 0.05)) ||
  VehiclesVy :∈ Vehicles → ℝ ||
  VehiclesAx :| (VehiclesAx ∈ Vehicles → ℝ ∧
  (Crash = FALSE ⇒ VehiclesAx(EgoVehicle) ≥ -0.05)) ||
  VehiclesAy :∈ Vehicles → ℝ ||
  Reward :∈ ℝ
END
END
"""


def _state(x2=60.0, vx_ego=25.0, ax_ego=0.0, crash=False):
    ego, v2, v3 = E("EgoVehicle"), E("Vehicles2"), E("Vehicles3")
    zero = FuncValue({ego: 0.0, v2: 0.0, v3: 0.0})
    return {
        "Crash": crash, "PresentVehicles": frozenset({ego, v2, v3}),
        "VehiclesX": FuncValue({ego: 100.0, v2: x2, v3: -30.0}),
        "VehiclesY": FuncValue({ego: 4.0, v2: 0.0, v3: 4.0}),
        "VehiclesVx": FuncValue({ego: vx_ego, v2: -1.0, v3: 1.0}), "VehiclesVy": zero,
        "VehiclesAx": FuncValue({ego: ax_ego, v2: 0.0, v3: 0.0}), "VehiclesAy": zero,
        "Reward": 0.5,
    }


@pytest.fixture(scope="module")
def listing2():
    return load_machine_text(LISTING_2, file="Listing2.mch")


def test_listing_2_guard(listing2):
    assert listing2.sets["Vehicles"] == (E("EgoVehicle"), E("Vehicles2"), E("Vehicles3"))
    assert listing2.enabled(_state(x2=60.0)) == {"FASTER"}
    assert listing2.enabled(_state(x2=44.9)) == set()  # a vehicle less than 40 m ahead
    assert listing2.enabled(_state(x2=-1.0)) == {"FASTER"}  # behind does not count


def test_listing_2_before_after(listing2):
    before = _state(vx_ego=25.0)
    assert listing2.check_after("FASTER", before, _state(vx_ego=26.0, ax_ego=1.0))
    assert listing2.check_after("FASTER", before, _state(vx_ego=24.96))  # within 0.05
    assert not listing2.check_after("FASTER", before, _state(vx_ego=24.9))  # slowed down
    assert not listing2.check_after("FASTER", before, _state(vx_ego=26.0, ax_ego=-1.0))
    # In `VehiclesVx :| (P)` every other variable, Crash included, has its value from
    # before the step (B semantics of ||): a crash in the step itself excuses nothing...
    crashed = _state(vx_ego=10.0, ax_ego=-15.0, crash=True)
    assert not listing2.check_after("FASTER", before, crashed)
    # ...while a state that had already crashed is not constrained.
    assert listing2.check_after("FASTER", _state(vx_ego=25.0, crash=True), crashed)
    assert not listing2.check_after("FASTER", _state(x2=30.0), _state(vx_ego=26.0))  # guard


def test_check_after_needs_every_variable(listing2):
    after = _state()
    del after["Reward"]
    with pytest.raises(Exception, match="no value for Reward"):
        listing2.check_after("FASTER", _state(), after)


# ------------------------------------------------------------------ Table 1 on the paper's data


def test_table1_on_paper_traces(table1, paper_traces):
    """The fixture shield agrees with the paper's: no blocked step with the shield on,
    233 blocked steps of 765 without it, and never a state where all actions are blocked."""
    counts = {}
    for folder in ("base", "base_shield"):
        steps = infeasible = 0
        for path in sorted((paper_traces / "simb" / folder).glob("*.json")):
            states = simb_states(path)
            for (_, before), (op, _) in zip(states, states[1:]):
                enabled = table1.enabled(before)
                assert enabled, f"{path.name}: deadlock"
                steps += 1
                infeasible += op not in enabled
        counts[folder] = (steps, infeasible)
    assert counts["base_shield"][1] == 0
    assert counts["base"] == (765, 233)


def test_table1_guards_by_hand(table1):
    ego, others = E("EgoVehicle"), [E(f"Vehicles{i}") for i in range(2, 6)]
    vs = [ego, *others]

    def state(x, y, vx):
        return {
            "Crash": False, "PresentVehicles": frozenset(vs),
            "VehiclesX": FuncValue(dict(zip(vs, [100.0, *x]))),
            "VehiclesY": FuncValue(dict(zip(vs, [4.0, *y]))),
            "VehiclesVx": FuncValue(dict(zip(vs, [25.0, *vx]))),
            "VehiclesVy": FuncValue({v: 0.0 for v in vs}),
            "VehiclesAx": FuncValue({v: 0.0 for v in vs}),
            "VehiclesAy": FuncValue({v: 0.0 for v in vs}), "Reward": 0.0,
        }
    far = [200.0] * 4
    assert table1.enabled(state(far, [0.0] * 4, [0.0] * 4)) == {
        "IDLE", "LANE_LEFT", "LANE_RIGHT", "FASTER", "SLOWER"}
    # a slower car 8 m ahead in the own lane: only a lane change or braking is left
    close = state([8.0, 200.0, 200.0, 200.0], [0.0] * 4, [-3.0, 0.0, 0.0, 0.0])
    assert table1.enabled(close) == {"LANE_LEFT", "LANE_RIGHT"}
    # and with both neighbouring lanes occupied beside the ego vehicle, SLOWER is allowed
    boxed = state([8.0, 0.0, 0.0, 200.0], [0.0, -4.0, 4.0, 0.0], [-3.0, 0.0, 0.0, 0.0])
    assert table1.enabled(boxed) == {"SLOWER"}


def test_descriptions_are_kept(table1):
    assert table1.descriptions["Crash"] == "TRUE when a crash occurred"
    assert table1.descriptions["EgoVehicle"] == "the vehicle the agent drives"


# ------------------------------------------------------------------ constants and sets


def test_constants_from_properties():
    m = load_machine_text("""
MACHINE C
SETS Cars; Colour = {red, green}
CONSTANTS me, you, aMax, vMax, favourite
PROPERTIES card(Cars) = 3 & me : Cars & you : Cars & me /= you & aMax = 5.0 &
    vMax = aMax * 6.0 & favourite = green & {aMax, vMax} <: REAL
END""")
    assert m.sets["Cars"] == (E("me"), E("you"), E("Cars3"))
    assert m.constants == {"me": E("me"), "you": E("you"), "aMax": 5.0, "vMax": 30.0,
                           "favourite": E("green")}
    assert m.types["vMax"] == "REAL"


def test_deferred_set_default_size():
    m = load_machine_text("MACHINE D SETS S CONSTANTS c PROPERTIES c : S END")
    assert m.sets["S"] == (E("c"), E("S2"))


@pytest.mark.parametrize("scope", ["1..3", "3", "4..6", "2 + 1"])
def test_a_deferred_set_sized_by_its_scope_definition(scope):
    """ProB's DEFINITIONS scope_S == a..b (b - a + 1 elements) or == n."""
    m = load_machine_text(f"MACHINE D SETS PID DEFINITIONS scope_PID == {scope} "
                          "VARIABLES x INVARIANT x : PID INITIALISATION x :: PID END")
    assert m.sets["PID"] == (E("PID1"), E("PID2"), E("PID3"))
    assert m.evaluate("card(PID)", {"x": E("PID1")}) == 3


def test_a_deferred_set_enumerated_in_the_properties():
    m = load_machine_text("MACHINE D SETS PID CONSTANTS a, b, c, d "
                          "PROPERTIES PID = {a, b, c} & a /= b & d : PID END")
    assert m.sets["PID"] == (E("a"), E("b"), E("c"))
    # d may be a, b or c: no element of a set its constants name is d's by default
    assert m.constants == {"a": E("a"), "b": E("b"), "c": E("c")}
    assert "d" in m.unset_constants
    assert load_machine_text("MACHINE D SETS PID PROPERTIES card(PID) = 3 "
                             "DEFINITIONS scope_PID == 1..3 END").sets["PID"][2] == E("PID3")


@pytest.mark.parametrize("text,message", [
    ("DEFINITIONS scope_PID == 1..3 PROPERTIES card(PID) = 4",
     "PID has 4 element(s) by card(PID) = 4 but 3 by scope_PID in DEFINITIONS"),
    ("CONSTANTS a, b PROPERTIES PID = {a, b} & card(PID) = 3",
     "PID has 2 element(s) by PID = {a, b} but 3 by card(PID) = 3"),
    ("DEFINITIONS scope_PID == TRUE", "write scope_PID == n or scope_PID == a..b"),
    ("DEFINITIONS scope_PID == 3..1", "would have 0 elements; a deferred set is not empty"),
    ("PROPERTIES card(PID) = 100000000", "the set PID has 100,000,000 elements"),
])
def test_deferred_set_sizes_that_cannot_be(text, message):
    """Sizes that disagree have no model (ProB finds no constants): an error, not one of
    them; a huge size is refused before 10^8 elements are made."""
    with pytest.raises(TracecheckError) as info:
        load_machine_text(f"MACHINE D SETS PID {text} END", file="D.mch")
    assert message in info.value.message


def test_properties_that_do_not_hold():
    with pytest.raises(ModelError) as info:
        load_machine_text("MACHINE P CONSTANTS k PROPERTIES k = 3 & k > 5 END", file="P.mch")
    assert "`k > 5` is false" in info.value.message
    assert (info.value.file, info.value.line) == ("P.mch", 1)


def test_duplicate_names():
    with pytest.raises(BScopeError, match="x is declared twice"):
        load_machine_text("MACHINE D CONSTANTS x VARIABLES x END")


# ------------------------------------------------------------------ definitions


DEFS = """
MACHINE Defs
DEFINITIONS
    sq(a) == a * a;
    big(a) == sq(a) > 10;
    LIMIT == 3;
    reset == n := 0;
    VISB_JSON_FILE == "x.json";
    ANIMATION_IMG1 == "a.gif";
    GAME_OVER == n : {}}
VARIABLES n
INVARIANT n : INTEGER
INITIALISATION reset
OPERATIONS
    grow = PRE not(big(n)) THEN n := n + LIMIT END;
    restart = PRE big(n) THEN reset END
END
"""


def test_definitions_expand():
    m = load_machine_text(DEFS)
    assert m.enabled({"n": 3}) == {"grow"}
    assert m.enabled({"n": 4}) == {"restart"}
    assert m.check_after("grow", {"n": 1}, {"n": 4})
    assert m.check_after("restart", {"n": 5}, {"n": 0})
    assert m.evaluate("sq(LIMIT)", {"n": 0}) == 9


@pytest.mark.parametrize("body,exc,fragment", [
    ("DEFINITIONS a == b; b == a VARIABLES n INVARIANT n : INTEGER & a = 1",
     BScopeError, "the definitions are cyclic: a -> b -> a"),
    ("DEFINITIONS f(x) == x VARIABLES n INVARIANT n = f(1, 2)",
     BScopeError, "takes 1 argument(s) (x) but is given 2"),
    ("DEFINITIONS f(x) == x VARIABLES n INVARIANT n = f",
     BScopeError, "needs 1 argument(s): f(x)"),
    ("DEFINITIONS ANIMATION_X == {1 |-> } VARIABLES n INVARIANT n : INTEGER & ANIMATION_X = {}",
     BSyntaxError, "the definition ANIMATION_X is used but could not be parsed"),
    ("DEFINITIONS d == n + 1 VARIABLES n INVARIANT d", BTypeError,
     "the INVARIANT must be a predicate, but `n + 1` is an expression"),
    ("DEFINITIONS p == n > 1 VARIABLES n INVARIANT n : INTEGER & p + 1 = 2", BTypeError,
     "each operand of '+' must be an expression, but `n > 1` is a predicate"),
])
def test_definition_errors(body, exc, fragment):
    with pytest.raises(exc) as info:
        load_machine_text(f"MACHINE D {body} END", file="D.mch")
    assert fragment in info.value.message
    assert info.value.file == "D.mch" and info.value.line == 1


# ------------------------------------------------------------------ substitutions


SUBSTS = """
MACHINE Subst
VARIABLES x, y, f
INVARIANT x : INTEGER & y : INTEGER & f : 1..3 --> INTEGER
INITIALISATION x, y, f := 0, 0, {1 |-> 0, 2 |-> 0, 3 |-> 0}
OPERATIONS
    assign = x := x + 1;
    multi = x, y := y, x;
    fun = f(2) := 7;
    par = x := 1 || y := 2;
    seq = BEGIN x := 5 ; y := x + 1 END;
    becin = x :: {10, 20};
    such = x : (x > x$0 & x < x' + 3);
    pre = PRE x > 0 THEN y := 1 END;
    sel = SELECT x = 0 THEN y := 1 WHEN x = 1 THEN y := 2 ELSE y := 3 END;
    anyop = ANY k WHERE k : 1..3 & k > x THEN y := k END;
    ifop = IF x > 0 THEN y := 1 ELSIF x < 0 THEN y := -1 END;
    letop = LET k BE k = x * 2 IN y := k END;
    choice = CHOICE x := 1 OR y := 1 END;
    param(p) = PRE p : 1..3 & p > x THEN x := p END;
    nothing = skip;
    badseq = BEGIN x :: {1, 2} ; y := x END;
    suchseq = BEGIN x : (x > x$0) ; y := x END
END
"""


@pytest.fixture(scope="module")
def substs():
    return load_machine_text(SUBSTS)


F0 = FuncValue({1: 0, 2: 0, 3: 0})


def S(x=0, y=0, f=F0):
    return {"x": x, "y": y, "f": f}


@pytest.mark.parametrize("op,before,after,ok", [
    ("assign", S(1), S(2), True), ("assign", S(1), S(3), False),
    ("assign", S(1), S(2, y=9), False),  # the frame: y must not change
    ("multi", S(1, 2), S(2, 1), True), ("multi", S(1, 2), S(1, 2), False),
    ("fun", S(), S(f=FuncValue({1: 0, 2: 7, 3: 0})), True), ("fun", S(), S(), False),
    ("par", S(), S(1, 2), True), ("par", S(), S(1, 3), False),
    ("seq", S(), S(5, 6), True), ("seq", S(), S(5, 1), False),
    ("becin", S(), S(20), True), ("becin", S(), S(15), False),
    ("such", S(4), S(6), True), ("such", S(4), S(4), False), ("such", S(4), S(7), False),
    ("pre", S(1), S(1, 1), True), ("pre", S(0), S(0, 1), False),
    ("sel", S(0), S(0, 1), True), ("sel", S(1), S(1, 2), True), ("sel", S(5), S(5, 3), True),
    ("sel", S(1), S(1, 1), False),
    ("anyop", S(1), S(1, 2), True), ("anyop", S(1), S(1, 3), True),
    ("anyop", S(1), S(1, 1), False),
    ("ifop", S(1), S(1, 1), True), ("ifop", S(-1), S(-1, -1), True), ("ifop", S(0), S(0, 0), True),
    ("ifop", S(0), S(0, 1), False),
    ("letop", S(3), S(3, 6), True), ("letop", S(3), S(3, 5), False),
    ("choice", S(), S(1, 0), True), ("choice", S(), S(0, 1), True), ("choice", S(), S(1, 1), False),
    ("param", S(1), S(3), True), ("param", S(1), S(1), False),
    ("nothing", S(1, 2), S(1, 2), True), ("nothing", S(1, 2), S(1, 3), False),
])
def test_check_after(substs, op, before, after, ok):
    assert substs.check_after(op, before, after) is ok


def test_guards_of_each_form(substs):
    assert substs.is_enabled("pre", S(1)) and not substs.is_enabled("pre", S(0))
    assert substs.is_enabled("anyop", S(2)) and not substs.is_enabled("anyop", S(3))
    assert substs.is_enabled("param", S(2)) and not substs.is_enabled("param", S(3))
    assert substs.is_enabled("sel", S(7))  # ELSE: always enabled
    assert substs.enabled(S(3)) >= {"assign", "nothing", "ifop", "sel"}


def test_a_non_deterministic_first_part_of_a_sequence_has_every_outcome(substs):
    assert substs.check_after("badseq", S(), S(1, 1))
    assert substs.check_after("badseq", S(), S(2, 2))
    assert not substs.check_after("badseq", S(), S(1, 2))
    # outcomes of `x : (P)` cannot be listed: refused, never a verdict
    with pytest.raises(UnsupportedError, match=r"listing the outcomes of `x : \(x > x\$0\)`"):
        substs.check_after("suchseq", S(), S(1, 1))


def test_unknown_operation(substs):
    with pytest.raises(InputError, match="has no operation 'jump'; it has assign, multi"):
        substs.check_after("jump", S(), S())


def test_invariant(substs):
    assert substs.invariant(S())
    assert not substs.invariant(S(f=FuncValue({1: 0})))
    assert substs.violated_invariant(S(f=FuncValue({1: 0}))) == ["f : 1..3 --> INTEGER"]


def test_load_machine_file_errors(tmp_path):
    with pytest.raises(InputError, match="no such model file"):
        load_machine(tmp_path / "nope.mch")
    bad = tmp_path / "bad.mch"
    bad.write_text("MACHINE Bad\nVARIABLES x\nINVARIANT x : BOOL &\nEND")
    with pytest.raises(BSyntaxError) as info:
        load_machine(bad)
    assert info.value.file == str(bad) and (info.value.line, info.value.column) == (3, 21)
    assert "unexpected end of the INVARIANT clause" in str(info.value)
    assert "^" in str(info.value)


def test_values_remembered_per_state_never_leak_between_before_and_after():
    """Repeated sub-formulas are evaluated once per state; the state after a step, or in the
    middle of a sequence, must not see what was remembered for the state before."""
    m = load_machine_text("""
MACHINE Memo
DEFINITIONS below(k) == card({z | z : 1..10 & z < k})
VARIABLES x, y
INVARIANT x : INTEGER & y : INTEGER
INITIALISATION x, y := 0, 0
OPERATIONS
    grow = PRE below(x) < 9 THEN x : (below(x) = below(x$0) + 1) END;
    step = PRE below(x) < 9 THEN BEGIN x := x + 1 ; y := below(x) END END
END""")
    assert m.check_after("grow", {"x": 3, "y": 0}, {"x": 4, "y": 0})
    assert not m.check_after("grow", {"x": 3, "y": 0}, {"x": 3, "y": 0})
    assert m.check_after("step", {"x": 3, "y": 0}, {"x": 4, "y": 3})
    assert not m.check_after("step", {"x": 3, "y": 0}, {"x": 4, "y": 2})
