"""Allowed sets of REAL parameters: exact membership, nearest allowed points, refusals.

Random linear guards in one and two parameters, random states and points: membership agrees
with the ordinary guard evaluation on every point, every nearest point satisfies the guard
(checked by the evaluator), and no allowed point of a fine grid is nearer.
"""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from hypothesis import given, settings, strategies as st

from tracecheck.b import load_machine_text
from tracecheck.b.linear import allowed_set, real_parameters
from tracecheck.errors import TracecheckError, UnsupportedError


def machine(guard: str, params: str = "a", extra: str = ""):
    typed = " & ".join(f"{p} : REAL" for p in params.split(", "))
    return load_machine_text(f'''MACHINE G
VARIABLES u, v
INVARIANT u : REAL & v : REAL
INITIALISATION u, v := 0.0, 0.0
OPERATIONS Act({params}) = PRE {typed} & ({guard}) THEN skip END{extra}
END''')


def evaluator_holds(m, state, point) -> bool:
    """The ordinary guard evaluation with the parameters bound (compiled once per machine)."""
    guard = m.cached("test guard", "Act", lambda: m.compile(m.operation("Act").guard))
    env = m.env(state)
    env.update(point)
    return bool(guard(env))


DYADIC = st.integers(-6, 6).map(float) | st.sampled_from([0.5, -1.25, 2.75])
NUM = DYADIC | st.sampled_from([0.1, 1e-3, 1 / 3])
REL = st.sampled_from(["<", "<=", ">", ">=", "/=", "="])


@st.composite
def linear_atom(draw, params=("a",), num=NUM):
    terms = " + ".join(f"({draw(num)}) * {p}" for p in params if draw(st.booleans())) or "0.0"
    return f"{terms} + u * ({draw(num)}) {draw(REL)} v + ({draw(num)})"


@st.composite
def guard(draw, params=("a",), depth=2, num=NUM):
    if depth == 0 or draw(st.integers(0, 2)) == 0:
        return draw(linear_atom(params, num))
    op = draw(st.sampled_from(["&", "or", "=>", "<=>"]))
    left, right = draw(guard(params, depth - 1, num)), draw(guard(params, depth - 1, num))
    text = f"({left}) {op} ({right})"
    return f"not({text})" if draw(st.booleans()) else text


