"""The allowed set of a guard that is not linear in its parameters, decided by z3
(tracecheck.checking.solved_set): every point it returns is allowed by the evaluator, the
nearest one is within the tolerance of a brute-force grid's, nothing allowed is None only
when proved, and a spent budget or a boundary floats cannot show is 'undecided'."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from tracecheck.b import load_machine_text
from tracecheck.b.values import Elem, FuncValue
from tracecheck.errors import InputError, UnsupportedError

pytest.importorskip("z3")

from tracecheck.checking.solved_set import (  # noqa: E402
    DEFAULT_TOLERANCE, check_solvable, solved_set)

MACHINE = load_machine_text("""MACHINE Curved
SETS Cars = {c1, c2, c3}
VARIABLES Limit, R, D, X, present
INVARIANT Limit : REAL & R : REAL & D : REAL & X : Cars --> REAL & present <: Cars
INITIALISATION Limit := 2.0 || R := 4.0 || D := 1.0 || X := Cars * {0.0} || present := {}
OPERATIONS
  Square(a) = PRE a : REAL & a * a <= Limit THEN skip END;
  Disc(a, s) = PRE a : REAL & s : REAL & a * a + s * s <= R THEN skip END;
  Product(a, s) = PRE a : REAL & s : REAL & a * s >= 1.0 THEN skip END;
  Never(a) = PRE a : REAL & a * a < 0.0 THEN skip END;
  Root(a) = PRE a : REAL & a * a = 2.0 THEN skip END;
  Sqrt(a) = PRE a : REAL & RSQRT(a) <= 2.0 THEN skip END;
  Inverse(a) = PRE a : REAL & a * a <= 1.0 / D THEN skip END;
  Apart(a) = PRE a : REAL & a * a <= 100.0 &
                 !c.(c : present => (X(c) - a) * (X(c) - a) >= 1.0) THEN skip END;
  Plain = skip
