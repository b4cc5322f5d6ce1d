"""The shortcuts that make a continuous shield's decision fast give the answers of the plain
exact computation: each fast path is checked here against the slow one it stands for.

* the guard a check evaluates (the state's sub-formulas read from the values the linear
  form computed, shared ones once) answers as the whole guard evaluated afresh;
* linear forms in integers, one sub-formula shared by several bounds, a bound ``p <= v``
  made directly: membership over the reals is the evaluator's where floats are exact;
* an interval compared with floats first (exactly only where they tie) contains, orders and
  bounds as with Fractions alone;
* the nearest point of a union of boxes, far boxes skipped, is the one every box tried in
  order gives.
"""

from __future__ import annotations

import math
from fractions import Fraction

from hypothesis import given, settings
from hypothesis import strategies as st

from tracecheck.b import load_machine_text
from tracecheck.b.linear import allowed_set, guard_with_parameters
from tracecheck.b.box_search import confirmed, distance_floor, nearest_in_boxes
from tracecheck.b.polytope import (Constraint, Interval, bound_constraint, clamp, constraint_of,
                                   inner_point, interval_of)


def machine(guard: str, params: str = "a"):
    typed = " & ".join(f"{p} : REAL" for p in params.split(", "))
    return load_machine_text(f'''MACHINE G
VARIABLES u, v
INVARIANT u : REAL & v : REAL
INITIALISATION u, v := 0.0, 0.0
OPERATIONS Act({params}) = PRE {typed} & ({guard}) THEN skip END
END''')


def whole_guard(m, state, point) -> bool:
    """The guard evaluated afresh, as a recorded action is (no value kept from before)."""
    env = m.env(state)
    env.update({p: float(x) for p, x in point.items()})
    return bool(guard_with_parameters(m, "Act")(env))


DYADIC = st.integers(-6, 6).map(float) | st.sampled_from([0.5, -1.25, 2.75, 0.25])
NUM = DYADIC | st.sampled_from([0.1, 1e-3, 1 / 3, -0.7])
# sub-formulas of the state found in several bounds (shared), conditions, extremes
STATE_TERM = st.sampled_from([
    "u", "v", "max({u, -u})", "max({u, -u}) + max({v, -v})", "min({u, v, 1.0})",
    "(IF u > v THEN u ELSE v END)", "(max({u, -u}) + max({v, -v})) * 2.0", "-u", "u * v",
])
REL = st.sampled_from(["<", "<=", ">", ">=", "/=", "="])


@st.composite
def atom(draw, params=("a",), num=NUM):
    terms = [f"({draw(num)}) * {p}" for p in params if draw(st.booleans())]
    if draw(st.booleans()):
        terms.append(f"{draw(STATE_TERM)} * {draw(st.sampled_from(params))}")
    if draw(st.integers(0, 3)) == 0:  # a bound: the parameter against a value of the state
        sides = [draw(st.sampled_from(params)), draw(STATE_TERM)]
        first, second = sides if draw(st.booleans()) else sides[::-1]
        return f"{first} {draw(REL)} {second}"
    return (f"{' + '.join(terms) or '0.0'} + {draw(STATE_TERM)} * ({draw(num)}) {draw(REL)} "
            f"{draw(STATE_TERM)} + ({draw(num)})")


@st.composite
def guard(draw, params=("a",), depth=2, num=NUM):
    if depth == 0 or draw(st.integers(0, 2)) == 0:
        return draw(atom(params, num))
    op = draw(st.sampled_from(["&", "or", "=>", "<=>"]))
    text = f"({draw(guard(params, depth - 1, num))}) {op} ({draw(guard(params, depth - 1, num))})"
    return f"not({text})" if draw(st.booleans()) else text


PARAMS = st.sampled_from(["a", "a, b"])
POINT = st.integers(-24, 24).map(lambda k: k / 4) | st.floats(-8, 8, allow_nan=False) | \
    st.sampled_from([0.0, -0.0])


@settings(max_examples=150, deadline=None)
@given(PARAMS.flatmap(lambda ps: st.tuples(st.just(ps), guard(tuple(ps.split(", "))))),
       st.fixed_dictionaries({"u": NUM, "v": NUM}), st.lists(st.tuples(POINT, POINT),
                                                               min_size=1, max_size=6))
def test_the_check_answers_as_the_whole_guard_evaluated_afresh(case, state, points):
    params, text = case
    m = machine(text, params)
    allowed = allowed_set(m, "Act", state)
    for x, y in points + points:  # each point twice: the second answer is the kept one
        point = dict(zip(params.split(", "), (x, y)))
        assert allowed.contains(point) == whole_guard(m, state, point), (text, point)


