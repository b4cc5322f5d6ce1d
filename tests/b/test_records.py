"""Records (rec, struct, r'a), identifiers as ProB's lexer reads them (Unicode letters,
back-quotes) and the elements S1, S2, … of deferred sets named in formulas."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tracecheck import errors as E
from tracecheck.b import ast as A
from tracecheck.b.columns import Columns
from tracecheck.b.evaluation import evaluate
from tracecheck.b.machine import load_machine_text
from tracecheck.b.notation import parse_literal, to_json
from tracecheck.b.parser import parse_formula
from tracecheck.b.printer import to_b
from tracecheck.b.typecheck import check_formula, describe_value_type
from tracecheck.b.values import Elem, Record, format_value
from tracecheck.b.vector import BatchFormula


def value(text: str, env: dict | None = None):
    node, _ = check_formula(text, {}, file="<test>")
    return evaluate(node, env or {}, source=text)


@pytest.mark.parametrize("text", [
    "rec(a: 1, b: TRUE)", "r'a + 1", "struct(a: INTEGER, b: BOOL)", "rec(a: rec(b: 1))'a'b",
    "f(x)'b", "x' > x$0", "δ + Σ", "`my name` + 1", "`TRUE` = `rec`", "x₁′ * 2",
    "!`a b`.(`a b` : S => 1 = 1)", "rec(`a b`: 1)'`a b`",
])
def test_printing_then_parsing_gives_the_same_tree(text):
    node = parse_formula(text)
    assert parse_formula(to_b(node)) == node


def test_the_parser_builds_records_fields_and_primes():
    assert parse_formula("rec(a: 1)") == A.Record((("a", A.IntLit(1)),))
    assert parse_formula("r'a") == A.Field(A.Name("r"), "a")
    assert parse_formula("x'") == A.Name("x'")
    assert parse_formula("`x`") == A.Name("x")  # a back-quoted name is the same name
    assert parse_formula("Σ") == A.Name("Σ")  # a Greek letter, as in ProB; SIGMA is ∑
    with pytest.raises(E.BSyntaxError, match="appears twice"):
        parse_formula("rec(a: 1, a: 2)")
    with pytest.raises(E.BSyntaxError, match="only a name may be primed"):
        parse_formula("f(x)' > 1")
    with pytest.raises(E.BSyntaxError):
        parse_formula("ℕx")  # ℕ is the set's symbol, never the start of a name


def test_records_compare_and_print_as_prob_does():
    assert format_value(value("rec(b: TRUE, a: 1)")) == "rec(a:1,b:TRUE)"
    assert value("rec(b: 2, a: 1) = rec(a: 1, b: 2)") is True
    assert value("rec(a: 1, b: TRUE)'a") == 1
    assert value("card(struct(a: BOOL, b: 1..3))") == 6
    assert format_value(value("struct(a: INTEGER)")) == "struct(a:INTEGER)"
    assert value("rec(a: 5) : struct(a: INTEGER)") is True
    assert value("{r | r : struct(a: 1..3) & r'a > 1}") == {Record([("a", 2)]),
                                                           Record([("a", 3)])}


@pytest.mark.parametrize("text,message", [
    ("rec(a: 1)'b", "has no field b"),
    ("rec(a: 1) = rec(a: TRUE)", "struct(a:INTEGER) vs struct(a:BOOL)"),
    ("(1 |-> 2)'a", "is not a record"),
    ("struct(a: 1)", "a struct field is a set"),
    ("{r | r'a > 0 & r : struct(a: INTEGER)}", "must be known before its field a"),
])
def test_type_errors_are_located(text, message):
    with pytest.raises(E.BTypeError, match=re.escape(message)) as info:
        check_formula(text, {}, file="<test>")
    assert info.value.line == 1


def test_record_literals_read_back_in_state_files():
    for text in ("rec(a:1,b:TRUE)", "{rec(x:1.5),rec(x:2.0)}", "rec(s:\"t\",p:(1↦2))",
                 "rec(`my f`:{1,2})"):
        v = parse_literal(text)
        assert parse_literal(format_value(v)) == v
        assert parse_literal(to_json(v)) == v
    assert parse_literal("rec(b:2, a:1)") == Record([("a", 1), ("b", 2)])
    assert describe_value_type(parse_literal("rec(a:1,b:TRUE)")) == "struct(a:INTEGER,b:BOOL)"
    with pytest.raises(E.BSyntaxError):
        parse_literal("rec(a:1,a:2)")


MACHINE = """MACHINE Records
SETS PID; NODES; Vehicles
CONSTANTS Ego
PROPERTIES card(NODES) = 60 & card(Vehicles) = 3 & Ego : Vehicles
VARIABLES owner, r
INVARIANT owner : PID & r : struct(a: INTEGER, b: BOOL)
INITIALISATION owner := PID1 || r := rec(a: 1, b: TRUE)
OPERATIONS
  Next = PRE owner = PID1 & r'a > 0 THEN
    owner := PID2 || r := rec(a: r'a + 1, b: bool(r'b = FALSE)) END
END
"""


@pytest.fixture(scope="module")
def machine():
    return load_machine_text(MACHINE, file="records.mch")


def test_deferred_set_elements_are_usable_in_formulas(machine):
    state = {"owner": Elem("PID1"), "r": Record([("a", 1), ("b", True)])}
    assert machine.invariant(state)
    for text in ("owner = PID1", "PID2 : PID", "NODES51 : NODES", "Vehicles3 /= Ego",
                 "r = rec(b: TRUE, a: 1)"):
        assert machine.compile(machine.check_formula(text, file="<e>"))(machine.env(state))
    after = {"owner": Elem("PID2"), "r": Record([("a", 2), ("b", False)])}
    assert machine.check_after("Next", state, after)
    assert not machine.check_after("Next", state, {**after, "r": Record([("a", 2), ("b", True)])})


@pytest.mark.parametrize("text,hint", [
    ("PID3 : PID", "PID1, PID2"),
    ("NODES61 = NODES1", "NODES1, NODES2, …, NODES60"),
    ("Vehicles1 = Ego", "takes the place of one"),  # the constant Ego has that place
])
def test_elements_beyond_a_sets_size_are_refused(machine, text, hint):
    with pytest.raises(E.BScopeError) as info:
        machine.check_formula(text, file="<e>")
    assert hint in info.value.hint


def test_batch_path_agrees_with_the_scalar_path_on_records(machine):
    states = [{"owner": Elem(o), "r": Record([("a", a), ("b", b)])}
              for o, a, b in [("PID1", 1, True), ("PID2", -3, False), ("PID1", 0, True)]]
    cols = Columns.from_states(states, (Elem("PID1"), Elem("PID2")))
    for text in ("r'a > 0 & owner = PID1", "r : struct(a: NATURAL, b: BOOL)", "r'b = TRUE"):
        node = machine.check_formula(text, file="<e>")
        batch = BatchFormula(node, machine.base_env, source=text)(cols)
        scalar = [machine.compile(node, source=text)(machine.env(s)) for s in states]
        assert [bool(v) for v in np.asarray(batch)] == scalar


def test_a_back_quoted_name_declared_as_a_variable():
    from tracecheck.b import load_machine_text

    m = load_machine_text("""MACHINE BQ
VARIABLES `my v`
INVARIANT `my v` : 0..10
INITIALISATION `my v` := 3
OPERATIONS inc = SELECT `my v` < 10 THEN `my v` := `my v` + 1 END
END""")
    assert m.variables == ("my v",)
    assert m.enabled({"my v": 4}) == {"inc"} and m.enabled({"my v": 10}) == set()