STATE = st.fixed_dictionaries({"u": NUM, "v": NUM})
POINT = st.integers(-40, 40).map(lambda k: k / 4) | st.floats(-12, 12, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(guard(num=DYADIC), st.fixed_dictionaries({"u": DYADIC, "v": DYADIC}),
       st.lists(st.integers(-40, 40).map(lambda k: k / 4), min_size=1, max_size=8))
def test_membership_over_the_reals_is_the_evaluators_where_floats_are_exact(text, state,
                                                                             points):
    # small dyadic numbers: the evaluator's float arithmetic is exact, so the two agree
    m = machine(text)
    allowed = allowed_set(m, "Act", state)
    for a in points:
        assert allowed.contains_exact({"a": a}) == evaluator_holds(m, state, {"a": a}), \
            (text, a)
        assert allowed.contains({"a": a}) == evaluator_holds(m, state, {"a": a})


@settings(max_examples=200, deadline=None)
@given(guard(), STATE, POINT)
def test_the_nearest_allowed_point_satisfies_the_guard_and_no_grid_point_is_nearer(
        text, state, a):
    m = machine(text)
    allowed = allowed_set(m, "Act", state)
    grid = [k / 8 for k in range(-120, 121)]
    inside = [x for x in grid if evaluator_holds(m, state, {"a": x})]
    try:
        nearest = allowed.nearest({"a": a})
    except UnsupportedError:  # undecided (see the test of two parameters)
        assert not inside and allowed.intervals
        return
    if nearest is None:  # nothing allowed, or no float the evaluator takes near the bound
        assert not inside
        return
    assert evaluator_holds(m, state, nearest), (text, a, nearest)
    if inside:
        assert abs(nearest["a"] - a) <= min(abs(x - a) for x in inside) + 1e-9


@settings(max_examples=150, deadline=None)
@given(st.lists(linear_atom(("a",)), min_size=1, max_size=3),
       st.lists(linear_atom(("b",)), min_size=1, max_size=3), STATE,
       st.tuples(POINT, POINT))
def test_two_parameters_separable_boxes(on_a, on_b, state, point):
    text = " & ".join(f"({t})" for t in on_a + on_b)
    m = machine(text, "a, b")
    allowed = allowed_set(m, "Act", state)
    assert allowed.separable
    p = {"a": point[0], "b": point[1]}
    assert allowed.contains(p) == evaluator_holds(m, state, p)
    grid = [(x / 2, y / 2) for x in range(-24, 25) for y in range(-24, 25)]
    try:
        nearest = allowed.nearest(p)
    except UnsupportedError:  # undecided: allowed over the reals, no float point tried
        #                       passed, and too many to try all — never where one does
        assert not any(evaluator_holds(m, state, {"a": x, "b": y}) for x, y in grid)
        assert allowed._boxes
        return
    if nearest is not None:
        assert evaluator_holds(m, state, nearest)
        d = math.hypot(nearest["a"] - p["a"], nearest["b"] - p["b"])
        grid = [(x, y) for x, y in grid if math.hypot(x - p["a"], y - p["b"]) < d - 1e-9]
    # no point of the grid nearer than the answer is allowed (none at all if it found none)
    assert not any(evaluator_holds(m, state, {"a": x, "b": y}) for x, y in grid)


def test_intervals_are_exact_and_printed_as_b_would_read_them():
    m = machine("a >= -4.0 & a <= 2.0 & (a < -1.0 or a > 0.5) & a /= 1.0")
    allowed = allowed_set(m, "Act", {"u": 0.0, "v": 0.0})
    assert str(allowed) == "a ∈ [-4.0, -1.0) ∪ (0.5, 1.0) ∪ (1.0, 2.0]"
    third = machine("3.0 * a <= 1.0")
    bound = allowed_set(third, "Act", {"u": 0.0, "v": 0.0}).intervals[0].high
    assert bound == Fraction(1, 3)  # exact, not 0.333…
    assert str(allowed_set(third, "Act", {"u": 0.0, "v": 0.0})) == "a ∈ (-∞, 0.3333333333333333…]"
    assert allowed_set(machine("a = u + 1.0"), "Act", {"u": 2.0, "v": 0.0}).intervals[0].low == 3
    none = allowed_set(machine("a > v & a < u"), "Act", {"u": 0.0, "v": 1.0})
    assert none.intervals == () and str(none) == "a ∈ ∅" and none.nearest({"a": 0.0}) is None


def test_a_float_state_value_is_taken_exactly():
    m = machine("a <= u")
    allowed = allowed_set(m, "Act", {"u": 0.1, "v": 0.0})
    assert allowed.intervals[0].high == Fraction(0.1)  # the double 0.1, not 1/10
    assert allowed.contains({"a": 0.1}) and not allowed.contains({"a": math.nextafter(0.1, 1)})


def test_where_float_arithmetic_refuses_the_exact_bound_the_nearest_point_steps_inside():
    m = machine("3.0 * a > v")
    state = {"u": 0.0, "v": 1.0}
    allowed = allowed_set(m, "Act", state)
    just_above = math.nextafter(1 / 3, 1)  # allowed over the reals; 3.0 * it rounds to 1.0
    assert allowed.contains_exact({"a": just_above})
    assert not allowed.contains({"a": just_above}) and not evaluator_holds(
        m, state, {"a": just_above})
    near = allowed.nearest({"a": 0.0})
    assert near["a"] > just_above and evaluator_holds(m, state, near)


def test_the_nearest_point_next_to_an_open_bound_is_inside():
    m = machine("a < 2.0")
    near = allowed_set(m, "Act", {"u": 0.0, "v": 0.0}).nearest({"a": 5.0})
    assert near == {"a": math.nextafter(2.0, -math.inf)} and evaluator_holds(
        m, {"u": 0.0, "v": 0.0}, near)


@pytest.mark.parametrize("text, why", [
    ("a * a < 4.0", "a product of two parameter terms"),
    ("u / a < 1.0", "a division by a parameter term"),
    ("a : {1.0, 2.0}", "the relation :"),
])
def test_a_guard_not_linear_in_its_parameters_is_refused(text, why):
    m = machine(text)
    with pytest.raises(UnsupportedError, match=f"the guard is not linear in its parameters: {why}"):
        allowed_set(m, "Act", {"u": 1.0, "v": 0.0})


def test_only_operations_with_real_parameters():
    m = machine("a > 0.0", extra=";\n  Go(n) = PRE n : NATURAL & n < 3 THEN skip END")
    assert real_parameters(m.operation("Act")) and not real_parameters(m.operation("Go"))
    with pytest.raises(UnsupportedError, match="no parameters typed `p : REAL`"):
        allowed_set(m, "Go", {"u": 0.0, "v": 0.0})


@pytest.mark.parametrize("rudder", ["rudder >= -1.0 & rudder <= 1.0",  # REAL by its use
                                    "rudder : INTEGER & rudder >= -1 & rudder <= 1"])
def test_an_operation_typing_some_parameters_real_is_refused_naming_the_others(rudder):
    """REAL parameters beside untyped or INTEGER ones: the enabled set is refused, state
    by state and in batch, naming the parameter not typed REAL (it had named the REAL
    one, "cannot enumerate thrust … its bound -1.0 is not an integer")."""
    from tracecheck.b import Columns

    m = load_machine_text(f"""MACHINE Boat
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS
  FIRE(thrust, rudder) = PRE thrust : REAL & thrust >= -1.0 & thrust <= 1.0 &
      {rudder} & x + thrust < 5.0 THEN x := x + thrust END;
  STOP = skip
END""", file="boat.mch")
    assert not real_parameters(m.operation("FIRE"))
    said = ("boat.mch:6:30: FIRE(thrust, rudder) types thrust REAL in its guard but not "
            "rudder: tracecheck decides an operation's REAL parameters as a continuous "
            "action only when its guard types every parameter so")
    for enabled in (lambda: m.enabled({"x": 0.0}),
                    lambda: m.enabled_batch(Columns.from_states([{"x": 0.0}]))):
        with pytest.raises(UnsupportedError) as e:
            enabled()
        assert str(e.value).startswith(said)
        assert e.value.hint == ("add `rudder : REAL` to the guard of FIRE, or make rudder "
                                "the parameters of another operation")
    assert m.enabled_batch(Columns.from_states([]))["STOP"].shape == (0,)
    fixed = load_machine_text("""MACHINE M
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS SET(a, n) = PRE a : REAL & a = 0.5 & n : 0..2 & x + a < 1.0 THEN skip END
END""")  # a REAL parameter the guard fixes is enumerated, as before
    assert fixed.enabled({"x": 0.0}) == {"SET"} and fixed.enabled({"x": 0.7}) == set()
    assert fixed.enabled_batch(Columns.from_states([{"x": 0.0}, {"x": 0.7}]))["SET"].tolist() \
        == [True, False]
    # a state variable typed REAL in the guard, or an enumeration of something else: what
    # the evaluator says stands (it was blamed on the parameters, with an empty REAL list)
    for op in ("Go(n) = PRE x : REAL & n : INTEGER & n > 0 THEN skip END",
               "Set(a, n) = PRE a : REAL & a = 0.5 & n : 0..2 & #k.(k : INTEGER & k > n) "
               "THEN skip END"):
        other = load_machine_text("MACHINE M VARIABLES x INVARIANT x : REAL INITIALISATION "
                                  f"x := 0.0 OPERATIONS {op} END")
        with pytest.raises(TracecheckError) as e:
            other.enabled({"x": 0.0})
        assert "types" not in e.value.message and "cannot enumerate" in e.value.message


ACC = '''MACHINE Acc
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL
INITIALISATION Gap, Speed := 50.0, 20.0
OPERATIONS
  Accelerate(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 & Gap - (Speed + a) * 1.5 > 10.0
                  THEN Speed := Speed + a END;
  Steer(a, s) = PRE a : REAL & s : REAL & a >= -1.0 & a <= 1.0 & s * 2.0 <= Gap - 30.0 &
                    s >= -0.5 THEN skip END;
  Brake = PRE Speed > 0.0 THEN Speed := 0.0 END
END'''


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 80).map(float), st.integers(0, 40).map(float)),
                min_size=1, max_size=12))