END""")

STATE = {"Limit": 2.0, "R": 4.0, "D": 1.0,
         "X": FuncValue({Elem("c1"): 0.0, Elem("c2"): 3.0, Elem("c3"): 9.0}),
         "present": frozenset({Elem("c1"), Elem("c2")})}

#: the guards of MACHINE over a grid (numpy), to compare the solver's answers with
GRID = np.linspace(-5.0, 5.0, 2001)  # steps of 0.005
A, S = np.meshgrid(GRID, GRID, indexing="ij")
ALLOWED = {"Disc": A * A + S * S <= 4.0, "Product": A * S >= 1.0}


def _set(op, timeout_s=5.0, **state):
    return solved_set(MACHINE, op, {**STATE, **state}, timeout_s=timeout_s)


def _grid_nearest(op, point, scale=(1.0, 1.0), box=None):
    """The distance from ``point`` to the nearest allowed grid point (scaled)."""
    mask = ALLOWED[op]
    if box is not None:
        (alo, ahi), (slo, shi) = box
        mask = mask & (A >= alo) & (A <= ahi) & (S >= slo) & (S <= shi)
    d = np.sqrt(((A - point[0]) / scale[0]) ** 2 + ((S - point[1]) / scale[1]) ** 2)
    return float(d[mask].min())


# ------------------------------------------------------------------ the evaluator decides


def test_membership_is_the_evaluators_answer_and_the_text_says_who_decides():
    square = _set("Square")
    assert square.contains({"a": 1.4}) and not square.contains({"a": 1.5})
    assert square.contains({"a": -math.sqrt(2.0) + 1e-12})
    assert str(square) == "a: not linear; decided by the solver"
    assert str(_set("Disc")) == "(a, s): not linear; decided by the solver"
    assert square.bands() is None and square.intervals is None and not square.separable
    assert square.contains_exact({"a": 1.4}) and not square.contains_exact({"a": 1.5})


def test_the_witness_is_confirmed_by_the_evaluator():
    for op in ("Square", "Disc", "Product", "Apart", "Inverse"):
        allowed = _set(op)
        w = allowed.witness()
        assert w is not None and allowed.contains(w), op
        assert MACHINE.allows(op, STATE, w), op  # the machine's own evaluation agrees


def test_nothing_allowed_is_none_only_where_the_solver_proves_it():
    never = _set("Never")
    assert never.witness() is None
    assert never.nearest({"a": 1.0}) is None and never.distance({"a": 1.0}) is None
    # a part without parameters that is not well-defined (1.0 / 0.0) allows nothing,
    # as the evaluator reads it; so does a square above the limit
    assert _set("Inverse", D=0.0).witness() is None
    assert _set("Square", Limit=-1.0).witness() is None


# ------------------------------------------------------------------ nearest, against a grid


@pytest.mark.parametrize("op, point", [
    ("Disc", (3.0, 3.0)), ("Disc", (-4.0, 0.5)), ("Disc", (0.1, -2.5)),
    ("Product", (0.0, 0.0)), ("Product", (-0.3, 2.0)), ("Product", (2.0, -1.0)),
])
def test_the_nearest_point_is_allowed_and_no_grid_point_is_nearer(op, point):
    allowed = _set(op)
    result = allowed.nearest_result({"a": point[0], "s": point[1]})
    assert result.complete and result.why == ""
    q = result.point
    assert allowed.contains(q) and MACHINE.allows(op, STATE, q)
    d = math.hypot(q["a"] - point[0], q["s"] - point[1])
    assert d == pytest.approx(result.distance, abs=1e-12)
    grid = _grid_nearest(op, point)
    assert d <= grid + DEFAULT_TOLERANCE  # no allowed grid point is nearer
    assert d >= grid - 0.005  # and the grid is that fine
    assert result.lower <= d <= result.lower + DEFAULT_TOLERANCE
    distance = allowed.distance({"a": point[0], "s": point[1]})
    assert abs(distance - d) <= 2 * DEFAULT_TOLERANCE


def test_the_nearest_point_of_a_disc_is_its_exact_projection():
    allowed = _set("Disc")
    q = allowed.nearest({"a": 3.0, "s": 4.0})  # the projection is (1.2, 1.6)
    assert q["a"] ** 2 + q["s"] ** 2 <= 4.0
    assert math.hypot(q["a"] - 1.2, q["s"] - 1.6) < 1e-5
    assert allowed.distance({"a": 3.0, "s": 4.0}) == pytest.approx(3.0, abs=1e-6)


def test_an_allowed_proposal_is_its_own_nearest_and_at_distance_zero():
    allowed = _set("Product")
    assert allowed.nearest({"a": 2.0, "s": 3.0}) == {"a": 2.0, "s": 3.0}
    assert allowed.distance({"a": 2.0, "s": 3.0}) == 0.0


def test_the_scale_weighs_each_parameter():
    allowed = _set("Disc")
    point, scale = (3.0, 3.0), (1.0, 10.0)  # s is cheap to move: a moves little
    q = allowed.nearest({"a": point[0], "s": point[1]}, {"a": 1.0, "s": 10.0})
    assert allowed.contains(q)
    d = math.hypot((q["a"] - point[0]) / scale[0], (q["s"] - point[1]) / scale[1])
    assert d <= _grid_nearest("Disc", point, scale) + DEFAULT_TOLERANCE
    assert q["a"] > 1.9  # mostly s moved


def test_one_parameter_a_square_below_a_state_variable():
    allowed = _set("Square", Limit=2.0)
    q = allowed.nearest({"a": 5.0})
    assert q["a"] * q["a"] <= 2.0 and abs(q["a"] - math.sqrt(2.0)) < 1e-6
    assert allowed.nearest({"a": -5.0})["a"] == pytest.approx(-math.sqrt(2.0), abs=1e-6)


def test_a_quantifier_over_the_states_elements():
    # allowed: |a| <= 10, at least 1 away from X(c1) = 0 and X(c2) = 3 (c3 is not present)
    allowed = _set("Apart")
    assert allowed.contains({"a": 1.5}) and not allowed.contains({"a": 2.5})
    assert allowed.nearest({"a": 2.5})["a"] == pytest.approx(2.0, abs=1e-6)
    assert allowed.nearest({"a": 0.2})["a"] == pytest.approx(1.0, abs=1e-6)
    assert allowed.nearest({"a": -0.2})["a"] == pytest.approx(-1.0, abs=1e-6)
    assert allowed.nearest({"a": 9.5}) == {"a": 9.5}  # only c3, not present, is there


# ------------------------------------------------------------------ within the box


def test_within_bounds_every_answer_lies_in_the_box():
    allowed = _set("Disc").within({"a": 0.5, "s": -math.inf}, {"a": 1.0})
    assert str(allowed) == "(a, s): not linear; decided by the solver (searched within the action space: a ∈ [0.5, 1.0])"
    assert not allowed.contains({"a": 0.0, "s": 0.0})  # allowed, outside the box
    w = allowed.witness()
    assert 0.5 <= w["a"] <= 1.0 and allowed.contains(w)
    q = allowed.nearest({"a": 3.0, "s": 3.0})
    assert 0.5 <= q["a"] <= 1.0 and allowed.contains(q)
    grid = _grid_nearest("Disc", (3.0, 3.0), box=((0.5, 1.0), (-np.inf, np.inf)))
    assert math.hypot(q["a"] - 3.0, q["s"] - 3.0) <= grid + DEFAULT_TOLERANCE
    assert math.hypot(q["a"] - 1.0, q["s"] - math.sqrt(3.0)) < 1e-5  # the arc at a = 1
    # a box the set does not reach: proved empty
    outside = _set("Disc").within({"a": 2.5}, {"a": 3.0})
    assert outside.witness() is None and outside.nearest({"a": 0.0, "s": 0.0}) is None
    # bounds narrow further, never widen
    narrower = allowed.within({"a": 0.0}, {"a": 0.75})
    assert str(narrower).endswith("a ∈ [0.5, 0.75])")


# ------------------------------------------------------------------ undecided, refused


def test_a_point_set_floats_cannot_show_is_undecided_not_a_guess():
    with pytest.raises(UnsupportedError) as info:
        _set("Root").witness()  # a * a = 2.0: no float squares to 2.0
    message = info.value.message
    assert message.startswith("undecided for Root in this state: z3 finds values allowed "
                              "over the reals (a = ")
    assert "no float near them passes the guard" in message
    assert "tracecheck does not guess" in message


def test_a_tiny_budget_is_undecided_not_a_wrong_answer():
    for op in ("Disc", "Never"):
        allowed = _set(op, timeout_s=1e-6)
        with pytest.raises(UnsupportedError) as info:
            allowed.witness()
        assert info.value.message == (
            f"undecided for {op} in this state: the solver could not tell whether any value "
            "is allowed (the budget of 1e-06 s is spent); tracecheck does not guess")
        assert "timeout_s" in info.value.hint
        with pytest.raises(UnsupportedError, match="undecided"):
            allowed.nearest({"a": 3.0, "s": 3.0})
        with pytest.raises(UnsupportedError, match="undecided"):
            allowed.distance({"a": 3.0, "s": 3.0})
    # an allowed proposal needs no solver: the evaluator's answer, whatever the budget
    assert _set("Disc", timeout_s=1e-6).nearest({"a": 0.0, "s": 0.0}) == {"a": 0.0, "s": 0.0}


def test_a_budget_spent_after_the_witness_gives_an_allowed_point_marked_incomplete():
    allowed = _set("Disc")
    w = allowed.witness()
    allowed.clock.deadline = time.monotonic()  # the state's budget spent from here on
    result = allowed.nearest_result({"a": 3.0, "s": 3.0})
    assert result.point == w and allowed.contains(result.point)
    assert not result.complete and result.lower == 0.0
    assert result.why == "the budget of 5.0 s is spent"
    with pytest.raises(UnsupportedError) as info:
        allowed.distance({"a": 3.0, "s": 3.0})
    assert "could not narrow the distance of (a = 3.0, s = 3.0) to the allowed set" in \
        info.value.message


def test_a_guard_the_solver_cannot_take_is_refused_before_any_state():
    with pytest.raises(UnsupportedError) as info:
        check_solvable(MACHINE, "Sqrt")
    error = info.value
    assert error.message == ("the solver cannot decide Sqrt's guard: cannot translate "
                             "RSQRT(…) here to SMT")
    assert error.line == 12 and "RSQRT(a)" in error.render()
    assert "linear" in error.hint
    with pytest.raises(UnsupportedError, match="cannot translate RSQRT"):
        _set("Sqrt")
    for op in ("Square", "Disc", "Product", "Apart", "Inverse"):
        check_solvable(MACHINE, op)  # these can be translated, in any state
    with pytest.raises(UnsupportedError, match="Plain has no parameters typed `p : REAL`"):
        check_solvable(MACHINE, "Plain")


def test_a_quantifier_over_literals_is_taken_before_any_state_as_in_each():
    """A new user's boat: `!k.(k : 1..3 => Speed + real(k) * thrust <= 6.0)` was decided by
    guards and replay (in a state) but refused by record before any episode: without a
    state, the literals 1 and 3 stood for values the solver chooses. A range read from the
    state still cannot be bound before one."""
    boat = load_machine_text("""MACHINE Boat
