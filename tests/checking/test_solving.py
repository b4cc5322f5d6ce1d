"""Solving a predicate for its free identifiers (tracecheck.checking.solving): finite
problems walked by the evaluator, the rest asked of z3; every solution the evaluator's, FALSE
only where the search was complete or z3 proved it, unknown with the reason otherwise."""

from __future__ import annotations

import itertools

import pytest

from tracecheck.b import load_machine_text
from tracecheck.b.btypes import INTEGER
from tracecheck.b.evaluation import Compiler
from tracecheck.b.typecheck import check_formula
from tracecheck.b.values import Elem
from tracecheck.checking import solving
from tracecheck.checking.solving import free_identifiers
from tracecheck.errors import TracecheckError, WellDefinednessError
from tests.helpers import solved as answer

pytest.importorskip("z3")

SEND_MORE = ("{S,E,N,D,M,O,R,Y} <: 0..9 & card({S,E,N,D,M,O,R,Y}) = 8 & S /= 0 & M /= 0 & "
             "S*1000+E*100+N*10+D + M*1000+O*100+R*10+E = M*10000+O*1000+N*100+E*10+Y")


def test_the_issue_example_is_solved_by_the_solver():
    got = answer("x*x = 100 & x < 0")
    assert (got.status, got.solutions, got.method) == ("TRUE", [{"x": -10}], "solver")


def test_free_identifiers_in_the_order_they_appear_without_bound_or_builtin_names():
    from tracecheck.b.parser import parse_formula

    node = parse_formula("y : NAT & #z.(z : 1..3 & z = x) & x = y & MAXINT > y", file="<t>")
    assert free_identifiers(node, {}) == ("y", "x")
    assert free_identifiers(node, {"y": None}) == ("x",)


def test_send_more_money():
    got = answer(SEND_MORE, all_solutions=True)
    assert got.status == "TRUE" and got.complete and got.more is False
    assert got.solutions == [dict(S=9, E=5, N=6, D=7, M=1, O=0, R=8, Y=2)]


@pytest.mark.parametrize("text,solutions,method", [
    ("x : 1..10 & x * x = 49", [{"x": 7}], "enumeration"),
    ("b : BOOL & x : 1..3 & (b = TRUE => x > 2) & (b = FALSE => x = 1)",
     [{"b": False, "x": 1}, {"b": True, "x": 3}], "enumeration"),
    ("x > 3 & x < 3", [], "enumeration"),
    ("x : NAT & x > 2147483643", [{"x": 2147483644 + k} for k in range(4)], "enumeration"),
    ("s <: 1..4 & card(s) = 3 & 2 /: s", [{"s": frozenset({1, 3, 4})}], "enumeration"),
    ("x / 2 = -3 & x < 0", [{"x": -7}, {"x": -6}], "solver"),  # B truncates towards zero
    ("x * x = 2", [], "solver"),
    ("x : NATURAL & x + 5 = 3", [], "solver"),
    ("x = MAXINT + 1", [{"x": 2147483648}], "enumeration"),
])
def test_all_solutions_of_finite_problems(text, solutions, method):
    got = answer(text, all_solutions=True)
    assert got.method == method
    assert sorted(got.solutions, key=lambda s: sorted(s.items())) == \
        sorted(solutions, key=lambda s: sorted(s.items()))
    assert got.status == ("TRUE" if solutions else "FALSE") and got.complete


def test_the_limit_says_whether_there_are_more():
    got = answer("x > 0", all_solutions=True, limit=3)
    assert got.status == "TRUE" and len(got.solutions) == 3 and not got.complete
    assert got.more is True
    got = answer("x : 1..1000 & x mod 7 = 0", all_solutions=True, limit=3)
    assert [s["x"] for s in got.solutions] == [7, 14, 21] and got.more is True


