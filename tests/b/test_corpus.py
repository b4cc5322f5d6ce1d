"""The differential corpus (corpus/expressions.txt): ProB's answers, on both evaluation paths.

Every case must give ProB's answer, or -- where the corpus marks it refused -- a located error
of the named class; never another value. The batch path must agree with the scalar path on
every row, including which rows have no value (not well-defined).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tracecheck import errors as E
from tracecheck.b.evaluation import Compiler
from tracecheck.b.parser import library_definitions, parse_formula
from tracecheck.b.scope import check_kind, expand, kind_of
from tracecheck.b.typecheck import type_of_value, typecheck_formula
from tracecheck.b.notation import parse_literal
from tracecheck.b.values import Elem, FuncValue, is_set
from tracecheck.b.columns import Columns
from tracecheck.b.vector import BatchFormula

CORPUS = Path(__file__).with_name("corpus") / "expressions.txt"
SOURCES = {"SUM", "REAL", "TC", "BRM", "LIT", "WD", "DRONE", "ISSUE", "LIB"}
#: ProB's console offers its library functions without an include, as the corpus does
LIBRARY = library_definitions("*")


@dataclass(frozen=True)
class Case:
    line: int
    formula: str
    answer: str
    source: str
    refused: str | None

    @property
    def id(self) -> str:
        return f"L{self.line}:{self.formula[:60]}"


def load_corpus() -> list[Case]:
    cases = []
    for number, text in enumerate(CORPUS.read_text(encoding="utf-8").splitlines(), start=1):
        if not text.strip() or text.startswith(("# ", "##")) or text == "#":
            continue  # comments; a formula may start with # (exists)
        parts = [p.strip() for p in text.split(" ⟹ ")]
        assert len(parts) in (3, 4), f"line {number}: {text}"
        refused = None
        if len(parts) == 4:
            assert parts[3].startswith("refused: "), f"line {number}"
            refused = parts[3].removeprefix("refused: ")
        cases.append(Case(number, parts[0], parts[1], parts[2], refused))
    return cases


CASES = load_corpus()


def prepare(formula: str, names: dict | None = None):
    node = expand(parse_formula(formula, file="<corpus>"), LIBRARY)
    kind = kind_of(node)
    check_kind(node, kind, source=formula)
    typecheck_formula(node, names or {}, kind=kind, source=formula, file="<corpus>")
    return node


def outcome(formula: str, env: dict | None = None, names: dict | None = None) -> tuple:
    """("value", v) or ("error", exception) on the scalar path."""
    try:
        node = prepare(formula, names)
        return ("value", Compiler(source=formula, file="<corpus>").compile(node)(dict(env or {})))
    except E.TracecheckError as exc:
        return ("error", exc)


def test_the_corpus_is_large_and_cites_its_sources():
    assert len(CASES) >= 300
    for case in CASES:
        assert case.source in SOURCES or case.source.startswith("P"), case
    assert len({c.formula for c in CASES}) == len(CASES), "a formula appears twice"


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_scalar_path_gives_probs_answer(case: Case):
    tag, result = outcome(case.formula)
    if case.refused or case.answer.startswith("error:"):
        wanted = case.refused or case.answer.removeprefix("error:")
        assert tag == "error", f"{case.formula} gave {result!r}, not an error"
        assert isinstance(result, getattr(E, wanted)), result
        assert result.line is not None, f"the error is not located: {result}"
        return
    assert tag == "value", f"{case.formula}: {result}"
    expected = parse_literal(case.answer)
    assert type(result) is type(expected) or (is_set(result) and is_set(expected)), \
        (result, expected)
    assert result == expected


def _batch(formula: str, cols: Columns, names: dict | None = None) -> tuple:
    try:
        node = prepare(formula, names)
        return ("value", BatchFormula(node, {}, source=formula)(cols))
    except E.TracecheckError as exc:
        return ("error", exc)


#: the batch path computes predicates and numbers: the cases whose answer is one (or none)
BATCH_CASES = [c for c in CASES if c.refused or c.answer.startswith("error:")
               or type(parse_literal(c.answer)) in (bool, int, float)]


@pytest.mark.parametrize("case", BATCH_CASES, ids=[c.id for c in BATCH_CASES])
def test_batch_path_agrees_with_the_scalar_path(case: Case):
    tag, value = outcome(case.formula)
    cols = Columns(n=3, elements=())
    btag, bvalue = _batch(case.formula, cols)
    assert btag == tag, (value, bvalue)
    if tag == "error":
        assert type(bvalue) is type(value)
    else:
        assert [v.item() if hasattr(v, "item") else v for v in bvalue] == [value] * 3


# ---------------------------------------------------------------- formulas over states

ELEMS = (Elem("a"), Elem("b"), Elem("c"))
ROWS = {
    "x": [0, 1, -3, 7, 2 ** 40, 5],
    "r": [0.5, -2.0, 1.0e308, 0.0, 3.0, -0.0],
    "flag": [True, False, True, False, True, False],
    "f": [{"a": 1.0, "b": 2.0, "c": 3.0}, {"a": -1.0}, {"b": 0.0, "c": 9.0},
          {"a": 5.0, "b": 5.0, "c": 5.0}, {}, {"c": 1.5}],
    "S": [{"a", "b"}, set(), {"c"}, {"a", "b", "c"}, {"b"}, {"a", "c"}],
}

STATE_FORMULAS = [
    "x * 2 > 1", "x + x = 2 * x", "x - 7 < 0", "x / 2 = 0", "x mod 3 = 1", "-x < 0",
    "x * x * x * x > 1000", "x * x * x * x * x * x = 2 ** 240", "x ** 2 > 3", "2 ** x > 100",
    "r * 10.0 > 0.0", "r + r > r", "1.0 / r > 0.0", "r / 2.0 < 1.0", "r ** 2 >= 0.0",
    "r * r * r > 0.0", "-r > 0.0", "real(x) > r", "floor(r) = 0",
    "flag = TRUE", "flag = TRUE or x > 3", "flag = TRUE => 1 / x > 0", "x /= 0 & 10 / x > 1",
    "f(a) > 0.0", "a : dom(f) & f(a) > 0.0", "a : dom(f) => f(a) > 0.0",
    "#v.(v : S & f(v) > 1.0)", "!v.(v : S => v : dom(f))", "!v.(v : S & v : dom(f) => f(v) < 9.0)",
    "card(S) > 1", "S <: dom(f)", "S = {a, b}", "a : S or c : S", "S \\/ {c} = {a, b, c}",
    "S /\\ {a} = {}", "S - {b} = {}", "#v.(v : S \\ {a} & f(v) = 5.0)",
    "#(v, w).(v : S & w : S & v /= w)", "x + 1 = x * x", "IF x > 0 THEN r ELSE 0.0 END < 1.0",
    "max({x, 3}) = 3", "x : 0..5", "x : NATURAL", "x + 1 : NATURAL1",
    "card(S) + 9223372036854775807 > 0", "x * 4611686018427387904 < 0",
]


def state_rows() -> list[dict[str, Any]]:
    n = len(ROWS["x"])
    rows = []
    for i in range(n):
        rows.append({
            "x": ROWS["x"][i], "r": ROWS["r"][i], "flag": ROWS["flag"][i],
            "f": FuncValue({Elem(k): v for k, v in ROWS["f"][i].items()}),
            "S": frozenset(Elem(e) for e in ROWS["S"][i]),
        })
    return rows


def names_for(rows: list[dict[str, Any]]) -> dict:
    owners = {e: "ELEMS" for e in ELEMS}
    from tracecheck.b.btypes import Base, Pow, Prod, REAL

    names = {k: type_of_value(v, owners) for k, v in rows[0].items()}
    names["f"] = Pow(Prod(Base("ELEMS"), REAL))
    names.update({str(e): Base("ELEMS") for e in ELEMS})
    return names


def columns_of(rows: list[dict[str, Any]]) -> Columns:
    cols = Columns.from_states(rows, ELEMS)
    cols.numbers["x"] = np.array([r["x"] for r in rows], dtype=np.int64)
    cols.numbers["r"] = np.array([r["r"] for r in rows], dtype=float)
    return cols


@pytest.mark.parametrize("formula", STATE_FORMULAS)
def test_batch_and_scalar_agree_row_by_row(formula):
    rows = state_rows()
    names = names_for(rows)
    consts = {str(e): e for e in ELEMS}
    scalar = [outcome(formula, {**consts, **row}, names) for row in rows]
    for i, row in enumerate(rows):
        btag, bvalue = _batch_consts(formula, columns_of([row]), names, consts)
        tag, value = scalar[i]
        assert btag == tag, (i, value, bvalue)
        if tag == "error":
            assert type(bvalue) is type(value), (i, value, bvalue)
        else:
            assert bvalue[0].item() == value, (i, value, bvalue)
    btag, bvalue = _batch_consts(formula, columns_of(rows), names, consts)
    errors = [v for t, v in scalar if t == "error"]
    if errors:
        assert btag == "error" and type(bvalue) is type(errors[0]), bvalue
    else:
        assert btag == "value"
        assert [v.item() for v in bvalue] == [v for _, v in scalar]


def _batch_consts(formula, cols, names, consts):
    try:
        node = prepare(formula, names)
        return ("value", BatchFormula(node, consts, source=formula)(cols))
    except E.TracecheckError as exc:
        return ("error", exc)


def test_the_state_formulas_vectorise():
    """Most of the formulas above run on numpy, not row by row (else the agreement above
    would test the scalar path against itself)."""
    rows = state_rows()
    names = names_for(rows)
    consts = {str(e): e for e in ELEMS}
    cols = columns_of(rows)
    planned = 0
    for formula in STATE_FORMULAS:
        batch = BatchFormula(prepare(formula, names), consts, source=formula)
        planned += batch._plan(cols) is not None
    assert planned >= len(STATE_FORMULAS) * 2 // 3


def test_answers_do_not_depend_on_the_order_a_set_is_walked():
    """∃/∀ over a set where the body is not well-defined for one element: an error (B's
    well-definedness), the same one whatever order Python's string hashing gives the set."""
    import os
    import subprocess
    import sys

    code = ("from tracecheck.b.evaluation import evaluate\n"
            "from tracecheck.b.parser import parse_formula as p\n"
            "from tracecheck.b.values import Elem, FuncValue\n"
            "S = frozenset({Elem('a'), Elem('c'), Elem('b')})\n"
            "f = FuncValue({Elem('c'): 1.5, Elem('b'): 0.5})\n"
            "for text in ('#v.(v : S & f(v) > 1.0)', '!v.(v : S => f(v) > 1.0)',\n"
            "             'card({v | v : S & f(v) > 1.0})'):\n"
            "    try:\n"
            "        print(evaluate(p(text), {'S': S, 'f': f}))\n"
            "    except Exception as exc:\n"
            "        print(type(exc).__name__, exc.message)\n")
    outputs = set()
    for seed in range(6):
        run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=dict(os.environ, PYTHONHASHSEED=str(seed)), timeout=60)
        assert run.returncode == 0, run.stderr
        outputs.add(run.stdout)
    assert len(outputs) == 1
    (text,) = outputs
    assert text.splitlines() == ["WellDefinednessError a is not in the domain of the function "
                                 "in `f(v)`"] * 3
