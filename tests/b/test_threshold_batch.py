"""The batch path of the threshold sets (tracecheck.b.threshold_batch): on every row it decides,
the same set as the exact path (tracecheck.b.threshold); rows it cannot decide (roots too close
to call, ill-defined terms, shapes it does not take) left to the exact path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tracecheck.b import load_machine_text
from tracecheck.b.columns import Columns
from tracecheck.b.threshold import ThresholdCompiler, values_of
from tracecheck.b.threshold_batch import ThresholdBatch
from tracecheck.b.values import Elem, FuncValue

M = load_machine_text("""MACHINE T
SETS Cars = {c1, c2, c3, c4}
VARIABLES x, n, pos, speed, here
INVARIANT x : REAL & n : INTEGER & pos : Cars --> REAL & speed : Cars --> REAL & here <: Cars
INITIALISATION x := 0.0 || n := 0 || pos := Cars * {0.0} || speed := Cars * {0.0} ||
    here := Cars
END""")
CARS = tuple(Elem(f"c{i}") for i in range(1, 5))
PAPER = Path(__file__).resolve().parents[3] / "shared" / "data" / "paper-traces" / "simb"

FORMULAS = [
    "x < d + 1.0",
    "x <= 2.0 * d & d < 10.0",
    "not(x < d) or d > 7.0",
    "x = d or d > 7.0",
    "x /= d",
    "d > 0.0 => x > d",
    "(d > 1.0) <=> (x > d)",
    "d - x / 2.0 > IF x > 1.0 THEN 1.0 ELSE 2.0 END",
    "d : NATURAL & d < x",
    "d : 0..n",
    "x : d..d + 5.0",
    "#c.(c : here & pos(c) < d + 5.0)",
    "!c.(c : here => pos(c) - d >= speed(c) * 2.0)",
    "#c.(c : here & pos(c) > d & pos(c) < d + 5.0)",
    "!c.(c : here & pos(c) > 0.0 & not(#e.(e : here & pos(e) > 0.0 & pos(e) < pos(c))) "
    "=> pos(c) - d >= speed(c))",
    "!c.(c : here => #e.(e : Cars & pos(e) > pos(c) - d))",
    "!c.(c : here => pos(c) - d >= speed(c) ** 2 / 3.0 + x ** 3)",
    "!c.(c : here => pos(c) - IF speed(c) > 0.0 THEN 2.0 * d ELSE d / 3.0 END > RABS(x))",
]


def _states(count: int, seed: int, ties: bool = False) -> list[dict]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        pos = rng.choice([-5.0, 0.0, 5.0, 12.5], size=4) if ties else \
            np.round(rng.uniform(-20, 40, size=4), 3)
        out.append({"x": float(np.round(rng.uniform(-5, 12), 2)), "n": int(rng.integers(-2, 6)),
                    "pos": FuncValue({c: float(p) for c, p in zip(CARS, pos)}),
                    "speed": FuncValue({c: float(s) for c, s in zip(
                        CARS, np.round(rng.uniform(-3, 3, size=4), 2))}),
                    "here": frozenset(c for c, k in zip(CARS, rng.random(4)) if k < 0.7)})
    return out


def _batch(text: str, states: list[dict]):
    node = M.parse(text)
    batch = ThresholdBatch(M, "d", {"g": node})
    got = batch.sets(Columns.from_states(states))["g"]
    return node, got


@pytest.mark.parametrize("text", FORMULAS)
@pytest.mark.parametrize("ties", [False, True], ids=["spread", "ties"])
def test_every_row_decided_has_the_exact_paths_set(text, ties):
    states = _states(300, seed=len(text), ties=ties)
    node, got = _batch(text, states)
    decided = [i for i, v in enumerate(got) if v is not None]
    for i in decided:
        assert got[i] == values_of(M, node, "d", states[i]), (text, states[i])
    assert len(decided) >= (100 if ties else 280), f"{text}: {len(decided)} of 300 decided"


def test_equal_roots_of_different_relations_are_one_breakpoint_computed_exactly():
    # pos(c) - d >= 0 and pos(c) - d >= speed(c) meet where speed(c) = 0: the same root
    text = "!c.(c : here => pos(c) - d >= 0.0 & pos(c) - d >= speed(c))"
    states = [{**s, "speed": FuncValue({c: 0.0 for c in CARS})} for s in _states(50, 7)]
    node, got = _batch(text, states)
    assert all(v is not None for v in got)
    assert got == [values_of(M, node, "d", s) for s in states]


def test_roots_too_close_to_call_in_floats_are_left_to_the_exact_path():
    # the two roots 0.1 + 0.2 and 0.3 differ by one unit in the last place
    states = [{**_states(1, 1)[0], "x": 0.1}]
    node, got = _batch("x + 0.2 < d & d < 0.3 or d > 5.0", states)
    assert got == [None]
    exact = values_of(M, node, "d", states[0])
    assert exact.text("d") == "d > 5.0"  # 0.1 + 0.2 > 0.3 exactly: the first part holds nowhere
    # a coefficient of the number that floats make zero (d - d) may not be zero exactly
    assert _batch("x < 3.0 & d > d", states)[1] == [None]


def test_a_row_with_an_ill_defined_term_is_left_to_the_exact_path_and_the_rest_decided():
    states = _states(20, 3)
    states[4] = {**states[4], "x": 0.0}
    node, got = _batch("d > 1.0 / x", states)
    assert got[4] is None
    assert all(v == values_of(M, node, "d", s) for k, (v, s) in enumerate(zip(got, states))
               if k != 4)


def test_a_guard_of_a_shape_the_batch_path_does_not_take_is_left_out():
    # a quantifier over numbers (not elements): the exact path takes it, this one does not
    node = M.parse("#y.(y : {1.0, 2.0} & y > d)")
    ThresholdCompiler(M, "d").pred(node)
    batch = ThresholdBatch(M, "d", {"g": node, "h": M.parse("x < d")})
    states = _states(5, 2)
    got = batch.sets(Columns.from_states(states))
    assert got["g"] == [None] * 5 and None not in got["h"]
    assert batch.ops == ["h"]


@pytest.mark.skipif(not PAPER.is_dir(), reason="the paper's traces are not here")
@pytest.mark.parametrize("shield,spec", [("strict", {"param": "VehLen"}),
                                         ("paper", {"literal": "FASTER:40.0"})])
def test_on_the_paper_traces_every_state_is_decided_with_the_exact_paths_set(shield, spec):
    from tracecheck.checking.shield import load_shield
    from tracecheck.interop import import_simb
    from tracecheck.live.envs.highway import HIGHWAY
    from tracecheck.search.tune_target import resolve_target

    sh = load_shield(shield)
    target = resolve_target(sh.machine, **spec)
    states = [s.state for e in import_simb([PAPER / "base_shield"], vocab=HIGHWAY)
              for s in e.steps][:600]
    batch = ThresholdBatch(sh.machine, target.name, target.guards, target.integer)
    assert batch.ops == list(target.guards)
    got = batch.sets(Columns.from_states(states))
    for op, sets in got.items():
        exact = ThresholdCompiler(sh.machine, target.name, (), target.integer).pred(
            target.guards[op])
        assert all(v is not None for v in sets), op
        assert sets == [exact(sh.machine.env(s)) for s in states], op


def test_the_terms_are_the_very_numbers_of_the_scalar_path_powers_included():
    # numpy's x ** 2 and x ** 3 differ from Python's in the last bit for some reals; the
    # exact breakpoints are computed from these terms, so they must be the engine's own
    from tracecheck.b.scope import EXPR
    from tracecheck.b.vector import BoundFormulas

    rng = np.random.default_rng(5)
    xs = (rng.standard_normal(20000) * rng.choice([1e-3, 1.0, 30.0, 1e5], 20000)).tolist()
    cols = Columns.from_states([{"x": v} for v in xs])
    node = M.parse("x ** 2 + x ** 3 / 7.0", kind=EXPR)
    got = np.asarray(BoundFormulas(M.base_env, cols).compile(node)()[1]).reshape(-1)
    assert got.tolist() == [v ** 2 + v ** 3 / 7.0 for v in xs]


@pytest.mark.parametrize("text", ["d <= x or 3.0 * d >= 1.0", "x = d or 3.0 * d /= 1.0"])
def test_roots_equal_in_floats_but_not_exactly_are_left_to_the_exact_path(text):
    # x = 1/3 as a float and the root of 3 d = 1 are the same float, not the same number:
    # the set changes between them although nothing changes at the float
    state = {**_states(1, 1)[0], "x": 1 / 3}
    node, got = _batch(text, [state])
    assert got[0] is None or got[0] == values_of(M, node, "d", state)
    assert values_of(M, node, "d", state).text("d") != "every value"
