"""STL robustness on episodes, cross-checked against rtamt's discrete-time offline monitor."""

from __future__ import annotations

import random

import numpy as np
import pytest

from tracecheck.b.machine import load_machine_text
from tracecheck.b.columns import Columns
from tracecheck.checking.stl import episode_robustness, parse_stl, robustness
from tracecheck.episodes.columns import RunColumns
from tracecheck.errors import BSyntaxError

SIGNALS = load_machine_text("""
MACHINE Signals
VARIABLES x, y
INVARIANT x : REAL & y : REAL
INITIALISATION x := 0.0 || y := 0.0
OPERATIONS op = skip
END""", file="Signals.mch")


def columns(episodes: list[tuple[list[float], list[float]]]) -> RunColumns:
    xs = [v for x, _ in episodes for v in x]
    ys = [v for _, y in episodes for v in y]
    lengths = [len(x) for x, _ in episodes]
    n = len(xs)
    states = Columns(n=n, elements=())
    states.numbers["x"], states.numbers["y"] = np.array(xs), np.array(ys)
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    return RunColumns(path="signals", episode_ids=np.arange(len(episodes)), starts=starts,
                      episode=np.repeat(np.arange(len(episodes)), lengths),
                      step=np.concatenate([np.arange(m) for m in lengths]),
                      time=np.zeros(n), action=np.full(n, -1, dtype=np.int16), action_names=(),
                      reward=np.zeros(n), crashed=np.zeros(n, dtype=bool), states=states)


def random_formula(rng: random.Random, depth: int = 0) -> tuple[str, str]:
    """The same formula in tracecheck's syntax and in rtamt's."""
    if depth > 2 or rng.random() < 0.3:
        v, op, c = rng.choice("xy"), rng.choice([">=", "<=", ">", "<"]), round(
            rng.uniform(-1, 1), 2)
        return f"{{{v} {op} {c}}}", f"({v} {op} {c})"
    kind = rng.choice(["not", "and", "or", "implies", "next", "always", "eventually",
                       "always[]", "eventually[]"])
    a, ra = random_formula(rng, depth + 1)
    if kind in ("not", "next", "always", "eventually"):
        ours = {"not": "not", "next": "X", "always": "G", "eventually": "F"}[kind]
        return f"{ours}({a})", f"{kind}({ra})"
    if kind.endswith("[]"):
        lo = rng.randint(0, 2)
        hi = lo + rng.randint(0, 3)
        ours = "G" if kind.startswith("always") else "F"
        return f"{ours}[{lo},{hi}]({a})", f"{kind[:-2]}[{lo},{hi}]({ra})"
    b, rb = random_formula(rng, depth + 1)
    ours = {"and": "&", "or": "or", "implies": "=>"}[kind]
    return f"({a}) {ours} ({b})", f"({ra}) {kind} ({rb})"


def test_robustness_is_rtamt_s_on_a_thousand_random_signals_and_formulas():
    rtamt = pytest.importorskip("rtamt")
    rng = random.Random(20261127)
    for case in range(1000):
        n = rng.randint(2, 8)  # rtamt needs two samples
        xs = [round(rng.uniform(-2, 2), 2) for _ in range(n)]
        ys = [round(rng.uniform(-2, 2), 2) for _ in range(n)]
        ours, theirs = random_formula(rng)
        spec = rtamt.StlDiscreteTimeSpecification()
        spec.declare_var("x", "float")
        spec.declare_var("y", "float")
        spec.spec = theirs
        spec.parse()
        expected = [v for _, v in spec.evaluate({"time": list(range(n)), "x": xs, "y": ys})]
        got = robustness(parse_stl(ours, SIGNALS), columns([(xs, ys)]), SIGNALS)
        assert np.allclose(got, expected), (case, ours, xs, ys, list(got), expected)


def test_episodes_are_kept_apart():
    cols = columns([([1.0, 2.0, 3.0], [0.0] * 3), ([-1.0, 5.0], [0.0] * 2)])
    f = parse_stl("G({x >= 0.0})", SIGNALS)
    assert list(robustness(f, cols, SIGNALS)) == [1.0, 2.0, 3.0, -1.0, 5.0]
    assert list(episode_robustness(parse_stl("F[0,1]({x > 2.5})", SIGNALS), cols,
                                   SIGNALS)) == [-0.5, 2.5]


def test_bounded_windows_are_the_sample_by_sample_definition():
    """The O(n) windows against the obvious loop: random episodes, bounds small, past the
    end, and far past any integer numpy holds."""
    rng = random.Random(7)
    for case in range(300):
        eps = [([round(rng.uniform(-2, 2), 2) for _ in range(rng.randint(1, 9))], None)
               for _ in range(rng.randint(1, 4))]
        eps = [(x, [0.0] * len(x)) for x, _ in eps]
        lo = rng.choice([0, 1, 2, 4, 12, 10 ** 18])
        hi = lo + rng.choice([0, 1, 2, 5, 30, 10 ** 18])
        op = rng.choice("GF")
        got = robustness(parse_stl(f"{op}[{lo},{hi}]({{x > 0.0}})", SIGNALS), columns(eps),
                         SIGNALS)
        want = []
        for x, _ in eps:
            for i in range(len(x)):
                window = x[i + lo:i + hi + 1] if i + lo < len(x) else []
                want.append((min if op == "G" else max)(window, default=np.inf if op == "G"
                                                        else -np.inf))
        assert list(got) == want, (case, op, lo, hi, eps)


def test_any_bound_answers_at_once():
    """G[0,100000000] looped over the bound (minutes); a bound beyond int64 overflowed."""
    import time

    cols = columns([([1.0, 2.0, 3.0] * 100, [0.0] * 300), ([-1.0, 5.0], [0.0] * 2)])
    start = time.perf_counter()
    for text in ("G[0,100000000]({x >= 0.0})", "F[3,99999999999999999999]({x > 2.5})",
                 "G[99999999999999999999,99999999999999999999]({x > 0.0})"):
        robustness(parse_stl(text, SIGNALS), cols, SIGNALS)
    assert time.perf_counter() - start < 5
    assert list(episode_robustness(parse_stl("G[0,100000000]({x >= 0.0})", SIGNALS), cols,
                                   SIGNALS)) == [1.0, -1.0]


@pytest.mark.parametrize("text,message", [
    ("G({x = 1.0})", "the atom {x = 1.0} is not a comparison"),
    ("G([op])", "'[op]' has no robustness"),  # as written, not 'next_op'
    ("G(e(op))", "'e(op)' has no robustness"),
    ("{x >= 1}", "in the atom {x >= 1}: type mismatch"),
    ("F[2,1] {x > 0.0}", "the bounds [2,1] are empty"),
    ("{x > 0.0} U {y > 0.0}", "'U' has no robustness"),
])
def test_stl_formulas_with_mistakes(text, message):
    with pytest.raises(BSyntaxError) as info:
        parse_stl(text, SIGNALS)
    assert message in str(info.value)
