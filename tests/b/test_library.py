"""ProB's library definition files (tracecheck.b.library): included by a machine, refused when
unknown, and the same answers on the scalar and batch paths row by row, including which rows
are not well-defined. ProB's answers themselves are in corpus/expressions.txt (source LIB)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tracecheck import errors as E
from tracecheck.b.btypes import REAL
from tracecheck.b.columns import Columns
from tracecheck.b.evaluation import Compiler
from tracecheck.b.library import FUNCTIONS, LIBRARY_FILES
from tracecheck.b.machine import load_machine_text
from tracecheck.b.parser import library_definitions, parse_formula
from tracecheck.b.scope import check_kind, expand, kind_of
from tracecheck.b.typecheck import typecheck_formula
from tracecheck.b.vector import BatchFormula
from tracecheck.stats.properties import load_properties
from tracecheck.live.envs.highway import HIGHWAY

ROOT = Path(__file__).resolve().parents[2]
PAPER_TRACES = ROOT.parent / "shared" / "data" / "paper-traces" / "prob2trace"
PAPER_SHIELD = ROOT / "models" / "shields" / "paper.mch"
AUTHORS_RSQRT = ROOT / "tests" / "fixtures" / "properties" / "authors_rsqrt.toml"


def machine(defs: str, extra: str = "") -> str:
    return f"""MACHINE Lib