def test_what_the_solver_cannot_take_is_unknown_with_the_reason():
    got = answer("x > 0 & [x] = [5]")
    assert got.status == "unknown" and "<t>:1:9: cannot translate this set" in got.reason
    got = answer("s <: INTEGER & card(s) = 2")
    assert got.status == "unknown" and "cannot translate card(…) here" in got.reason
    got = answer("s <: STRING & card(s) = 2")
    assert got.status == "unknown" and "s is of type POW(STRING)" in got.reason
    got = answer("x*x*x + y*y*y = z*z*z & x > 0 & y > 0 & z > 0", timeout_s=0.5)
    assert got.status == "unknown" and got.reason == "time limit (0.5 s)"


def test_a_large_finite_problem_outside_the_solver_is_walked_until_the_time_limit():
    got = answer("x : 1..400 & y : 1..400 & [x, y] = [400, 399]", timeout_s=30)
    assert got.solutions == [{"x": 400, "y": 399}] and got.method == "enumeration"
    got = answer("x : 1..4000 & y : 1..4000 & [x, y] = [0, 0]", timeout_s=0.3)
    assert got.status == "unknown" and got.reason.startswith("time limit (0.3 s) after ")


def test_reals_are_floats_the_evaluator_confirms():
    got = answer("x * 3.0 = 1.0")
    assert got.status == "TRUE" and 3.0 * got.solutions[0]["x"] == 1.0
    got = answer("x * x = 2.0")  # ±√2: neither it nor a float next to it squares to 2.0
    assert got.status == "unknown" and "not one in floats" in got.reason
    assert answer("x > 1.0 & x < 0.5").status == "FALSE"  # compared as it is: no rounding
    # none over the exact reals, but 1.0e-300 + 1.0 = 1.0 in floats: not FALSE
    got = answer("x : REAL & x + 1.0 = 1.0 & x > 0.0")
    assert got.status == "unknown" and "the REALs are floats" in got.reason


@pytest.mark.parametrize("text", [
    "x : INTEGER & real(x) * 0.1 = 0.30000000000000004",  # x = 3 in floats, none exactly
    "x : INTEGER & x > 0 & real(x) + 1.0E16 = 1.0E16",  # x = 1 in floats, none exactly
])
def test_an_integer_made_real_meets_float_rounding_too(text):
    got = answer(text)
    assert got.status == "unknown" and "the REALs are floats" in got.reason
    assert answer(text.replace("x : INTEGER", "x : 0..10")).status == "TRUE"  # walked
    assert answer("x : INTEGER & x * x = 9 & x < 0").status == "TRUE"  # integers: no rounding
    assert answer("x : INTEGER & x * x = 8").status == "FALSE"


def test_where_the_predicate_has_no_value_is_noted():
    got = answer("x : 0..3 & 10 / x = 5")
    assert got.solutions == [{"x": 2}] and "no value where x = 0: division by zero" in got.note
    # no solution, and a point without value: the located error, not FALSE (as ProB)
    with pytest.raises(WellDefinednessError, match="no value where x = 0: division by zero"):
        answer("x : INTEGER & 10 / x = 50")
    with pytest.raises(WellDefinednessError, match="no value where x = -1: mod needs"):
        answer("x mod 3 = 2 & x < 0")  # mod needs x >= 0: never defined here


def test_elements_of_a_machine_set_and_its_constants():
    machine = load_machine_text("""MACHINE Paint
SETS Colour = {red, green, blue}; Car
CONSTANTS price
PROPERTIES price : Colour --> NAT & price = {red |-> 3, green |-> 5, blue |-> 7}
END""")
    got = answer("c : Colour & price(c) > 4", machine, all_solutions=True)
    assert got.solutions == [{"c": Elem("green")}, {"c": Elem("blue")}] and got.complete
    got = answer("c /= d & price(c) + price(d) = 10 & c : Colour & d : Colour", machine,
                 all_solutions=True)
    assert [(s["c"], s["d"]) for s in got.solutions] == [("red", "blue"), ("blue", "red")]
    got = answer("v : Car & w : Car & v /= w", machine, all_solutions=True)  # deferred
    assert [(s["v"], s["w"]) for s in got.solutions] == [("Car1", "Car2"), ("Car2", "Car1")]



