"""Integer variables of comprehensions, quantifiers, card, SIGMA and PI bounded by
comparisons (``x > 0 & x < 4``) are walked over the interval those imply (issue 27): ProB's
answers, both evaluation paths; an unbounded or REAL variable stays refused, located."""

from __future__ import annotations

import numpy as np
import pytest

from tracecheck.b.columns import Columns
from tracecheck.b.evaluation import evaluate
from tracecheck.b.parser import parse_formula
from tracecheck.b.vector import BatchFormula
from tracecheck.errors import EvaluationError


def ev(text, state=None):
    return evaluate(parse_formula(text), state or {})


@pytest.mark.parametrize("text, expected", [
    ("{x | x > 0 & x < 4}", frozenset({1, 2, 3})),
    ("#x.(x > 2 & x < 4)", True),
    ("#x.(x > 2 & x < 3)", False),
    ("card({x | 10 < x & x <= 20})", 10),
    ("SIGMA(x).(x >= 1 & x <= 4 & x /= 2 | x)", 8),
    ("PI(x).(x >= 1 & x <= 4 | x)", 24),
    ("!x.(x > 0 & x < 5 => x * x < 25)", True),
    ("{x | x >= a & x <= b}", frozenset({3, 4, 5})),  # bounds from the state
    ("{x, y | x > 0 & x < 3 & y >= x & y <= 2}", frozenset({(1, 1), (1, 2), (2, 2)})),
    ("{x | x > 5 & x < 6}", frozenset()),  # an empty interval
    ("{x | x < 4 & x > 0 & x > 1 & x <= 9}", frozenset({2, 3})),  # the tightest bounds
    ("{x | x : INTEGER & x > 0 & x < 4}", frozenset({1, 2, 3})),  # not INTEGER: the range
    ("{x | x : NATURAL & x < 4}", frozenset({0, 1, 2, 3})),  # NATURAL gives x >= 0
    ("{x | x : NAT1 & x < 3}", frozenset({1, 2})),
    ("{x | x : NAT & x < 5}", frozenset({0, 1, 2, 3, 4})),  # ProB's answer (was refused)
    # a variable is planned once what it reads has values, whatever the order of the ids
    ("{x, y | x = y + 1 & y : 1..3}", frozenset({(2, 1), (3, 2), (4, 3)})),
    ("{x, y | y = 3 & x > 0 & x < y}", frozenset({(1, 3), (2, 3)})),
    # BOOL variables walk their type
    ("{a, b | a = TRUE or b = FALSE}", frozenset({(False, False), (True, False), (True, True)})),
    ("#a.(a = TRUE & a /= FALSE)", True),
])
def test_comparisons_bound_an_integer_variable(text, expected):
    assert ev(text, {"a": 3, "b": 5}) == expected


@pytest.mark.parametrize("text, fragment", [
    # listing them is refused (the set itself is held by its definition: defined.py)
    ("card({x | x > 0})", "cannot enumerate x in `{x|x > 0}`"),
    ("card({x | x > 0.5 & x < 4.0})", "its bound `0.5` is not an integer"),
    ("card({x | x : INTEGER & x > 0})", "cannot enumerate the infinite set INTEGER"),
    ("card({a, b | a /= b})", "cannot enumerate a in"),  # no type to walk
])
def test_an_unbounded_or_real_variable_is_refused(text, fragment):
    with pytest.raises(EvaluationError, match=fragment.replace("{", r"\{").replace("}", r"\}")
                       .replace("|", r"\|").replace(".", r"\.")):
        ev(text)


def test_the_batch_path_agrees_row_by_row():
    a, b = np.array([1, 3, 5, 7]), np.array([4, 3, 2, 9])
    cols = Columns(4, (), numbers={"a": a, "b": b})
    batch = BatchFormula(parse_formula("card({x | x >= a & x < b})"), {})(cols)
    assert list(batch) == [ev("card({x | x >= a & x < b})", {"a": int(p), "b": int(q)})
                           for p, q in zip(a, b)] == [3, 0, 0, 2]


def test_an_enumerated_sets_variable_walks_its_elements():
    from tracecheck.b import load_machine_text
    from tracecheck.b.values import Elem

    m = load_machine_text("""MACHINE Col
SETS COLOURS = {red, green, blue}
VARIABLES cur
INVARIANT cur : COLOURS
INITIALISATION cur := red
END""")
    state = {"cur": Elem("red")}
    assert m.evaluate("card({c, d | c /= d & c /= blue})", state) == 4
    assert m.evaluate("{c | c /= cur} = {green, blue}", state) is True
