"""Property tests: printing and parsing agree; random text only raises tracecheck's errors."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from tracecheck.b import ast as A
from tracecheck.b.machine import load_machine_text
from tracecheck.b.parser import parse_formula, parse_machine_source
from tracecheck.b.printer import to_b
from tracecheck.b.notation import parse_literal
from tracecheck.b.values import Elem, FuncValue, format_value
from tracecheck.errors import BSyntaxError, TracecheckError

names = st.sampled_from(["x", "y", "S", "f", "VehiclesX", "EgoVehicle"]).map(A.Name)
numbers = st.one_of(
    st.integers(min_value=0, max_value=10**6).map(A.IntLit),
    st.floats(min_value=0, max_value=1e9, allow_nan=False).map(A.RealLit),
)
leaves = st.one_of(names, numbers, st.booleans().map(A.BoolLit))
ids = st.sampled_from([("v",), ("v", "w")])


def exprs(children):
    return st.one_of(
        st.builds(A.BinOp, st.sampled_from(["+", "-", "*", "/", "mod", "**", "..", "\\/",
                                            "/\\", "\\", "-->", "+->", "<+", "<|"]),
                  children, children),
        st.builds(A.Neg, children),
        st.builds(A.Pair, children, children),
        st.builds(A.Apply, names, st.lists(children, min_size=1, max_size=2).map(tuple)),
        st.builds(A.Call, st.sampled_from(["card", "dom", "min", "RSQRT", "POW"]),
                  children.map(lambda c: (c,))),
        st.builds(A.SetExt, st.lists(children, max_size=3).map(tuple)),
        st.builds(A.Image, names, children),
        st.builds(A.Inverse, names),
    )


expressions = st.recursive(leaves, exprs, max_leaves=8)


def preds(children):
    rel = st.builds(A.Rel, st.sampled_from(["=", "/=", "<", "<=", ">", ">=", ":", "/:", "<:",
                                            "<<:", "/<:", "/<<:"]), expressions, expressions)
    return st.one_of(
        rel,
        st.builds(A.And, children, children),
        st.builds(A.Or, children, children),
        st.builds(A.Implies, children, children),
        st.builds(A.Equiv, children, children),
        st.builds(A.Not, children),
        st.builds(A.Quant, st.sampled_from(["!", "#"]), ids, children),
        st.builds(A.Comprehension, ids, children, st.none() | expressions).map(
            lambda c: A.Rel(":", A.Name("x"), c)),
        st.builds(A.Lambda, ids, children, expressions).map(lambda c: A.Rel("=", c, c)),
        st.builds(A.IfExpr, st.lists(st.tuples(children, expressions), min_size=1,
                                     max_size=2).map(tuple), expressions).map(
            lambda c: A.Rel("<", c, A.IntLit(1))),
        st.builds(A.Call, st.just("bool"), children.map(lambda c: (c,))).map(
            lambda c: A.Rel("=", c, A.BoolLit(True))),
    )


predicates = st.recursive(
    st.builds(A.Rel, st.sampled_from(["=", "<", ":"]), expressions, expressions), preds,
    max_leaves=6)


@settings(max_examples=300, deadline=None)
@given(predicates)
def test_print_parse_round_trip(node):
    text = to_b(node)
    assert parse_formula(text) == node
    assert to_b(parse_formula(text)) == text


ALPHABET = st.sampled_from(list("xyS01.(){}[],;:=<>-+*/\\|&!#%~' \n\"") +
                           ["or", "not", "IF", "THEN", "END", "∀", "↦", "MACHINE", "ℝ", "··"])


@settings(max_examples=400, deadline=None)
@given(st.lists(ALPHABET, max_size=25).map("".join))
def test_random_text_only_raises_our_errors(text):
    try:
        parse_formula(text)
    except TracecheckError:
        pass
    try:
        parse_machine_source("MACHINE M\nINVARIANT " + text + "\nEND")
    except TracecheckError:
        pass


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=30))
def test_random_literal_only_raises_syntax_errors(text):
    try:
        parse_literal(text)
    except BSyntaxError:
        pass


values = st.recursive(
    st.one_of(st.integers(-1000, 1000), st.booleans(),
              st.floats(allow_nan=False, allow_infinity=False, width=64),
              st.sampled_from(["EgoVehicle", "Vehicles2", "a"]).map(Elem)),
    lambda inner: st.one_of(
        st.tuples(inner, inner),
        st.frozensets(st.one_of(st.integers(0, 5), st.sampled_from([Elem("p"), Elem("q")])),
                      max_size=4),
        st.dictionaries(st.sampled_from([Elem("p"), Elem("q"), Elem("r")]),
                        st.floats(allow_nan=False, allow_infinity=False)).map(FuncValue),
        # integer and pair keys, nested maplets (ProB prints (0↦0)↦ICE as 0↦0↦ICE)
        st.dictionaries(st.one_of(st.integers(-3, 9),
                                  st.tuples(st.integers(0, 3), st.integers(0, 3))),
                        inner, max_size=4).map(FuncValue),
        st.frozensets(st.tuples(st.tuples(st.integers(0, 2), st.integers(0, 2)),
                                st.sampled_from([Elem("ICE"), Elem("HOLE")])), max_size=4),
        st.text(max_size=5),
    ),
    max_leaves=6)


@settings(max_examples=300, deadline=None)
@given(values)
def test_value_print_parse_round_trip(value):
    assert parse_literal(format_value(value)) == value


_VS = [Elem("EgoVehicle")] + [Elem(f"Vehicles{i}") for i in range(2, 6)]
STATE = {
    "Crash": False, "PresentVehicles": frozenset(_VS), "Reward": 0.0,
    **{name: FuncValue({v: float(10 * i) for i, v in enumerate(_VS)})
       for name in ("VehiclesX", "VehiclesY", "VehiclesVx", "VehiclesVy", "VehiclesAx",
                    "VehiclesAy")},
}
EXAMPLE = (Path(__file__).resolve().parents[2] / "models" / "shields" /
           "paper.mch").read_text()
PIECES = ["(", ")", "{", "}", "&", "or", "=>", ":", "=", "1", "1.0", "v", "END", "THEN", ";",
          "||", ":=", "::", "-", "..", "|", ".", "#", "card", "EgoVehicle", "TRUE", "'", "$0"]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.integers(0, len(EXAMPLE) - 1), st.sampled_from(PIECES + [""]),
                          st.integers(0, 6)), min_size=1, max_size=3))
def test_mutated_machine_only_raises_our_errors(edits):
    """Edits of a real shield: loading and evaluating raise tracecheck's errors or nothing."""
    text = EXAMPLE
    for pos, piece, cut in edits:
        text = text[:pos] + f" {piece} " + text[pos + cut:]
    try:
        machine = load_machine_text(text)
        machine.enabled(STATE)
        for name in machine.operations:
            machine.check_after(name, STATE, STATE)
    except TracecheckError:
        pass
