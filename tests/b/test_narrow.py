"""Allowed points of a narrower float type (tracecheck.b.narrow): an action space of float32
takes float32 values, so a guard that allows only values no float32 is allows nothing
there — and never "nothing" on a guess."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tracecheck.b import load_machine_text
from tracecheck.b.linear import allowed_set
from tracecheck.b.narrow import _edge, _has_value
from tracecheck.b.polytope import Interval
from tracecheck.errors import UnsupportedError


def _one(guard: str, state: float = 0.0):
    m = load_machine_text(f"""MACHINE N VARIABLES x INVARIANT x : REAL INITIALISATION x := 0.0
OPERATIONS GO(r) = PRE r : REAL & {guard} THEN skip END END""")
    return allowed_set(m, "GO", {"x": state})


@pytest.mark.parametrize("guard, f32, f64", [
    ("r = 0.1", None, 0.1),  # no float32 is 0.1
    ("r = 0.5", 0.5, 0.5),
    ("r > 0.1 & r < 0.1 + 1.0E-12", None, "some"),  # narrower than a float32 step
    ("r <= 0.1 & r >= 0.1 - 1.0E-7", "some", "some"),  # float32(0.1) lies above 0.1
    ("(r = 0.1 or r = 0.25)", 0.25, 0.1),
    ("r > x + 3.0", "some", "some"),
])
def test_a_float32_space_allows_only_float32_values(guard, f32, f64):
    allowed = _one(guard)
    wide = allowed.within({"r": -4.0}, {"r": 4.0})
    narrow = allowed.within({"r": -4.0}, {"r": 4.0}, {"r": "float32"})
    found64, found32 = wide.witness(), narrow.witness()
    assert found64 is not None and (f64 == "some" or found64["r"] == f64)
    assert (found32 is not None) if f32 == "some" else (found32 and found32["r"]) == f32
    if found32 is not None:  # a float32 the evaluator confirms
        assert float(np.float32(found32["r"])) == found32["r"] and wide.contains(found32)
    assert allowed.within({"r": -4.0}, {"r": 4.0}, {"r": "float64"}).witness() == found64


def test_no_float32_found_over_several_parameters_is_undecided_not_nothing():
    m = load_machine_text("""MACHINE N VARIABLES x INVARIANT x : REAL INITIALISATION x := 0.0
OPERATIONS GO(u, v) = PRE u : REAL & v : REAL & u + v = 0.1 & u - v = x THEN skip END END""")
    allowed = allowed_set(m, "GO", {"x": 0.0}).within({}, {}, {"u": "float32",
                                                             "v": "float32"})
    with pytest.raises(UnsupportedError, match="undecided: .* no float32 value"):
        allowed.witness()


def _brute_least(low: float, high: float, lo_open: bool, hi_open: bool):
    """The least float32 in the interval, by walking the float32 values from below."""
    v = np.nextafter(np.float32(low), np.float32(-np.inf))
    for _ in range(8):
        x = Fraction(float(v))
        if x > Fraction(low) or (x == Fraction(low) and not lo_open):
            break
        v = np.nextafter(v, np.float32(np.inf))
    x = Fraction(float(v))
    inside = x < Fraction(high) or (x == Fraction(high) and not hi_open)
    return float(v) if inside else None


@settings(max_examples=300, deadline=None)
@given(st.floats(-1e6, 1e6), st.integers(0, 40), st.booleans(), st.booleans())
def test_the_least_float32_of_an_interval_is_exact(low, width, lo_open, hi_open):
    high = low
    for _ in range(width):  # a few float64 steps: most such intervals hold no float32
        high = float(np.nextafter(high, np.inf))
    if width > 30:
        high = low + abs(low) * 1e-6 + 1e-6
    interval = Interval(Fraction(low), Fraction(high), lo_open, hi_open)
    if interval.empty:
        return
    expected = _brute_least(low, high, lo_open, hi_open)
    assert _has_value(interval, np.float32) == (expected is not None)
    if expected is not None:
        assert _edge(interval, np.float32, 1) == expected


def test_ends_past_the_float32_range():
    huge = Interval(Fraction(10) ** 40, None)
    assert _edge(huge, np.float32, 1) is None
    wide = Interval(-Fraction(10) ** 40, Fraction(0))
    assert _edge(wide, np.float32, 1) == -float(np.finfo(np.float32).max)


@pytest.mark.parametrize("guard, expected", [
    ("r > 2.0E38", float(np.finfo(np.float32).max)),  # unbounded: the type's greatest
    ("r < 0.0 - 2.0E38", -float(np.finfo(np.float32).max)),
    ("r >= 1.0E39", None),  # past float32's range: none (it was undecided)
    ("r <= 0.0 - 1.0E39", None),
])
def test_values_past_the_float32_range(guard, expected):
    """An unbounded end tries the type's values at its range's end; no warning escapes
    (4e38 is inf as a float32: numpy warned "overflow encountered in cast")."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        found = _one(guard).within({}, {}, {"r": "float32"}).witness()
    assert (found and found["r"]) == expected


def test_the_solvers_set_stays_undecided_when_asked_again():
    """The solver's set (a guard not linear) in a float32 space: its float64 witness was
    kept and given on the second ask (a reviewer's r * r = 0.01 + 1e-15)."""
    pytest.importorskip("z3")
    from tracecheck.checking.solved_set import solved_set

    m = load_machine_text("""MACHINE N VARIABLES x INVARIANT x : REAL INITIALISATION x := 0.0
OPERATIONS GO(r) = PRE r : REAL & r * r >= 0.01 & r * r <= 0.01 + 1.0E-15 + x & r > 0.0
THEN skip END END""")
    narrow = solved_set(m, "GO", env=m.env({"x": 0.0}), timeout_s=5.0).within(
        {"r": -4.0}, {"r": 4.0}, {"r": "float32"})
    for _ in range(2):
        with pytest.raises(UnsupportedError, match="no float32 value"):
            narrow.witness()
