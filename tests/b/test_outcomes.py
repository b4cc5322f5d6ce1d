"""CASE, VAR, WHILE and a sequence whose first part is not deterministic (issue 43): every
outcome listed (tracecheck.b.outcomes), checked on the scalar path and, where the operation
has a before-after predicate (CASE), on the batch path row by row; a loop whose INVARIANT
fails or whose VARIANT does not decrease is an error naming the loop, never a verdict."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tracecheck.b import load_machine_text
from tracecheck.b.columns import Columns, step_pairs
from tracecheck.b.outcomes import MAX_ITERATIONS
from tracecheck.errors import BSyntaxError, UnsupportedError, WellDefinednessError

LOOPS = """MACHINE Loops
VARIABLES total, n, mode
INVARIANT total : NATURAL & n : 0..10 & mode : 1..3
INITIALISATION total := 0 || n := 3 || mode := 1
OPERATIONS
  Sum = VAR i, acc IN
          i := 0; acc := 0;
          WHILE i < n DO
            i := i + 1; acc := acc + i
          INVARIANT i : 0..n & acc = i * (i + 1) / 2
          VARIANT n - i
          END;
          total := acc
        END;
  Pick(k) = PRE k : 1..3 THEN
    CASE k OF
      EITHER 1 THEN mode := 2
      OR 2, 3 THEN mode := 3
    END END
  END;
  Step = CASE mode OF EITHER 1 THEN n := n + 1 OR 2 THEN n := 0 ELSE skip END END;
  Strict = CASE mode OF EITHER 1 THEN n := 5 END END;
  Guess = BEGIN ANY x WHERE x : 1..2 THEN n := x END ; total := total + n END;
  Swap = VAR t IN t := n; n := mode; mode := t END
END"""

START = {"total": 0, "n": 3, "mode": 1}


@pytest.fixture(scope="module")
def loops():
    return load_machine_text(LOOPS, file="loops.mch")


def test_a_while_loop_inside_var_computes_its_sum(loops):
    assert loops.check_after("Sum", START, {**START, "total": 6})
    assert not loops.check_after("Sum", START, {**START, "total": 5})
    assert loops.check_after("Sum", {**START, "n": 0}, {**START, "n": 0, "total": 0})
    assert loops.successor("Sum", START, loops.parse("total = 6")).state["total"] == 6


def test_var_locals_never_reach_the_state(loops):
    assert loops.check_after("Swap", {**START, "n": 2}, {**START, "n": 1, "mode": 2})
    assert not loops.check_after("Swap", {**START, "n": 2}, {**START, "n": 2, "mode": 1})


def test_case_takes_the_branch_of_the_value_and_else(loops):
    assert loops.allows("Pick", START, {"k": 2}) and not loops.allows("Pick", START, {"k": 4})
    for mode in (2, 3):  # some k gives each
        assert loops.check_after("Pick", START, {**START, "mode": mode}) is True
    assert not loops.check_after("Pick", START, START)
    assert loops.check_after("Step", START, {**START, "n": 4})
    assert loops.check_after("Step", {**START, "mode": 2}, {**START, "mode": 2, "n": 0})
    assert loops.check_after("Step", {**START, "mode": 3}, {**START, "mode": 3})
    assert not loops.check_after("Step", {**START, "mode": 3}, {**START, "mode": 3, "n": 4})


def test_case_without_else_blocks_a_value_in_no_branch(loops):
    # the B book's CASE without ELSE: a SELECT on the listed values
    assert loops.is_enabled("Strict", START)
    assert not loops.is_enabled("Strict", {**START, "mode": 2})
    assert "mode : {1}" in loops.operation("Strict").guard_source.replace("(", "").replace(
        ")", "")


def test_case_on_the_batch_path_agrees_with_the_scalar_path_on_every_row(loops):
    states = [{"total": 0, "n": n, "mode": m} for n, m in itertools.product(range(0, 6),
                                                                              (1, 2, 3))]
    rows = [(a, b) for a, b in itertools.product(states, states)]
    flat = [s for a, b in rows for s in (a, b)]
    cols = Columns.from_states(flat)
    pairs = step_pairs(cols, np.arange(1, len(flat), 2))
    for op in ("Step", "Strict"):
        batch = loops.postcondition_batch(op, pairs)
        assert batch is not None  # CASE has a before-after predicate
        scalar = [loops.effect_ok(op, a, b) for a, b in rows]
        assert batch.tolist() == scalar and any(scalar) and not all(scalar)


def test_a_nondeterministic_first_part_of_a_sequence_has_every_outcome(loops):
    got = [loops.check_after("Guess", START, {**START, "total": t, "n": n})
           for t, n in ((1, 1), (2, 2), (3, 3), (2, 1))]
    assert got == [True, True, False, False]
    assert loops.successor("Guess", START, loops.parse("total = 2")).state["n"] == 2


def loop_machine(body: str) -> str:
    return f"""MACHINE L
VARIABLES x
INVARIANT x : INTEGER
INITIALISATION x := 0
OPERATIONS
  Run = {body}