VARIABLES Speed, N
INVARIANT Speed : REAL & N : INTEGER
INITIALISATION Speed := 2.0 || N := 3
OPERATIONS
  Steer(t) = PRE t : REAL & t * t <= 1.0 & !k.(k : 1..3 => Speed + real(k) * t <= 6.0)
    THEN skip END;
  Stated(t) = PRE t : REAL & t * t <= 1.0 & !k.(k : 1..N => Speed + real(k) * t <= 6.0)
    THEN skip END
END""")
    check_solvable(boat, "Steer")
    allowed = solved_set(boat, "Steer", {"Speed": 2.0, "N": 3}, timeout_s=5.0)
    assert allowed.contains({"t": 1.0}) and not allowed.contains({"t": 1.5})
    with pytest.raises(UnsupportedError, match="a binding of k over a range the solver "
                                               "chooses"):
        check_solvable(boat, "Stated")
    assert solved_set(boat, "Stated", {"Speed": 2.0, "N": 3}, timeout_s=5.0).contains(
        {"t": 1.0})


def test_a_state_value_that_is_not_finite_is_refused_with_its_name():
    with pytest.raises(InputError, match="Limit is inf, not a B real"):  # at the boundary
        _set("Square", Limit=math.inf)


DISC = """MACHINE Disc
VARIABLES R, Gap
INVARIANT R : REAL & Gap : REAL
INITIALISATION R, Gap := 4.0, 10.0
OPERATIONS
  DRIVE(a, s) = PRE a : REAL & s : REAL & a * a + s * s <= R & a <= Gap
    THEN R, Gap :(R : REAL & Gap : REAL) END
