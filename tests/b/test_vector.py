"""The batch path gives exactly the scalar path's answers, row by row."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tracecheck.b.evaluation import compile_formula
from tracecheck.b.parser import parse_formula
from tracecheck.b.values import Elem, FuncValue
from tracecheck.b.columns import Columns
from tracecheck.b.vector import BatchFormula
from tracecheck.errors import WellDefinednessError

ELEMS = tuple(Elem(n) for n in ("EgoVehicle", "Vehicles2", "Vehicles3", "Vehicles4"))
CONSTANTS = {"EgoVehicle": ELEMS[0], "Vehicles2": ELEMS[1], "Vehicles": frozenset(ELEMS),
             "limit": 10.0}

FORMULAS = [
    "#v.(v : PresentVehicles \\ {EgoVehicle} & X(v) > 0.0 & X(v) < 45.0 & Y(v) < 3.5)",
    "!v.(v : PresentVehicles => X(v) + Vx(v) * 2.0 >= -limit)",
    "not(#v.(v : Vehicles & v /= EgoVehicle & (X(v) <= -15.0 or Vx(v) > 1.0)))",
    "Crash = FALSE => RSQRT(Vx(EgoVehicle) ** 2 + 1.0) <= 30.0",
    "card(PresentVehicles) > 2 <=> Reward > 0.5",
    "EgoVehicle : dom(X) & X(EgoVehicle) / Reward > 1.0",  # division by a column that may be 0
    "IF Crash = TRUE THEN Reward ELSE -Reward END > 0.1",
    "bool(Reward > 0.2) = Crash",
    "EgoVehicle : PresentVehicles & Vehicles2 /: PresentVehicles",
    "RABS(Y(EgoVehicle)) - floor(Reward * 3.0) >= 0.0",
    # IF guards a division: only the rows that take the branch may be ill-defined
    "IF Reward = 0.0 THEN 1.0 ELSE 1.0 / Reward END > 0.5",
    # nested element quantifiers (two element axes)
    "!v.(v : PresentVehicles => #w.(w : PresentVehicles & X(w) >= X(v)))",
    "#v.(v : PresentVehicles & not(#w.(w : PresentVehicles & w /= v & X(w) < X(v))) & "
    "X(v) > 0.0)",
    # comprehensions, images, min/max, LET, ELSIF (the authors' RSS shield is made of these)
    "card({v | v : PresentVehicles & X(v) > 0.0}) >= 1",
    "min({40.0} \\/ X[{v | v : PresentVehicles & Y(v) > 0.0}]) > 1.0",
    "{v | v : PresentVehicles & X(v) > 10.0} /= {} => "
    "min(X[{v | v : PresentVehicles & X(v) > 10.0}]) < 30.0",
    "max({0.0, X(EgoVehicle) - min(Vx[PresentVehicles \\ {EgoVehicle}])}) > 1.0",
    "LET d BE d = X(EgoVehicle) * 2.0 IN d > Reward & d < 50.0 END",
    "#v.(v : PresentVehicles & X(v) = min(X[{w | w : PresentVehicles & Y(w) >= 0.0}]))",
    "IF Reward > 0.5 THEN 1.0 ELSIF Reward > 0.0 THEN 2.0 ELSE 1.0 / Reward END > 0.5",
    "min({v . v : PresentVehicles | X(v) + Vx(v)}) < 10.0",
    "{v | v : PresentVehicles & v : {w | w : PresentVehicles & Y(w) < 0.0}} = {EgoVehicle}",
    # not vectorisable: answered by the scalar path row by row
    "#(v, w).(v : PresentVehicles & w : PresentVehicles & v /= w & X(v) = X(w))",
    "#v.(v : PresentVehicles & card({w | w : PresentVehicles & X(w) > X(v)}) = 0)",
]

floats = st.floats(min_value=-50, max_value=50, allow_nan=False).map(lambda x: round(x, 1))


@st.composite
def states(draw):
    present = frozenset({ELEMS[0]} | {e for e in ELEMS[1:] if draw(st.booleans())})
    return {
        "Crash": draw(st.booleans()),
        "Reward": draw(st.sampled_from([0.0, 0.3, 0.9, -0.5])),
        "PresentVehicles": present,
        "X": FuncValue({e: draw(floats) for e in ELEMS}),
        "Y": FuncValue({e: draw(floats) for e in ELEMS}),
        "Vx": FuncValue({e: draw(floats) for e in ELEMS}),
    }


def scalar_or_error(fn, state):
    try:
        return fn({**CONSTANTS, **state})
    except WellDefinednessError:
        return "wd"


@pytest.mark.parametrize("text", FORMULAS)
@settings(max_examples=40, deadline=None)
@given(rows=st.lists(states(), min_size=1, max_size=12))
def test_batch_matches_scalar(text, rows):
    node = parse_formula(text)
    scalar = compile_formula(node, source=text)
    expected = [scalar_or_error(scalar, s) for s in rows]
    batch = BatchFormula(node, CONSTANTS, source=text)
    cols = Columns.from_states(rows, ELEMS)
    if "wd" in expected:
        with pytest.raises(WellDefinednessError):
            batch(cols)
        return
    got = batch(cols)
    assert list(got) == expected


def test_plans_vectorise_the_common_shapes():
    cols = Columns.from_states([{
        "Crash": False, "Reward": 1.0, "PresentVehicles": frozenset(ELEMS),
        "X": FuncValue({e: 1.0 for e in ELEMS}), "Y": FuncValue({e: 1.0 for e in ELEMS}),
        "Vx": FuncValue({e: 1.0 for e in ELEMS}),
    }], ELEMS)
    planned = [BatchFormula(parse_formula(t), CONSTANTS)._plan(cols) is not None
               for t in FORMULAS]
    assert planned == [True] * 22 + [False] * 2


def test_partial_function_rows_fall_back_to_scalar():
    rows = [
        {"F": FuncValue({ELEMS[0]: 1.0}), "n": 1.0},
        {"F": FuncValue({ELEMS[0]: 5.0, ELEMS[1]: 2.0}), "n": 1.0},
    ]
    cols = Columns.from_states(rows, ELEMS[:2])
    text = "Vehicles2 : dom(F) & F(Vehicles2) > n"
    out = BatchFormula(parse_formula(text), {"Vehicles2": ELEMS[1]})(cols)
    assert list(out) == [False, True]
    with pytest.raises(WellDefinednessError) as info:
        BatchFormula(parse_formula("F(Vehicles2) > n"), {"Vehicles2": ELEMS[1]},
                     source="F(Vehicles2) > n")(cols)
    assert info.value.message.startswith("state 0: ")


def test_rows_round_trip():
    row = {"Crash": True, "Reward": 2.5, "PresentVehicles": frozenset(ELEMS[:2]),
           "X": FuncValue({e: float(i) for i, e in enumerate(ELEMS)}), "k": 3,
           "T": frozenset({(1, 2)})}
    cols = Columns.from_states([row, row], ELEMS)
    assert cols.row(1) == row
    assert set(cols.numbers) == {"Reward", "k"} and "T" in cols.others


def test_enabled_batch_matches_enabled(table1):
    states = []
    rng = np.random.default_rng(7)
    for _ in range(50):
        vs = table1.sets["Vehicles"]
        states.append({
            "Crash": False, "PresentVehicles": frozenset(vs), "Reward": 0.0,
            **{name: FuncValue({v: float(rng.uniform(-40, 40)) for v in vs})
               for name in ("VehiclesX", "VehiclesVx", "VehiclesVy", "VehiclesAx",
                            "VehiclesAy")},
            "VehiclesY": FuncValue({v: float(rng.choice([-4.0, 0.0, 4.0, 8.0])) for v in vs}),
        })
    batch = table1.enabled_batch(Columns.from_states(states, table1.sets["Vehicles"]))
    for i, s in enumerate(states):
        assert {op for op, arr in batch.items() if arr[i]} == table1.enabled(s)


def test_if_branches_only_count_where_taken():
    """A division guarded by IF does not send the rows where it is not taken to the scalar
    path (which would be correct but slow)."""
    from tracecheck.b.arrays import BatchContext

    rows = [{"Reward": r, "X": FuncValue({ELEMS[0]: 1.0})} for r in (0.0, 2.0, 0.0)]
    cols = Columns.from_states(rows, ELEMS[:1])
    formula = BatchFormula(parse_formula("IF Reward = 0.0 THEN 1.0 ELSE 1.0 / Reward END"), {})
    ctx = BatchContext(cols)
    tag, value = formula._plan(cols)(ctx)
    assert not ctx.bad.any()
    assert list(formula(cols)) == [1.0, 0.5, 1.0]


@pytest.mark.parametrize("text", [
    " & ".join(f"X(EgoVehicle) + {k}.0 > Reward" for k in range(1500)),
    "+".join(["Reward"] * 1500) + " > 100.0",
    "not(" * 1500 + "Crash = TRUE" + ")" * 1500,
], ids=["conjunction", "sum", "not"])
def test_long_formulas_on_the_batch_path(text):
    """1500 levels (a generated guard) on both paths, row by row the same."""
    rows = [{"Crash": c, "Reward": r, "X": FuncValue({ELEMS[0]: x})}
            for c, r, x in [(True, 0.5, 1.0), (False, 0.0, -3.0), (False, 0.1, 0.0)]]
    cols = Columns.from_states(rows, ELEMS[:1])
    node = parse_formula(text)
    batch = BatchFormula(node, CONSTANTS, source=text)(cols)
    scalar = compile_formula(node, source=text)
    assert list(batch) == [scalar({**CONSTANTS, **row}) for row in rows]


def test_float_column_names_the_row_of_an_integer_too_large_for_a_float():
    """B integers stay exact on both paths (an object array of Python ints where 64 bits do
    not hold them); turned into floats, one too large is an error at its row, never inf."""
    from tracecheck.b.arrays import float_column
    from tracecheck.errors import EvaluationError

    cols = Columns(3, (), numbers={"n": np.array([1.0, 2.0, 3.0])})
    cols.label = lambda i: f"episode 7, step {i}"
    batch = BatchFormula(parse_formula("2 ** (400 * floor(n))"), {})
    values = batch(cols)
    assert values.tolist() == [batch._row(cols, i) for i in range(3)] == \
        [2 ** 400, 2 ** 800, 2 ** 1200]
    with pytest.raises(EvaluationError, match=r"^episode 7, step 2: the value of `E`, an "
                                              r"integer of about 362 digits, does not fit"):
        float_column(values, cols, "`E`")
    assert float_column(values[:2], cols, "`E`").tolist() == [2.0 ** 400, 2.0 ** 800]
    assert float_column(np.array([1, 2]), cols, "`E`").dtype == float


@pytest.mark.parametrize("text", ["k * k", "3 ** (40 * floor(n))", "floor(n * 1.0e300)",
                                  "ceiling(n / 2.0) * k", "floor(n) = 1"])
def test_integers_beyond_64_bits_are_exact_on_the_batch_path_too(text):
    """Rows the batch path hands to the scalar path keep their exact integer (an object
    array; `k * k` was an OverflowError traceback), and floor/ceiling are INTEGERs there as
    in the scalar path (3 ** 40 was a rounded float)."""
    cols = Columns(3, (), numbers={"k": np.array([2 ** 40, 1, -3], dtype=np.int64),
                                   "n": np.array([1.0, 3.0, 2.5])})
    batch = BatchFormula(parse_formula(text), {})
    assert batch._plan(cols) is not None
    assert batch(cols).tolist() == [batch._row(cols, i) for i in range(3)]


@given(st.integers(0, 20), st.integers(0, 4), st.integers(0, 2 ** 32 - 1),
       st.sampled_from([bool, np.int64, float]))
def test_all_last_is_numpys_all_along_the_last_axis(width, rows, seed, dtype):
    from tracecheck.b.arrays import all_last

    rng = np.random.default_rng(seed)
    for shape in ((width,), (rows, width), (rows, 1, width)):
        values = (rng.random(shape) < 0.9).astype(dtype)
        got, want = all_last(values), np.all(values, axis=-1)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert np.array_equal(got, want)


@pytest.mark.parametrize("big", [2 ** 63, -(2 ** 63) - 1, 2 ** 70, 2 ** 63 - 1, 2 ** 53 + 1])
def test_integers_beyond_int64_keep_their_value_in_a_batch(big):
    """An integer no int64 holds (a new user's state ``{"n": 2**63}`` crashed recording
    with OverflowError), or one beside floats no float holds, stays a Python int: the
    batch answers as the scalar path, exactly."""
    from tracecheck.b import load_machine_text

    m = load_machine_text("""MACHINE Big SETS K = {k1, k2} VARIABLES n, f, r
INVARIANT n : INTEGER & f : K --> INTEGER & r : REAL
INITIALISATION n := 0 || f := K * {0} || r := 0.0
OPERATIONS
  Past = SELECT n + 1 > 9223372036854775807 THEN skip END;
  Huge = SELECT f(k1) > 9223372036854775807 THEN skip END;
  Near = SELECT f(k2) - n = 1 THEN skip END
END""")
    states = [{"n": v, "f": FuncValue({Elem("k1"): v, Elem("k2"): v + 1}), "r": 0.5}
              for v in (big, 3, abs(big) + 2)]
    batch = m.enabled_batch(Columns.from_states(states))
    for row, state in enumerate(states):
        assert {op for op, on in batch.items() if on[row]} == m.enabled(state), state
    mixed = Columns.from_states([{"n": big, "f": states[0]["f"], "r": 0.5},
                                 {"n": 0.5, "f": states[0]["f"], "r": 0.5}])
    assert "n" not in mixed.numbers or abs(big) <= 2 ** 53  # a float column would round it
