"""The nearest point of a polytope (tracecheck.b.polytope), exactly, against a brute-force
grid; and the allowed set of a guard whose constraints name two parameters at once."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tracecheck.b import load_machine_text
from tracecheck.b.linear import allowed_set
from tracecheck.b.polytope import nearest_in_polytope
from tracecheck.errors import UnsupportedError

COEF = st.integers(-3, 3).map(Fraction)
ROW = st.tuples(st.lists(COEF, min_size=2, max_size=2), st.integers(-6, 6).map(Fraction),
                st.sampled_from(["<=", "<"]))
POINT = st.tuples(st.integers(-8, 8), st.integers(-8, 8))


def _ok(rows, x) -> bool:
    return all(sum(a * v for a, v in zip(coef, x)) + c <= 0 for coef, c, _ in rows)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(ROW, min_size=1, max_size=5), POINT)
def test_the_nearest_point_is_feasible_and_no_grid_point_is_nearer(rows, point):
    p = [Fraction(point[0]), Fraction(point[1])]
    q = nearest_in_polytope(rows, p)
    grid = [(Fraction(i, 2), Fraction(j, 2)) for i in range(-24, 25) for j in range(-24, 25)]
    feasible = [g for g in grid if _ok(rows, g)]
    if q is None:
        assert not feasible
        return
    assert _ok(rows, q)
    d = sum((a - b) ** 2 for a, b in zip(q, p))
    assert all(sum((a - b) ** 2 for a, b in zip(g, p)) >= d for g in feasible)


MACHINE = """MACHINE Two
VARIABLES cap
INVARIANT cap : REAL
INITIALISATION cap := 1.0
OPERATIONS
  MOVE(u, v) = PRE u : REAL & v : REAL & u + v < cap & u - v <= 2.0 & v >= -3.0
               THEN skip END
END"""


def test_a_guard_over_two_parameters_at_once_projects_and_is_confirmed():
    m = load_machine_text(MACHINE)
    allowed = allowed_set(m, "MOVE", {"cap": 1.0})
    assert not allowed.separable
    near = allowed.nearest({"u": 2.0, "v": 2.0})  # onto u + v = 1 (open): (0.5, 0.5) inside
    assert near["u"] + near["v"] < 1.0 and abs(near["u"] - 0.5) < 1e-9
    assert allowed.contains(near)
    assert allowed.witness() is not None
    assert abs(allowed.distance({"u": 2.0, "v": 2.0}) - np.sqrt(4.5)) < 1e-12
    assert allowed.distance({"u": 0.0, "v": 0.0}) == 0.0
    far = allowed_set(m, "MOVE", {"cap": -20.0})  # nearest 0 is the open corner (-17, -3)
    near = far.nearest({"u": 0.0, "v": 0.0})
    assert far.contains(near) and abs(near["u"] + 17.0) < 1e-9 and abs(near["v"] + 3.0) < 1e-9
    assert abs(far.distance({"u": 0.0, "v": 0.0}) - np.sqrt(17 ** 2 + 3 ** 2)) < 1e-12
    m2 = load_machine_text(MACHINE.replace("v >= -3.0", "v >= -3.0 & u >= -1.0"))
    empty = allowed_set(m2, "MOVE", {"cap": -40.0})  # u + v >= -1 - 3: nothing below -40
    assert empty.witness() is None and empty.nearest({"u": 0.0, "v": 0.0}) is None
    assert empty.distance({"u": 0.0, "v": 0.0}) is None


def _go(guard: str):
    return load_machine_text(f"""MACHINE M
VARIABLES G
INVARIANT G : REAL
INITIALISATION G := 1.0
OPERATIONS Go(a, b) = PRE a : REAL & b : REAL & {guard} THEN skip END
END""")


def test_equalities_over_several_parameters_find_an_allowed_float_or_say_undecided():
    import pytest

    from tracecheck.errors import UnsupportedError

    for guard in ("a + 3.0*b = G", "a + b = G & 2.0*a + 2.0*b = 2.0*G", "a + b = G & a < 0.5"):
        m = _go(guard)
        found = m.allowed("Go", {"G": 1.0}).witness()
        assert found is not None and m.allows("Go", {"G": 1.0}, found), guard
        assert m.is_enabled("Go", {"G": 1.0})
    thin = _go("a + 3.0*b <= G & a + 3.0*b > G - 1.0E-15")  # allowed, but no float found
    with pytest.raises(UnsupportedError, match="undecided"):
        thin.allowed("Go", {"G": 1.0}).witness()


def _edge_set(accepted_floats: int, exact_floats: int = 18, check=None):
    """u in [-1, the 18th float above -1] over the reals, of which the evaluator accepts
    only -1.0 and the next ``accepted_floats`` floats (a guard's rounding at the edge)."""
    import math
    from fractions import Fraction as F

    from tracecheck.b.linear import AllowedSet
    from tracecheck.b.polytope import Constraint

    hi, ok = -1.0, -1.0
    for _ in range(exact_floats):
        hi = math.nextafter(hi, 0.0)
    for _ in range(accepted_floats):
        ok = math.nextafter(ok, 0.0)
    parts = ((Constraint((("u", F(-1)),), F(-1), "<="),
              Constraint((("u", F(1)),), -F(hi), "<=")),)
    return AllowedSet(("u",), parts, check or (lambda p: -1.0 <= p["u"] <= ok)), ok


def test_a_narrow_interval_is_searched_float_by_float_before_nothing_is_said():
    """The new user's double integrator: u ∈ [-1.0, -0.999999999999998…] over the reals,
    the evaluator accepts -1.0 and six floats above it; neither the middle nor the ends
    nor the floats next to them pass, and "deadlock" was said."""
    allowed, ok = _edge_set(6)
    assert allowed.witness() == {"u": ok}  # the accepted float nearest 0
    assert allowed.nearest({"u": 0.3}) == {"u": ok}
    assert allowed.nearest({"u": -3.0}) == {"u": -1.0}
    nothing, _ = _edge_set(6, check=lambda p: False)  # every float searched: none
    assert nothing.witness() is None


def test_a_wide_interval_no_float_of_which_passes_is_undecided_not_empty():
    from fractions import Fraction as F

    from tracecheck.b.linear import AllowedSet
    from tracecheck.b.polytope import Constraint

    wide = AllowedSet(("u",), ((Constraint((("u", F(-1)),), F(-1), "<="),
                                Constraint((("u", F(1)),), F(0), "<=")),), lambda p: False)
    with pytest.raises(UnsupportedError, match="undecided: the guard allows values over "
                                               r"the reals \(\[-1.0, 0.0\]\)"):
        wide.witness()
