"""Where the engine could not tell, it says so: the wrong answers a second oracle and new
users found (issue 40), each a FALSE that was in truth TRUE or unknown."""

from __future__ import annotations

import pytest

from tracecheck.b.evaluation import evaluate
from tracecheck.b.machine import load_machine_text
from tracecheck.b.parser import parse_formula
from tracecheck.b.spaces import covers
from tracecheck.b.transitions import initial_state_ok
from tracecheck.b.values import Elem, FuncValue, Interval
from tracecheck.errors import EvaluationError, UnsupportedError


def ev(text, state=None):
    return evaluate(parse_formula(text), state or {}, source=text)


def seq(*items):
    return FuncValue({k + 1: v for k, v in enumerate(items)})


@pytest.mark.parametrize("text", [
    "[[1,2],[2,1]] : perm(perm({1,2}))",
    "{(0|->[1,2]),(1|->[2,1])} : {0,1} -->> perm({1,2})",
    "{([1,2]|->0),([2,1]|->0)} : perm({1,2}) --> {0}",
    "[[2,1],[1,2]] : iseq(perm({1,2}))",
    "card(perm({1,2})) = 2 & card(perm({1,2,3})) = 6",
    "card(iseq({1,2,3})) = 16 & card(iseq1({1,2,3})) = 15",
    "card(seq({})) = 1 & card(seq1({})) = 0 & card(perm({})) = 1",
    "perm({1,2}) = {[1,2],[2,1]}",
    "iseq1({7}) = {[7]}",
])
def test_sets_of_sequences_over_finite_sets_are_finite(text):
    assert ev(text) is True


def test_perm_of_perm_with_enumerated_elements():
    a, b = Elem("a"), Elem("b")
    state = {"S": frozenset({a, b}), "s": seq(seq(b, a), seq(a, b))}
    assert ev("s : perm(perm(S))", state) is True
    assert ev("s : perm(perm(S)) & s : iseq(perm(S))", state) is True
    assert ev("[[a,b],[a,b]] : perm(perm(S))", dict(state, a=a, b=b)) is False


@pytest.mark.parametrize("text", ["[1,2] : perm(NATURAL)", "{} : NATURAL -->> {1}"])
def test_an_infinite_set_is_never_covered(text):
    assert ev(text) is False


def test_a_set_not_known_to_be_finite_is_not_called_infinite():
    class Unknown(Interval):  # a set whose finiteness tracecheck cannot tell
        def finiteness(self):
            return None
    with pytest.raises(EvaluationError, match="cannot tell whether .* is finite"):
        covers({1, 2}, Unknown(1, 2))
    with pytest.raises(EvaluationError, match="cannot tell whether the set seq"):
        ev("card(seq(s))", {"s": Unknown(1, 2)})


PYTHAGORAS = """MACHINE Pyth
VARIABLES xx
INVARIANT xx : INTEGER
INITIALISATION BEGIN xx := 1; ANY r1, r2 WHERE r1 : NAT & r2 : NAT & r1*r1 + r2*r2 = 25
  THEN xx := r1 + r2 END END
END
"""


@pytest.mark.parametrize("value", [5, 7, 6])
def test_an_initialisation_it_cannot_walk_is_a_refusal_not_false(value):
    machine = load_machine_text(PYTHAGORAS, file="Pyth.mch")
    with pytest.raises(UnsupportedError,
                       match="cannot tell whether the INITIALISATION can give this state"):
        initial_state_ok(machine, {"xx": value})


def test_a_walkable_initialisation_still_answers():
    machine = load_machine_text(PYTHAGORAS.replace("r1 : NAT & r2 : NAT",
                                                   "r1 : 0..10 & r2 : 0..10"), file="P.mch")
    assert [initial_state_ok(machine, {"xx": v}) for v in (5, 7, 6)] == [True, True, False]