END
"""


@pytest.mark.parametrize("r, text, witness", [
    ("4.0", "DRIVE: (a, s): not linear; decided by the solver; allowed, e.g. a = ", True),
    ("-1.0", "DRIVE: (a, s): not linear; decided by the solver; nothing allowed (the solver "
             "proved it)", False),
])
def test_guards_names_an_allowed_point_of_a_set_the_solver_decides(capsys, tmp_path, r, text,
                                                                   witness):
    import json

    from tests.helpers import run

    (tmp_path / "disc.mch").write_text(DISC)
    (tmp_path / "s.json").write_text(json.dumps({"R": r, "Gap": "1.0"}))
    code, out, err = run(capsys, "guards", tmp_path / "disc.mch", "--state", tmp_path / "s.json")
    assert code == 0, err
    assert text in " ".join(out.split())
    code, out, _ = run(capsys, "guards", tmp_path / "disc.mch", "--state", tmp_path / "s.json",
                       "--json")
    drive = json.loads(out)["allowed"]["DRIVE"]
    assert drive["decided_by"] == "solver" and drive["undecided"] is None
    if witness:
        point = drive["witness"]
        assert point["a"] ** 2 + point["s"] ** 2 <= 4.0 and point["a"] <= 1.0
    else:
        assert drive["witness"] is None
