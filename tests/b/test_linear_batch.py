"""Margins over many states at once (tracecheck.b.linear_batch) against the exact, one state
at a time (tracecheck.b.linear): every decided row agrees, to float rounding."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tracecheck.b import load_machine_text
from tracecheck.b.columns import Columns
from tracecheck.b.linear import allowed_set
from tracecheck.b.linear_batch import batch_margins

NUM = st.integers(-6, 6).map(float) | st.sampled_from([0.5, -1.25, 0.1, 1 / 3, 1e-3])
REL = st.sampled_from(["<", "<=", ">", ">=", "/=", "="])


@st.composite
def atom(draw):
    return (f"({draw(NUM)}) * a + u * ({draw(NUM)}) {draw(REL)} v * ({draw(NUM)}) "
            f"+ ({draw(NUM)})")


@st.composite
def guard(draw, depth=2):
    if depth == 0 or draw(st.integers(0, 2)) == 0:
        return draw(atom()) if draw(st.integers(0, 4)) else f"u > {draw(NUM)}"
    op = draw(st.sampled_from(["&", "or", "=>", "<=>"]))
    text = f"({draw(guard(depth - 1))}) {op} ({draw(guard(depth - 1))})"
    return f"not({text})" if draw(st.booleans()) else text


def machine(text: str):
    return load_machine_text(f"""MACHINE G
VARIABLES u, v
INVARIANT u : REAL & v : REAL
INITIALISATION u, v := 0.0, 0.0
OPERATIONS Act(a) = PRE a : REAL & a >= -8.0 & ({text}) THEN skip END
END""")


VALUE = st.integers(-40, 40).map(lambda k: k / 4) | st.floats(-20, 20)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(guard(), st.lists(st.tuples(NUM, NUM, VALUE), min_size=1, max_size=10))
def test_decided_rows_are_the_exact_distance(text, rows):
    m = machine(text)
    cols = Columns.from_states([{"u": u, "v": v} for u, v, _ in rows])
    values = np.array([x for _, _, x in rows])
    distance, nothing, decided = batch_margins(m, "Act", cols, values)
    for i, (u, v, x) in enumerate(rows):
        if not decided[i]:
            continue
        exact = allowed_set(m, "Act", {"u": u, "v": v}).distance({"a": x})
        if exact is None:
            assert nothing[i], (text, u, v, x)
        else:
            assert not nothing[i] and abs(distance[i] - exact) <= 1e-9 * (1 + abs(x)), \
                (text, u, v, x, distance[i], exact)


def test_most_rows_of_a_plain_guard_are_decided():
    m = machine("a <= u - 2.0 * v")
    cols = Columns.from_states([{"u": float(u), "v": 1.0} for u in range(100)])
    values = np.full(100, 200.0)  # outside in every state (a replayed infeasible step)
    distance, nothing, decided = batch_margins(m, "Act", cols, values)
    assert decided.all() and not nothing.any()
    assert distance[10] == 192.0  # a <= 8: 200 is 192 outside


def test_a_guard_it_cannot_build_leaves_every_row_to_the_exact_path():
    m = machine("a * a <= 4.0")
    cols = Columns.from_states([{"u": 0.0, "v": 0.0}])
    assert not batch_margins(m, "Act", cols, np.array([3.0]))[2].any()


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(guard(), st.lists(st.tuples(NUM, NUM, VALUE), min_size=1, max_size=10),
       st.tuples(st.integers(-8, 0), st.integers(0, 8)))
def test_decided_rows_within_an_action_space_are_the_exact_distance(text, rows, space):
    """Cut to an action space's closed bounds, as replay cuts to the run header's."""
    low, high = float(space[0]), float(space[1])
    m = machine(text)
    cols = Columns.from_states([{"u": u, "v": v} for u, v, _ in rows])
    values = np.array([min(max(x, low), high) for _, _, x in rows])  # recorded inside
    distance, nothing, decided = batch_margins(m, "Act", cols, values, (low, high))
    for i, (u, v, _) in enumerate(rows):
        if not decided[i]:
            continue
        within = allowed_set(m, "Act", {"u": u, "v": v}).within({"a": low}, {"a": high})
        exact = within.distance({"a": float(values[i])})
        if exact is None:
            assert nothing[i], (text, u, v, values[i], space)
        else:
            assert not nothing[i] and abs(distance[i] - exact) <= 1e-9 * (1 + abs(values[i])), \
                (text, u, v, values[i], space, distance[i], exact)