@settings(max_examples=150, deadline=None)
@given(PARAMS.flatmap(lambda ps: st.tuples(st.just(ps), guard(tuple(ps.split(", ")),
                                                              num=DYADIC))),
       st.fixed_dictionaries({"u": DYADIC, "v": DYADIC}),
       st.lists(st.tuples(st.integers(-24, 24), st.integers(-24, 24)), min_size=1,
                max_size=6))
def test_the_polytopes_are_exact_where_the_evaluators_floats_are(case, state, points):
    # small dyadic numbers: the evaluator's arithmetic is exact, so the sets over the reals
    # (integer linear forms, shared sub-formulas, bounds made directly) must agree with it
    params, text = case
    m = machine(text, params)
    allowed = allowed_set(m, "Act", state)
    for x, y in points:
        point = dict(zip(params.split(", "), (x / 4, y / 4)))
        assert allowed.contains_exact(point) == whole_guard(m, state, point), (text, point)


def test_a_shared_sub_formula_is_evaluated_only_where_the_guard_evaluates_it():
    # 1.0 / u is ill-defined at u = 0, where neither the guard nor the shield evaluates it
    # (found twice: kept under one name, computed when first read)
    m = machine("a <= (IF u = 0.0 THEN 1.0 ELSE 1.0 / u END) + v & "
                "a >= -(IF u = 0.0 THEN 1.0 ELSE 1.0 / u END) * 2.0")
    for u, shown in ((0.0, "a ∈ [-2.0, 1.0]"), (2.0, "a ∈ [-1.0, 0.5]")):
        allowed = allowed_set(m, "Act", {"u": u, "v": 0.0})
        assert str(allowed) == shown
        for a in (-2.0, -1.5, 0.5, 0.75, 1.0):
            assert allowed.contains({"a": a}) == whole_guard(m, {"u": u, "v": 0.0}, {"a": a})


# -- intervals: floats first, exactly at a tie

def _reference_interval(part) -> Interval:
    """Fractions alone (what interval_of did before comparing floats first)."""
    low = high = None
    low_open = high_open = False
    for c in part:
        (_, k), = c.coeffs
        bound = -c.const / k
        for value, is_open, upper in ([(bound, False, True), (bound, False, False)]
                                      if c.op == "=" else [(bound, c.op == "<", k > 0)]):
            if upper and (high is None or value < high or (value == high and is_open)):
                high, high_open = value, is_open
            if not upper and (low is None or value > low or (value == low and is_open)):
                low, low_open = value, is_open
    return Interval(low, high, low_open, high_open)


BASE = st.sampled_from([0.0, 1.0, -1.0, 0.1, 1 / 3, 2.5, 1e-300, 1e300, -7.25])
# a rational at, or just beside, a float: where comparing the floats cannot decide
NEAR = st.tuples(BASE, st.integers(-2, 2), st.sampled_from([0, 1, -1])).map(
    lambda t: Fraction(t[0] if t[1] == 0 else math.nextafter(t[0], math.copysign(math.inf,
                                                                                t[1])))
    + t[2] * Fraction(1, 2 ** 1100))
COEF = st.sampled_from([Fraction(1), Fraction(-1), Fraction(3), Fraction(-1, 3),
                        Fraction(2, 7), Fraction(10 ** 20)])


@st.composite
def one_parameter_constraint(draw):
    k, bound = draw(COEF), draw(NEAR)
    return Constraint((("a", k),), -bound * k, draw(st.sampled_from(["<", "<=", "="])))


@settings(max_examples=300, deadline=None)
@given(st.lists(one_parameter_constraint(), min_size=1, max_size=5),
       st.lists(NEAR.map(float) | BASE, min_size=1, max_size=5))
def test_intervals_compared_in_floats_first_are_the_exact_ones(part, xs):
    got, want = interval_of(part), _reference_interval(part)
    assert got == want
    assert got.empty == (want.low is not None and want.high is not None and (
        want.low > want.high or (want.low == want.high and (want.low_open or want.high_open))))
    for x in xs:
        assert got.contains(x) == got.contains(Fraction(x))
        if not got.empty:
            inside = clamp(x, got)
            assert inside == x if got.contains(Fraction(x)) else inside in (
                float(got.low) if got.low is not None else None,
                float(got.high) if got.high is not None else None)
    if got.low is not None and got.high is not None:
        assert inner_point(got, 0.0) == float((got.low + got.high) / 2)


