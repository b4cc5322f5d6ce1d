"""The values of one number for which a predicate holds, exactly (tracecheck.b.threshold):
the set algebra, each kind of formula, and the refusals; checked against the evaluator at
every breakpoint and between them."""

from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tracecheck.b import ast, load_machine_text
from tracecheck.b.columns import Columns
from tracecheck.b.threshold import Values, values_of
from tracecheck.b.values import Elem, FuncValue
from tracecheck.errors import UnsupportedError

M = load_machine_text("""MACHINE T
SETS Cars = {c1, c2, c3}
VARIABLES x, pos, here
INVARIANT x : REAL & pos : Cars --> REAL & here <: Cars
INITIALISATION x := 0.0 || pos := Cars * {0.0} || here := Cars
END""")
C1, C2, C3 = (Elem(n) for n in ("c1", "c2", "c3"))
STATE = {"x": 2.5, "pos": FuncValue({C1: 10.0, C2: 30.0, C3: -4.0}), "here": frozenset({C1, C2})}


def _set(text: str, state=STATE) -> Values:
    return values_of(M, M.parse(text), "d", state)


def _holds(text: str, d: float, state=STATE) -> bool:
    env = M.env(state)
    env["d"] = d
    comp = M.compiler()
    with comp.binding(("d",)):
        return bool(comp.compile(M.parse(text))(env))


@pytest.mark.parametrize("text,shown", [
    ("x < d + 1.0", "d > 1.5"),
    ("x <= 2.0 * d", "d >= 1.25"),
    ("not(x < d)", "d <= 2.5"),
    ("x = d or d > 7.0", "d = 2.5 or d > 7.0"),
    ("x /= d", "d < 2.5 or d > 2.5"),
    ("d > 0.0 => x > d", "d < 2.5"),
    ("(d > 1.0) <=> (d > 3.0)", "d <= 1.0 or d > 3.0"),
    ("#c.(c : here & pos(c) < d + 5.0)", "d > 5.0"),
    ("!c.(c : here => pos(c) < d)", "d > 30.0"),
    ("#c.(c : here & pos(c) > d & pos(c) < d + 5.0)", "5.0 < d < 10.0 or 25.0 < d < 30.0"),
    ("d - x / 2.0 > IF x > 1.0 THEN 1.0 ELSE 2.0 END", "d > 2.25"),
    ("d : REAL & d > 1.0", "d > 1.0"),
    ("x < 3.0 & d > d", "no value"),
    ("x < 3.0 or d > d", "every value"),
], ids=lambda v: v if isinstance(v, str) and len(v) < 30 else None)
def test_each_kind_of_formula_gives_its_exact_set(text, shown):
    got = _set(text)
    assert got.text("d") == shown
    points = list(got.points) or [F(0)]
    probes = points + [p + F(1, 1000) for p in points] + [p - F(1, 1000) for p in points]
    for p in probes:  # the evaluator agrees at and around every breakpoint
        assert got.contains(p) == _holds(text, float(p)), (text, p)


@pytest.mark.parametrize("text,why", [
    ("d * d > x", "a product of two terms with it"),
    ("x / d > 1.0", "a division by a term with it"),
    ("IF d > 1.0 THEN 1.0 ELSE 0.0 END > x", "an IF whose condition reads it"),
    ("d : {1.0, 2.0}", "a membership of it in a set"),
    ("max({d, x}) > 1.0", "a call (max, min, card, …) of it"),
    ("#(c, e).(c : here & e : here & pos(c) < d)", "a quantifier over several variables"),
    ("!c.(pos(c) < d)", "a ∀ without `=>`"),
], ids=["product", "division", "if-condition", "membership", "function", "two-bound", "forall"])
def test_what_tracecheck_cannot_solve_for_is_refused_with_the_reason(text, why):
    with pytest.raises(UnsupportedError, match="the guard (is not linear in the tuned number|"
                       "reads the tuned number where tracecheck cannot solve for it)") as info:
        _set(text)
    assert why in info.value.message