def test_enabled_decides_real_parameters_alike_state_by_state_and_in_batch(rows):
    from tracecheck.b import Columns

    m = load_machine_text(ACC)
    states = [{"Gap": g, "Speed": v} for g, v in rows]
    batch = m.enabled_batch(Columns.from_states(states))
    for i, state in enumerate(states):
        enabled = m.enabled(state)
        assert {op for op, ok in batch.items() if ok[i]} == enabled
        allowed = m.allowed("Accelerate", state)
        assert ("Accelerate" in enabled) == (allowed.witness() is not None)
        # over the reals: some a in [-4, 2] with Gap - (Speed + a) * 1.5 > 10
        assert ("Accelerate" in enabled) == (state["Gap"] - (state["Speed"] - 4.0) * 1.5 > 10.0)


@pytest.mark.parametrize("guard, expected", [
    # "any acceleration up to 0.5, or full braking": the braking box lies in the other one
    ("a >= -1.0 & s >= -0.5 & s <= 0.5 & (a <= 0.5 or a = -1.0)",
     {"a": "[-1.0, 0.5]", "s": "[-0.5, 0.5]"}),
    # two boxes, neither holding the other: no band to draw
    ("s >= -0.5 & s <= 0.5 & ((a >= 0.0 & a <= 1.0) or (a >= -1.0 & a <= 0.5 & s >= 0.0))",
     None),
])
def test_bands_of_a_union_of_boxes_where_one_holds_the_others(guard, expected):
    m = machine(guard, "a, s")
    bands = allowed_set(m, "Act", {"u": 0.0, "v": 0.0}).bands()
    assert (None if bands is None else
            {p: " ∪ ".join(str(i) for i in found) for p, found in bands.items()}) == expected


