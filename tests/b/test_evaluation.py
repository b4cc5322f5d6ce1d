"""Scalar evaluation: one case per construct with a hand-computed value, and the errors."""

from __future__ import annotations

import pytest

from tracecheck.b.evaluation import evaluate
from tracecheck.b.parser import parse_formula
from tracecheck.b.values import Elem, FuncValue
from tracecheck.errors import BTypeError, EvaluationError, WellDefinednessError

E = Elem
STATE = {
    "n": 7,
    "r": 2.5,
    "b": True,
    "S": frozenset({1, 2, 3}),
    "f": FuncValue({E("p"): 1.5, E("q"): -2.0}),
    "V": frozenset({E("p"), E("q")}),
    "p": E("p"), "q": E("q"), "c": E("c"),
    "rl": frozenset({(1, 10), (1, 11), (2, 20)}),
}


def ev(text, state=STATE):
    return evaluate(parse_formula(text), state, source=text)


CASES = [
    # arithmetic (B integer division truncates towards zero)
    ("n + 1", 8), ("n - 10", -3), ("n * 2", 14), ("n / 2", 3), ("-n / 2", -3), ("n / -2", -3),
    ("n mod 3", 1), ("2 ** 10", 1024), ("-n", -7), ("r * 2.0", 5.0), ("r / 2.0", 1.25),
    ("r ** 2", 6.25), ("1.0E2", 100.0),
    # comparisons and logic
    ("n > 3", True), ("n < 3", False), ("n >= 7", True), ("n <= 6", False), ("n = 7", True),
    ("n /= 7", False), ("b & n > 3", True), ("b & n > 9", False), ("not(b) or n = 7", True),
    ("n > 9 => 1 / 0 = 1", True), ("n > 3 <=> b", True), ("b = TRUE", True),
    ("bool(n > 3)", True), ("bool(n > 9) = FALSE", True),
    # sets
    ("card(S)", 3), ("2 : S", True), ("4 /: S", True), ("{1, 2} <: S", True),
    ("S <<: S", False), ("{1} <<: S", True), ("{4} /<: S", True), ("S /<<: S", True),
    ("S \\/ {4}", frozenset({1, 2, 3, 4})), ("S /\\ {2, 5}", frozenset({2})),
    ("S \\ {1}", frozenset({2, 3})), ("S - {1}", frozenset({2, 3})), ("{}", frozenset()),
    ("1..4", None), ("card(1..4)", 4), ("min(S)", 1), ("max(S)", 3),
    ("{1} * {2, 3}", frozenset({(1, 2), (1, 3)})), ("POW({1}) = {{}, {1}}", True),
    ("{1} : POW(S)", True), ("{4} : POW(S)", False), ("S : POW(INTEGER)", True),
    ("7 : NATURAL", True), ("-1 : NATURAL", False), ("0 : NATURAL1", False),
    ("2.5 : REAL", True), ("TRUE : BOOL", True), ("1 : NAT", True),
    # relations and functions
    ("f(p)", 1.5), ("f(q)", -2.0), ("dom(f)", frozenset({E("p"), E("q")})), ("ran(f)", frozenset({1.5, -2.0})),
    ("rl[{1}]", frozenset({10, 11})), ("rl~[{20}]", frozenset({2})),
    ("(1 |-> 2)", (1, 2)), ("(1, 2, 3)", ((1, 2), 3)),
    ("f : V --> REAL", True), ("f : V --> INTEGER", False), ("rl : S <-> NATURAL", True),
    ("rl : S +-> NATURAL", False), ("{(1 |-> 2)} : S >-> S", False),
    ("{1} <| rl", frozenset({(1, 10), (1, 11)})), ("rl |> {20}", frozenset({(2, 20)})),
    ("{1} <<| rl", frozenset({(2, 20)})), ("rl |>> {20}", frozenset({(1, 10), (1, 11)})),
    ("{(1 |-> 1)} <+ {(1 |-> 2), (3 |-> 3)}", frozenset({(1, 2), (3, 3)})),
    # binders
    ("!x.(x : S => x > 0)", True), ("!x.(x : S => x > 1)", False), ("#x.(x : S & x > 2)", True),
    ("#(x, y).(x : S & y : S & x + y = 6)", True), ("{x | x : S & x > 1}", frozenset({2, 3})),
    ("{x, y | x : S & y = x * x & y > 3}", frozenset({(2, 4), (3, 9)})),
    ("{x·x : S | x * 10}", frozenset({10, 20, 30})), ("{x•x : S | x * 10}", frozenset({10, 20, 30})),
    ("%x.(x : S | x * x)(3)", 9), ("SIGMA(x).(x : S | x)", 6), ("PI(x).(x : S | x)", 6),
    ("UNION(x).(x : S | {x, x + 1})", frozenset({1, 2, 3, 4})),
    ("INTER(x).(x : S | {1, 2, 3, x})", frozenset({1, 2, 3})),
    ("!v.(v : dom(f) => f(v) < 2.0)", True),
    ("IF n > 5 THEN 1 ELSIF n > 3 THEN 2 ELSE 3 END", 1),
    ("IF n > 9 THEN 1 ELSIF n > 3 THEN 2 ELSE 3 END", 2),
    ("LET x, y BE x = 2 & y = x + 1 IN x * y END", 6),
    ("LET x BE x = n IN x > 3 END", True),
    # numbers
    ("floor(2.7)", 2), ("ceiling(2.1)", 3), ("floor(-2.5)", -3), ("real(3)", 3.0),
    ("RSQRT(16.0)", 4.0), ("RABS(-2.5)", 2.5), ("MAXINT", 2147483647),
]