@settings(max_examples=300, deadline=None)
@given(NEAR, st.booleans(), st.sampled_from(["<", "<="]), st.sampled_from(["a", "b"]))
def test_a_bound_made_directly_is_the_constraint_the_linear_form_makes(value, upper, op, p):
    n, d = value.numerator, value.denominator
    direct = bound_constraint(p, (n, d), upper, op)
    order = ("a", "b")
    form = tuple((d if upper else -d) if q == p else 0 for q in order) + \
        ((-n if upper else n),)
    general = constraint_of((form, d), op, order)
    plain = Constraint(direct.coeffs, direct.const, direct.op)  # its limit computed afresh
    assert direct == general == plain
    assert direct.limit == general.limit == plain.limit == (value, float(value), upper)


# -- the nearest point of a union of boxes: far boxes skipped

BOX_BOUND = st.integers(-12, 12).map(lambda k: k / 2) | st.sampled_from([0.1, -1 / 3, 2.75])


@st.composite
def box_guard(draw):
    boxes = []
    for _ in range(draw(st.integers(1, 5))):
        (a0, a1), (b0, b1) = sorted(draw(st.tuples(BOX_BOUND, BOX_BOUND))), \
            sorted(draw(st.tuples(BOX_BOUND, BOX_BOUND)))
        ops = draw(st.tuples(st.sampled_from(["<", "<="]), st.sampled_from(["<", "<="])))
        boxes.append(f"(a >= {a0} & a {ops[0]} {a1} & b > {b0} & b {ops[1]} {b1} + u)")
    return " or ".join(boxes)


@settings(max_examples=200, deadline=None)
@given(box_guard(), st.tuples(POINT, POINT), st.sampled_from([{}, {"a": 0.5, "b": 3.0}]),
       st.sampled_from([0.0, 0.1]))
def test_the_nearest_point_skipping_far_boxes_is_the_one_every_box_gives(text, point, scale, u):
    m = machine(text, "a, b")
    allowed = allowed_set(m, "Act", {"u": u, "v": 0.0})
    assert allowed.separable
    boxes = allowed._boxes
    p = {"a": point[0], "b": point[1]}
    best, best_d = None, math.inf  # every box, in order: the first of the nearest
    for box in boxes:
        candidate = confirmed(allowed, {q: clamp(p[q], box[q]) for q in "ab"}, box)
        if candidate is None:
            continue
        d = sum(((candidate[q] - p[q]) / scale.get(q, 1.0)) ** 2 for q in "ab")
        assert distance_floor(box, p, {q: scale.get(q, 1.0) for q in "ab"}) <= d
        if d < best_d:
            best, best_d = candidate, d
    assert nearest_in_boxes(allowed, boxes, p, scale or None) == best == \
        allowed.nearest(p, scale or None)
    if best is not None:
        assert whole_guard(m, {"u": u, "v": 0.0}, best)


# -- the nearest point of a polytope: the active set floats find, verified exactly

PCOEF = st.integers(-3, 3).map(Fraction) | st.sampled_from([Fraction(1, 3), Fraction(-2, 7),
                                                            Fraction(10 ** 9 + 1, 10 ** 9)])
PROW = st.tuples(st.lists(PCOEF, min_size=2, max_size=2),
                 st.integers(-6, 6).map(Fraction) | st.sampled_from([Fraction(1, 3)]),
                 st.sampled_from(["<=", "<", "<=", "="]))


@settings(max_examples=300, deadline=None)
@given(st.lists(PROW, min_size=1, max_size=7),
       st.tuples(st.integers(-8, 8), st.integers(-8, 8), st.sampled_from([0, 1, -1])))
def test_the_nearest_point_of_a_polytope_from_the_float_hint_is_the_exact_one(rows, point):
    from unittest import mock

    from tracecheck.b import linear_batch, polytope

    p = [Fraction(point[0]) + Fraction(point[2], 3), Fraction(point[1])]
    fast = polytope.nearest_in_polytope(rows, p)
    with mock.patch.object(linear_batch, "nearest_active_set", lambda *args: None):
        every = polytope.nearest_in_polytope(rows, p)  # every active set, in rationals
    assert fast == every
    # whatever set the floats suggest, only the nearest point passes the exact check
    m = len([r for r in rows if any(r[0])])
    for hint in [()] + [(i,) for i in range(m)] + [(i, j) for i in range(m)
                                                     for j in range(i + 1, m)]:
        with mock.patch.object(linear_batch, "nearest_active_set", lambda *_, h=hint: h):
            assert polytope.nearest_in_polytope(rows, p) == every, hint