def test_a_guard_of_many_disjuncts_is_refused_fast_and_without_a_recursion_error():
    """1500 disjuncts took 19 s to refuse (free_names asked at every level, 18 M calls)
    and, called from a program of one's own, hit Python's recursion limit."""
    import time

    def guard(n):
        return " or ".join(f"(a > {2 * i}.0 & a < {2 * i + 1}.0)" for i in range(n))
    start = time.perf_counter()
    with pytest.raises(UnsupportedError, match="more than 256 cases"):
        allowed_set(machine(guard(1500)), "Act", {"u": 0.0, "v": 0.0})
    assert time.perf_counter() - start < 2.0
    allowed = allowed_set(machine(guard(250)), "Act", {"u": 0.0, "v": 0.0})
    assert len(allowed.intervals) == 250 and allowed.contains({"a": 498.5})


def test_a_quantifier_over_a_parameter_is_refused_in_the_users_words():
    """A parameter inside a quantifier is refused naming it as the user wrote it (not the
    parser's class name), the docs saying how to write it linear (a min over the set)."""
    m = load_machine_text("""MACHINE Q
VARIABLES X, Obstacles
INVARIANT X : REAL & Obstacles : POW(REAL)
INITIALISATION X := 0.0 || Obstacles := {5.0}
OPERATIONS
  MOVE(a) = SELECT a : REAL & a >= -1.0 & a <= 1.0 & !o.(o : Obstacles & o > X => X + a < o)
            THEN X := X + a END
END""")
    with pytest.raises(UnsupportedError, match=r"a quantifier \(! or #\) over a parameter in "
                                               r"`!o\.\(o : Obstacles"):
        allowed_set(m, "MOVE", {"X": 0.0, "Obstacles": frozenset({5.0})})