@pytest.mark.parametrize("text,expected", [c for c in CASES if c[1] is not None],
                         ids=[c[0] for c in CASES if c[1] is not None])
def test_value(text, expected):
    value = ev(text)
    assert value == expected
    assert type(value) is type(expected) or isinstance(value, frozenset)


WD = [
    ("1 / 0", "division by zero in `1 / 0`"),
    ("r / 0.0", "division by zero"),
    ("n mod 0", "mod needs a ≥ 0 and b > 0 (here 7 mod 0)"),
    ("-1 mod 2", "mod needs a ≥ 0"),
    ("min({})", "min of the empty set in `min({})`"),
    ("max(S /\\ {})", "max of the empty set"),
    ("f(c)", "c is not in the domain of the function in `f(c)`"),
    ("rl(1)", "1 is mapped to several values of the relation"),
    ("rl(5)", "5 is not in the domain of the relation"),
    ("RSQRT(-1.0)", "square root of the negative number -1.0"),
    ("2 ** -1", "negative exponent -1"),
]


@pytest.mark.parametrize("text,fragment", WD, ids=[t for t, _ in WD])
def test_well_definedness(text, fragment):
    with pytest.raises(WellDefinednessError) as info:
        ev(text)
    assert fragment in info.value.message
    assert info.value.line == 1 and info.value.column >= 1


def test_well_definedness_location_points_at_the_term():
    text = "n > 1 &\n  f(c) > 0.0"
    with pytest.raises(WellDefinednessError) as info:
        ev(text)
    assert (info.value.line, info.value.column) == (2, 3)


@pytest.mark.parametrize("text,exc,fragment", [
    ("x + 1", EvaluationError, "x has no value here"),
    ("card({x | x > 1})", EvaluationError, "cannot enumerate x"),
    ("!x.(x : INTEGER => x > 0)", EvaluationError, "cannot enumerate the infinite set INTEGER"),
    ("card(INTEGER)", EvaluationError, "the set INTEGER is infinite: it has no card"),
    ("S + 1", BTypeError, "`S` must be a number"),
    ("n < S", BTypeError, "`S` must be a number"),
    ("n(1)", BTypeError, "`n` must be a function"),
    ("2 : n", BTypeError, "`n` must be a set"),
])
def test_evaluation_errors(text, exc, fragment):
    with pytest.raises(exc) as info:
        ev(text)
    assert fragment in info.value.message


def test_quantifier_does_not_leak_its_variable():
    env = dict(STATE)
    env["x"] = 99
    assert evaluate(parse_formula("#x.(x : S & x = 2) & x = 99"), env)


def test_interval_is_lazy():
    assert ev("5 : 1..1000000000") is True


def test_what_names_only_built_in_sets_is_computed_once_when_compiling():
    """Issue 46: ``REAL * REAL`` and ``prj1(REAL * REAL, REAL)`` name nothing a state gives
    (a definition like the lunar lander's ``SegX1(i)`` repeats them at every application):
    they are computed once, when compiling, not once per evaluation — and give the same
    answers and messages as before."""
    from tracecheck.b.evaluation import Compiler

    comp = Compiler(source="prj1(REAL * REAL, REAL)")
    fn = comp.compile(parse_formula("prj1(REAL * REAL, REAL)"))
    assert fn({}) is fn({"x": 1.0})  # one value, made when compiling
    assert fn({}).name == "prj1((REAL * REAL),REAL)"
    assert ev("prj1(REAL * REAL, REAL)(((1.5 |-> 2.0) |-> 3.0))") == (1.5, 2.0)
    assert ev("prj2(REAL, REAL)((1.5 |-> 2.0))") == 2.0
    with pytest.raises(WellDefinednessError, match=r"not in the domain of prj1\(REAL,REAL\)"):
        ev("prj1(REAL, REAL)((1 |-> 2))")  # integers are not reals
    assert ev("(2.0 |-> 1.0) : REAL * REAL") is True
    assert ev("MAXINT + 1 > MAXINT") is True