DEFINITIONS {defs}
CONSTANTS c
PROPERTIES c = 2.0 {extra}
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 1.0
END
"""


def test_an_included_library_gives_its_functions():
    m = load_machine_text(machine('"LibraryReals.def"; half == 0.5',
                                  "& RSIN(RPI / c) = 1.0 & RLOG(c, 1024.0) = 10.0"))
    assert m.evaluate("RPOW(x, c) + RSQRT(4.0) + RLOGe(REULER)", {"x": 3.0}) == 12.0
    assert m.evaluate("RLT(x, half)", {"x": 0.25}) is True
    with pytest.raises(E.WellDefinednessError, match="RLOGe"):
        m.evaluate("RLOGe(x - 1.0) > 0.0", {"x": 1.0})


@pytest.mark.parametrize("file", sorted(LIBRARY_FILES))
def test_each_known_file_loads(file):
    load_machine_text(machine(f'"{file}"'))


def test_without_the_include_the_names_are_unknown():
    with pytest.raises(E.TracecheckError):
        load_machine_text(machine("half == 0.5", "& RSIN(c) > 0.0"))


@pytest.mark.parametrize("file,cls", [("Mine.def", E.BScopeError),  # not found
                                      ("LibraryMath.def", E.BSyntaxError),
                                      ("LibraryIO.def", E.BSyntaxError), ("notes.txt", E.BSyntaxError)])
def test_other_definition_files_are_refused_naming_the_file(file, cls):
    with pytest.raises(cls) as info:
        load_machine_text(machine(f'"{file}"'))
    assert file in str(info.value) and info.value.line == 2


def test_a_library_name_defined_again_is_an_error():
    with pytest.raises(E.BSyntaxError, match="RSIN appears twice"):
        load_machine_text(machine('"LibraryReals.def"; RSIN(y) == y'))


def test_refused_functions_say_why_where_used():
    m = load_machine_text(machine('"LibraryReals.def"'))
    with pytest.raises(E.UnsupportedError, match="RCOT"):
        m.evaluate("RCOT(x) > 0.0", {"x": 1.0})


# ---------------------------------------------------------------- scalar and batch, row by row

REAL_FUNCTIONS = sorted(n for n, f in FUNCTIONS.items() if f.floats)
ROWS = [0.5, -2.0, 0.0, -0.0, 1.0, 3.0, 1.0e308, -1.0e-300, 710.0, 2.0, -0.5, 100.0]


def _prepare(text: str):
    node = expand(parse_formula(text), library_definitions("*"))
    check_kind(node, kind_of(node), source=text)
    typecheck_formula(node, {"r": REAL, "s": REAL}, kind=kind_of(node), source=text)
    return node


def _scalar(node, text, env):
    try:
        return ("value", Compiler(source=text).compile(node)(dict(env)))
    except E.TracecheckError as exc:
        return ("error", type(exc))


def _batch(node, text, rs, ss):
    cols = Columns(n=len(rs), elements=())
    cols.numbers["r"] = np.array(rs, dtype=float)
    cols.numbers["s"] = np.array(ss, dtype=float)
    try:
        return ("value", [v.item() for v in BatchFormula(node, {}, source=text)(cols)])
    except E.TracecheckError as exc:
        return ("error", type(exc))


@pytest.mark.parametrize("name", REAL_FUNCTIONS)
def test_batch_and_scalar_agree_row_by_row(name):
    args = "r" if FUNCTIONS[name].arity == 1 else "r, s"
    text = f"{name}({args}) >= 0.0"
    node = _prepare(text)
    ss = ROWS[::-1]
    scalar = [_scalar(node, text, {"r": r, "s": s}) for r, s in zip(ROWS, ss)]
    for i, (r, s) in enumerate(zip(ROWS, ss)):
        tag, value = _batch(node, text, [r], [s])
        assert (tag, value[0] if tag == "value" else value) == scalar[i], (name, r, s)
    whole = _batch(node, text, ROWS, ss)
    errors = [v for t, v in scalar if t == "error"]
    assert whole == (("error", errors[0]) if errors else ("value", [v for _, v in scalar]))
    # the guarded form has a value on every row, the same on both paths
    guarded = f"(r > 0.0 & r < 100.0 & s > 0.0 & s < 100.0) => {text}"
    gnode = _prepare(guarded)
    expected = [_scalar(gnode, guarded, {"r": r, "s": s}) for r, s in zip(ROWS, ss)]
    if all(t == "value" for t, _ in expected):
        assert _batch(gnode, guarded, ROWS, ss) == ("value", [v for _, v in expected])


def test_the_real_functions_run_on_numpy_columns():
    node = _prepare("RSIN(r) + RPOW(r, s) > 0.0")
    batch = BatchFormula(node, {}, source="")
    cols = Columns(n=2, elements=())
    cols.numbers["r"], cols.numbers["s"] = np.array([0.5, 2.0]), np.array([2.0, 3.0])
    assert batch._plan(cols) is not None
    assert [v.item() for v in batch(cols)] == [True, True]
    assert math.sin(0.5) + 0.25 > 0.0


# ---------------------------------------------------------------- the authors' RSQRT predicate

TRACES = sorted(PAPER_TRACES.glob("*.prob2trace")) if PAPER_TRACES.is_dir() else []


@pytest.mark.skipif(not TRACES, reason=f"the paper's traces are not at {PAPER_TRACES}")
@pytest.mark.parametrize("trace", TRACES, ids=[t.stem for t in TRACES])
def test_the_authors_rsqrt_predicates_on_the_paper_traces(trace):
    from tracecheck.b.machine import load_machine
    from tracecheck.interop.prob2trace import read_prob2trace

    shield = load_machine(PAPER_SHIELD)
    episode = read_prob2trace(trace, 0, HIGHWAY)
    states = [dict(s) for s in episode.states]
    assert states
    cols = Columns.from_states(states)
    for prop in load_properties(AUTHORS_RSQRT).properties:
        node = shield.check_formula(prop.predicate, file=str(AUTHORS_RSQRT))
        scalar = [shield.compile(node, source=prop.predicate)({**shield.constants, **s})
                  for s in states]
        batch = BatchFormula(node, shield.constants, source=prop.predicate)(cols)
        assert [bool(v) for v in batch] == scalar, prop.name


def test_the_string_functions_refuse_a_string_over_the_limit_before_building_it(capsys):
    """STRING_JOIN of large strings reached 4 GB; now the size is checked first."""
    from tests.helpers import run
    from tracecheck.b.library import MAX_STRING

    join = 'STRING_JOIN(%i.(i : 1..2000 | STRING_JOIN(%j.(j : 1..1000 | "abcdefghij"), "")), "")'
    code, out, err = run(capsys, "eval", f"STRING_LENGTH({join})")
    assert code == 2 and out == "", err
    assert (f"STRING_JOIN would build a string of 20,000,000 characters; tracecheck builds "
            f"strings of up to {MAX_STRING:,}") in " ".join(err.split())
    half = f'STRING_JOIN(%j.(j : 1..{MAX_STRING // 64} | "{"abcdefgh" * 8}"), "")'
    code, out, err = run(capsys, "eval", f"STRING_LENGTH(STRING_APPEND({half}, {half}))")
    assert code == 2 and f"STRING_APPEND would build a string of {2 * MAX_STRING:,}" in \
        " ".join(err.split())
    code, out, _ = run(capsys, "eval", 'STRING_JOIN(["a", "b"], "-")')
    assert (code, out.strip()) == (0, '"a-b"')