def test_a_set_an_equality_fixes_enters_the_solver_as_a_value():
    # f is no number, but its one value is known: the solver takes x with f in its scope
    got = answer("f = {(1|->3),(2|->6)} & x * x = f(2) + 3 & x < 0")
    assert got.status == "TRUE" and got.names == ("f", "x")
    assert got.solutions == [{"f": frozenset({(1, 3), (2, 6)}), "x": -3}]
    assert answer("f = {(1|->3)} & x * x = f(1) + 2").status == "FALSE"  # z3's proof


def test_elements_the_solver_does_not_choose_are_walked_and_the_numbers_solved_at_each():
    machine = load_machine_text("""MACHINE Rail
SETS Trains = {thomas, gordon, percy}
END""")
    text = ("pos = {thomas|->100, gordon|->2020, percy|->20} & t1 : dom(pos) & t2 : dom(pos) & "
            "pos(t1) < pos(t2) & x : INTEGER & x * 2 = pos(t2) - pos(t1) & x > 999")
    got = answer(text, machine, all_solutions=True)
    assert [(s["t1"], s["t2"], s["x"]) for s in got.solutions] == [
        ("percy", "gordon", 1000)] and got.complete
    assert answer("t : Trains & x * x = 15", machine).status == "FALSE"  # every t: z3 proved
    with pytest.raises(WellDefinednessError, match="division by zero"):
        answer("t : Trains & x = 1 / 0 + 0 * x", machine)
    got = answer("t : Trains & y : Trains & x > 2 & x * x = 9", machine, all_solutions=True,
                 limit=4)
    assert len(got.solutions) == 4 and not got.complete and got.more is not False

OPS = ["x + y", "x - y", "x * y", "x / y", "x mod y", "x ** 2 - y", "abs(x) - y",
       "(x + y) / 3", "x / (y - 2)"]


@pytest.mark.parametrize("expr", OPS)
@pytest.mark.parametrize("rel,bound", [("=", 2), ("<", -3), (">=", 4)])
def test_the_solver_finds_exactly_what_the_evaluator_finds(monkeypatch, expr, rel, bound):
    """Integer semantics (truncating division, mod, well-definedness) are the evaluator's:
    the solver's complete list equals brute force over the box."""
    text = f"x >= -6 & x <= 6 & y >= -6 & y <= 6 & {expr} {rel} {bound}"
    node, _ = check_formula(text, {"x": INTEGER, "y": INTEGER}, file="<t>")
    fn = Compiler(source=text).compile(node)
    expected, undefined = [], False
    for x, y in itertools.product(range(-6, 7), repeat=2):
        try:
            if fn({"x": x, "y": y}) is True:
                expected.append({"x": x, "y": y})
        except TracecheckError:
            undefined = True
    monkeypatch.setattr(solving, "SMALL_SPACE", 0)  # the solver, not the walk
    if not expected and undefined:  # no solution, and points without value: not FALSE
        with pytest.raises(WellDefinednessError, match="the predicate has no value where"):
            answer(text, all_solutions=True, limit=200)
        return
    got = answer(text, all_solutions=True, limit=200)
    assert got.method == "solver" and got.complete
    key = lambda s: (s["x"], s["y"])  # noqa: E731
    assert sorted(got.solutions, key=key) == sorted(expected, key=key)


def test_sets_and_relations_over_finite_types_are_walked():
    # B, C, D have no bound but their type POW(BOOL): walked, and the search is complete
    assert answer("A \\/ B = D & A /\\ C = {} & D = C & A /= {} & A : POW(BOOL)").status \
        == "FALSE"
    got = answer("r : BOOL <-> BOOL & card(r) = 3 & (r ; r) = r", all_solutions=True)
    F, T = False, True  # of the four 3-pair relations, those without (T, F) or (F, T)
    assert got.complete and sorted(sorted(s["r"]) for s in got.solutions) == [
        [(F, F), (F, T), (T, T)], [(F, F), (T, F), (T, T)]]
    got = answer("x <: BOOL & card(x) = 2")
    assert got.solutions == [{"x": frozenset({False, True})}]
