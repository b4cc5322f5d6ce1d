"""z3 stopped at a wall-clock deadline: an interrupt that lands just after z3 finished must
not leave its context canceled (a flake of the full suite: reading the model of a
satisfiable question, or the next question, failed with "canceled")."""

from __future__ import annotations

import time

import pytest

from tracecheck.checking.deadline import interrupted_at

z3 = pytest.importorskip("z3")


def test_an_interrupt_after_the_check_leaves_the_model_readable():
    x = z3.Real("x")
    with interrupted_at(z3, 0.01):
        solver = z3.Solver()
        solver.add(x > 1)
        assert solver.check() == z3.sat
        model = solver.model()
        time.sleep(0.2)  # the deadline passes here, after the check
    assert z3.is_true(model.eval(x > 1, model_completion=True))
    again = z3.Solver()
    again.add(x > 2)
    assert again.check() == z3.sat


def test_an_interrupt_stops_a_long_question():
    a, b, c = z3.Ints("a b c")
    solver = z3.Solver()  # Fermat for n = 5 over the integers: z3 does not finish
    solver.add(a > 0, b > 0, c > 0, a ** 5 + b ** 5 == c ** 5)
    start = time.monotonic()
    with interrupted_at(z3, 0.5):
        verdict = solver.check()
    assert verdict == z3.unknown and time.monotonic() - start < 5
    assert z3.Solver().check() == z3.sat  # the next question runs