END"""


@pytest.mark.parametrize("body,message", [
    ("WHILE x < 3 DO x := x + 1 INVARIANT x <= 2 VARIANT 3 - x END",
     r"the INVARIANT of the WHILE loop at line 6 is false after 3 iteration\(s\)"),
    ("WHILE x < 3 DO x := x + 1 INVARIANT x <= 3 VARIANT x END",
     "the VARIANT of the WHILE loop at line 6 does not decrease at iteration 1"),
    ("WHILE x < 3 DO x := x + 1 INVARIANT x <= 3 VARIANT 1 - x END",
     r"the VARIANT of the WHILE loop at line 6 is -1 < 0 after 2 iteration\(s\)"),
])
def test_a_loop_that_breaks_its_invariant_or_variant_is_an_error_naming_it(body, message):
    m = load_machine_text(loop_machine(body), file="l.mch")
    with pytest.raises(WellDefinednessError, match=message) as err:
        m.check_after("Run", {"x": 0}, {"x": 3})
    assert err.value.line == 6


def test_a_loop_over_the_iteration_limit_is_refused_not_answered():
    body = "WHILE x < 10000000 DO x := x + 1 INVARIANT x : NATURAL VARIANT 10000000 - x END"
    m = load_machine_text(loop_machine(body), file="l.mch")
    with pytest.raises(UnsupportedError, match=f"more than {MAX_ITERATIONS:,} iterations"):
        m.check_after("Run", {"x": 0}, {"x": 10000000})


def test_a_guard_inside_a_loop_is_refused_at_load():
    body = ("WHILE x < 3 DO SELECT x > 0 THEN x := x + 1 END INVARIANT x <= 3 "
            "VARIANT 3 - x END")
    with pytest.raises(UnsupportedError, match="a guard .* inside a WHILE's body"):
        load_machine_text(loop_machine(body), file="l.mch")


def test_while_keywords_inside_an_operation_are_not_clauses():
    # the loop's INVARIANT must not end the OPERATIONS clause; the machine's still counts
    m = load_machine_text(loop_machine(
        "WHILE x < 2 DO x := x + 1 INVARIANT x <= 2 VARIANT 2 - x END"), file="l.mch")
    assert m.check_after("Run", {"x": 0}, {"x": 2}) and m.invariant({"x": 2})
    with pytest.raises(BSyntaxError, match="expected"):
        load_machine_text(loop_machine("WHILE x < 2 DO x := x + 1 VARIANT 2 - x END"),
                          file="l.mch")


GUARDS = "MACHINE G VARIABLES c, s INVARIANT c : INTEGER & s : INTEGER " \
         "INITIALISATION c := 0 || s := 0 OPERATIONS Op = {} END"
POINTS = [{"c": c, "s": s} for c in (-1, 0, 1, 4) for s in (0, 1, 3)]


@pytest.mark.parametrize("body,enabled", [
    # IF: the first branch whose condition holds; no ELSE: skip
    ("IF c > 0 THEN SELECT s > 2 THEN s := 0 END ELSE s := 1 END",
     lambda c, s: c <= 0 or s > 2),
    ("CHOICE SELECT c > 3 THEN s := 1 END OR PRE c < 0 THEN s := 2 END END",
     lambda c, s: c > 3 or c < 0),
    ("SELECT c = 0 THEN SELECT s = 1 THEN s := 2 END ELSE skip END",
     lambda c, s: c != 0 or s == 1),
    ("CASE c OF EITHER 0 THEN SELECT s = 1 THEN s := 2 END OR 1 THEN skip END END",
     lambda c, s: (c == 0 and s == 1) or c == 1),
])
def test_guards_inside_if_choice_and_select_else_count(body, enabled):
    m = load_machine_text(GUARDS.format(body), file="g.mch")
    got = [m.is_enabled("Op", p) for p in POINTS]
    assert got == [enabled(p["c"], p["s"]) for p in POINTS]
    batch = m.enabled_batch(Columns.from_states(POINTS))["Op"].tolist()
    assert batch == got
    # where enabled, some step is possible; where not, none
    for p, on in zip(POINTS, got):
        steps = [m.check_after("Op", p, {"c": p["c"], "s": s}) for s in (0, 1, 2, 3)]
        assert any(steps) == on, (body, p)


@pytest.mark.parametrize("body", [
    "BEGIN c := 1 ; SELECT c > 5 THEN s := 1 END END",
    "BEGIN c :: 1..3 ; PRE c > 5 THEN s := 1 END END",
    "VAR t IN t := 1 ; ANY q WHERE q : 1..t THEN s := q END END",
    "VAR i IN i := 0; WHILE i < 3 DO SELECT i < 1 THEN i := i + 1 END INVARIANT i : 0..3 "
    "VARIANT 3 - i END; s := i END",
])
def test_a_guard_after_a_sequence_or_inside_a_loop_is_refused_at_load(body):
    # it would be left out of the operation's guard: enabled, and no step possible
    with pytest.raises(UnsupportedError, match="after `;`|inside a WHILE's body") as err:
        load_machine_text(GUARDS.format(body), file="g.mch")
    assert err.value.file == "g.mch" and err.value.line == 1


def test_outputs_are_not_part_of_the_state_checked():
    m = load_machine_text("MACHINE C VARIABLES x INVARIANT x : 0..5 INITIALISATION x := 0 "
                          "OPERATIONS v <-- Get = v := x; w <-- Pick = w :: 1..x END")
    assert m.check_after("Get", {"x": 1}, {"x": 1}) and not m.check_after("Get", {"x": 1},
                                                                          {"x": 2})
    assert m.check_after("Pick", {"x": 1}, {"x": 1})
    assert not m.check_after("Pick", {"x": 0}, {"x": 0})  # 1..0 is empty: no step