@st.composite
def sets(draw):
    points = sorted(set(draw(st.lists(st.integers(-5, 5), max_size=4))))
    at = draw(st.lists(st.booleans(), min_size=len(points), max_size=len(points)))
    pieces = draw(st.lists(st.booleans(), min_size=len(points) + 1, max_size=len(points) + 1))
    return Values(tuple(F(p) for p in points), tuple(at), tuple(pieces))


@settings(max_examples=300, deadline=None)
@given(sets(), sets())
def test_the_set_algebra_agrees_with_membership_everywhere(a, b):
    probes = [F(k, 2) for k in range(-14, 15)]
    for x in probes:
        assert a.intersect(b).contains(x) == (a.contains(x) and b.contains(x))
        assert a.union(b).contains(x) == (a.contains(x) or b.contains(x))
        assert a.complement().contains(x) == (not a.contains(x))
    rebuilt = Values.nothing()
    for lo, hi, lc, hc in a.intervals():
        lower = Values.everything() if lo is None else Values.half(lo, True, lc)
        upper = Values.everything() if hi is None else Values.half(hi, False, hc)
        rebuilt = rebuilt.union(lower.intersect(upper))
    assert all(rebuilt.contains(x) == a.contains(x) for x in probes)


def test_a_row_reader_reads_each_row_as_row_does_and_keys_tell_states_apart():
    states = [{"x": float(k % 3), "n": k % 2, "b": k % 2 == 0,
               "f": FuncValue({C1: float(k), C2: 1.5}), "s": frozenset({C1} if k % 2 else {C2}),
               "o": ("t", k % 2)} for k in range(6)]
    cols = Columns.from_states(states)
    read = cols.row_reader(np.array([1, 4]))
    for r in (1, 4):
        assert read(r) == cols.row(r) and type(read(r)["n"]) is int
    ids: dict = {}
    keys = cols.keys(np.arange(6), ids)
    assert len(set(keys)) == 6
    same = Columns.from_states([states[3], states[3]]).keys(np.arange(2), ids)
    assert same[0] == same[1] == keys[3]
    assert ast.free_names(M.parse("x < d")) == {"x", "d"}


def test_a_quantifier_is_evaluated_as_the_engine_does_every_element_each_conjunct_in_order():
    """An element where a conjunct is not well-defined is a refusal, as the engine's; a
    conjunct after one that holds for no value is not evaluated, as the engine's is not."""
    state = {**STATE, "pos": FuncValue({C1: 10.0, C2: 0.0, C3: -4.0})}
    with pytest.raises(Exception, match="(?i)divi|defined"):  # c2: 1.0 / 0.0
        _set("!c.(c : here => 1.0 / pos(c) < d)", state)
    with pytest.raises(Exception, match="(?i)divi|defined"):  # the engine reaches it too
        _set("#c.(c : here & pos(c) < d & 1.0 / pos(c) > 0.0)", state)
    guarded = "#c.(c : here & pos(c) /= 0.0 & 1.0 / pos(c) < d)"
    got = _set(guarded, state)
    assert got.text("d") == "d > 0.1"
    assert all(got.contains(F(v)) == _holds(guarded, v, state) for v in (0.05, 0.1, 0.2))


@pytest.mark.parametrize("text", ["x : 0..d", "x /: 0..d", "2 * d : x..(x + 3)"],
                         ids=["in", "not-in", "number-inside"])
def test_a_whole_number_interval_with_the_number_at_an_end_is_two_bounds(text):
    machine = load_machine_text("MACHINE I VARIABLES x INVARIANT x : INTEGER "
                                "INITIALISATION x := 0 END")
    got = values_of(machine, machine.parse(text), "d", {"x": 4}, integer=True)
    for d in range(-3, 12):
        env = machine.env({"x": 4})
        env["d"] = d
        comp = machine.compiler()
        with comp.binding(("d",)):
            assert got.contains(F(d)) == bool(comp.compile(machine.parse(text))(env)), d
