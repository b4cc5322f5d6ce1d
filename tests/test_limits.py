"""The interpreter limits: raised only while the engine needs them, restored after (also
when threads need them at once), and library calls on deep formulas and long integers work
without the CLI around them."""

from __future__ import annotations

import sys
import threading

import pytest

from tracecheck.b.evaluation import evaluate
from tracecheck.b.parser import parse_formula
from tracecheck.b.printer import to_b
from tracecheck.jsontext import json_text
from tracecheck.limits import (MAX_DIGITS, RECURSION_LIMIT, deep_recursion, int_text,
                               long_integers)

DEEP = "not(" * 1500 + "x = 1" + ")" * 1500


def test_library_calls_on_a_deep_formula_leave_the_limits_as_they_were():
    before = sys.getrecursionlimit(), sys.get_int_max_str_digits()
    node = parse_formula(DEEP)
    assert evaluate(node, {"x": 1}) is True  # an even number of nots
    assert to_b(node).count("not(") == 1500
    assert (sys.getrecursionlimit(), sys.get_int_max_str_digits()) == before


def test_long_integers_as_json_without_the_cli():
    value = evaluate(parse_formula("2 ** 40000"), {})
    text = json_text({"v": value})
    assert text == '{"v": ' + int_text(value) + "}" and len(int_text(value)) == 12_042
    with pytest.raises(ValueError):  # Python's own limit outside: why long_integers exists
        str(value)


def test_prove_on_a_deeply_nested_guard_without_the_cli():
    pytest.importorskip("z3")
    from tracecheck.b.machine import load_machine_text
    from tracecheck.checking import prove

    guard = "not(" * 1200 + "x > 3" + ")" * 1200
    machine = load_machine_text(f"MACHINE M\nVARIABLES x\nINVARIANT x : 0..5\n"
                                f"INITIALISATION x := 0\nOPERATIONS\n  Inc = PRE {guard} "
                                f"THEN skip END\nEND\n", file="M.mch")
    (result,) = prove(machine, deadlock_free=True)
    assert result.status == "counterexample"
    assert sys.getrecursionlimit() < RECURSION_LIMIT


def test_threads_holding_a_limit_at_once_do_not_restore_it_under_each_other():
    old = sys.getrecursionlimit()
    assert old < RECURSION_LIMIT
    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def first():
        with deep_recursion():
            first_in.set()
            second_in.wait(5)
        first_out.set()

    def second():
        first_in.wait(5)
        with deep_recursion():
            second_in.set()
            first_out.wait(5)
            seen["inside after the first left"] = sys.getrecursionlimit()
    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert seen == {"inside after the first left": RECURSION_LIMIT}
    assert sys.getrecursionlimit() == old


def test_nested_and_repeated_entries_restore_the_original():
    old = sys.get_int_max_str_digits()
    with long_integers():
        with long_integers():
            assert sys.get_int_max_str_digits() == MAX_DIGITS
        assert sys.get_int_max_str_digits() == MAX_DIGITS
    assert sys.get_int_max_str_digits() == old