def test_folding_leaves_an_ill_typed_branch_to_where_it_is_evaluated():
    """A sub-formula of built-in sets that cannot be computed (``BOOL || {}``, which the
    type checker refuses) is not computed when compiling: a branch never taken stays
    untouched (``tracecheck eval`` type-checks first and refuses the formula, located)."""
    assert ev("n = 7 or (BOOL || {}) = {}") is True


def test_a_product_of_sets_it_cannot_print_is_still_a_set():
    """A product or projection prints its name only when a message needs it: ``(NAT \\/ INT)
    * BOOL``, whose name tracecheck cannot print (it cannot count the union), used to be
    refused when made; its membership is now answered — rightly."""
    assert ev("(1 |-> TRUE) : (NAT \\/ INT) * BOOL") is True
    assert ev("(1 |-> 2) : (NAT \\/ INT) * BOOL") is False
    assert ev("prj1(NAT \\/ NAT1, NAT)((1 |-> 2)) = 1") is True


def test_inside_a_binder_a_formula_of_the_state_alone_is_computed_once_per_state():
    """Issue 46: ``{i | i : 1..50 & i > g(1) * 2.0 + g(1) - 1.0}`` reads the state's ``g``
    twice per evaluation, not twice per value of ``i`` (a binder binds in the state's own
    dict, where the value is remembered); a formula that reads ``i`` is computed for each;
    one that is not defined in the state fails as before, each time it is asked."""
    from tracecheck.b.evaluation import compile_formula

    class Counted(dict):
        reads = 0

        def __getitem__(self, key):
            Counted.reads += 1
            return super().__getitem__(key)

    text = "{i | i : 1..50 & i > g(1) * 2.0 + g(1) - 1.0 & i < g(2) * real(i) + 40.0}"
    fn = compile_formula(parse_formula(text), source=text)
    state = {"g": FuncValue(Counted({1: 10.0, 2: 0.5}))}
    assert fn(dict(state)) == frozenset(range(30, 51))
    assert Counted.reads == 2 + 21  # g(1) twice; g(2) for each i past the first test
    text = "{i | i : 1..3 & i > 1 / (n - 7) + n * 2 - 1}"
    for _ in range(2):
        with pytest.raises(WellDefinednessError, match="division by zero"):
            ev(text)


def test_threads_compiling_at_once_never_share_a_remembered_value():
    """Each formula remembered per state has a slot of its own, also when threads compile
    at once (a library user's workers): two formulas sharing one would read each other's
    values."""
    import collections
    import sys
    import threading

    from tracecheck.b import memo
    from tracecheck.b.evaluation import compile_formula

    def work(t):
        for k in range(150):
            text = f"{{i | i : 1..3 & i < x * {t} + y * {k} + {t * 1000 + k + 7919}}}"
            compile_formula(parse_formula(text))
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=work, args=(t,)) for t in range(6)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
    finally:
        sys.setswitchinterval(interval)
    by_slot = collections.Counter(memo._SLOTS.values())
    assert by_slot.most_common(1)[0][1] == 1


def test_a_formula_naming_an_element_of_a_bound_set_is_not_remembered_across_it():
    """``V10`` may be an element of the set ``V``: inside ``{V | V <: … }`` a formula naming it
    reads the bound ``V`` too, so it is computed for each value, not remembered from the
    first (whose ``V`` holds ``V10``) — the same refusal whatever the order walked."""
    from tracecheck.b.machine import load_machine_text

    m = load_machine_text("""MACHINE M
SETS V
PROPERTIES card(V) = 10
VARIABLES x
INVARIANT x : INTEGER
INITIALISATION x := 0
OPERATIONS
Op = SELECT card({V | V <: {V1, V10, V2} & card(V) = 2 &
                 (IF V10 = V10 THEN 1 ELSE 0 END) + x + 0 = 1}) = 3 THEN skip END
END""")
    with pytest.raises(EvaluationError, match="V10 has no value here"):
        m.enabled({"x": 0})