def test_an_allowed_set_a_few_floats_wide_at_an_open_end_projects_onto_an_allowed_float():
    """A new user's tank: `Level + Inflow - flow > 15.0` at Level = 15.000000000000002 allows
    [0.0, 1.8e-15) over the reals, but the evaluator's rounding refuses its middle and its
    open end: the live shield said "undecided" and took the fallback (5.0, refused), where
    0.0 and the floats up to 8.9e-16 are allowed. The closed end anchors the search."""
    m = load_machine_text("""MACHINE Tank
VARIABLES Level, Inflow
INVARIANT Level : REAL & Inflow : REAL
INITIALISATION Level, Inflow := 50.0, 0.0
OPERATIONS PUMP(flow) = PRE flow : REAL & flow >= 0.0 & flow <= 10.0 &
    Level + Inflow - flow > 15.0 THEN skip END
END""")
    state = {"Level": 15.000000000000002, "Inflow": 0.0}
    allowed = allowed_set(m, "PUMP", state)
    found = allowed.nearest({"flow": 1.5717679262161255})
    assert found is not None and allowed.contains(found)
    # the allowed float nearest the proposal: the next float up is refused
    assert 15.000000000000002 + 0.0 - found["flow"] > 15.0
    assert not 15.000000000000002 + 0.0 - math.nextafter(found["flow"], 1.0) > 15.0
    assert found["flow"] == pytest.approx(8.881784197001252e-16, rel=1e-9)
    assert allowed.witness() is not None
    # a proposal beyond the floats' squares: no OverflowError
    assert allowed.nearest({"flow": 1e200}) == found


def test_a_closed_end_anchors_only_within_its_own_box():
    """From a review: an anchor moving one parameter to a closed end and leaving the other
    outside the box was allowed through the guard's other case, and the projection ended
    there — 121 away where (10 - 1 float, b + 1) is 2 away."""
    m = load_machine_text("""MACHINE Two
VARIABLES X, Y, T
INVARIANT X : REAL & Y : REAL & T : REAL
INITIALISATION X, Y, T := 0.0, 0.0, 0.0
OPERATIONS Act(a, b) = PRE a : REAL & b : REAL &
  ((a >= 0.0 & a < 10.0 & X - b + Y <= T & b <= 200.0) or
   (a <= 0.0 & b >= -200.0 & b <= 200.0)) THEN skip END
END""")
    allowed = allowed_set(m, "Act", {"X": 48.4498722612494, "Y": 98.55082298257977,
                                     "T": 23.464043487103847})
    point = {"a": 11.0, "b": 122.53665175672533}
    found = allowed.nearest(point)
    assert allowed.contains(found)
    assert sum((found[p] - point[p]) ** 2 for p in point) == pytest.approx(2.0)


def test_an_empty_set_whose_closure_holds_a_point_is_undecided_without_claiming_values():
    """a - b > 1 & a + b <= 1 & b >= 0 is empty (only its closure holds (1, 0)): tracecheck
    cannot prove that here, so it is undecided — and the reason no longer says the guard
    allows values over the reals (a new user's Steer)."""
    m = load_machine_text("""MACHINE S VARIABLES speed INVARIANT speed : REAL
INITIALISATION speed := 0.0
OPERATIONS Steer(a, b) = PRE a : REAL & b : REAL & a >= 0.0 & b >= 0.0 & a + b <= 1.0 &
  a - b > 0.5 * speed THEN skip END END""")
    with pytest.raises(UnsupportedError) as info:
        allowed_set(m, "Steer", {"speed": 2.0}).witness()
    assert "allows values over the reals" not in info.value.message
    assert "with < read as <=, hold points" in info.value.message
