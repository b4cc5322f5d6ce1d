"""The built-in ``paper`` shield makes the authors' decision on every state.

Two references: the authors' own machine (HighwayEnvironment2.mch, read from ../shared and
skipped where absent) and an independent plain-numpy encoding of Table 1 below, written from
the paper's text and Listing 2 (centre positions; "less than 40 m" is a centre within 45 m
ahead and 3.5 m to either side), with the bounds of the authors' machine.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tracecheck.b.machine import load_machine
from tracecheck.b.notation import parse_literal
from tracecheck.b.values import Elem, FuncValue
from tracecheck.b.columns import Columns
from tracecheck.checking.shield import load_shield


SHARED = Path(__file__).resolve().parents[3] / "shared" / "data"
PAPER_MODELS = SHARED / "paper-models"
PAPER_TRACES = SHARED / "paper-traces"
AUTHORS = PAPER_MODELS / "HighwayEnvironment" / "HighwayEnvironment2.mch"
ACTIONS = ("IDLE", "LANE_LEFT", "LANE_RIGHT", "FASTER", "SLOWER")
ELEMENTS = tuple(Elem(e) for e in ("EgoVehicle", "Vehicles2", "Vehicles3", "Vehicles4",
                                   "Vehicles5"))


def table1(x, y, vx, present, ego_y):
    """Table 1 in numpy: x, y, vx are (n, 4) arrays of the other vehicles (relative to the
    ego vehicle), present an (n, 4) mask, ego_y the ego vehicle's lateral position."""
    def any_(cond):
        return np.any(present & cond, axis=1)

    def lane(lo, hi):
        return (y > lo) & (y < hi)

    front = (x > 0) & (y < 3.5) & (y > -3.5)
    left_lane, right_lane = lane(-6.0, -2.0), lane(2.0, 6.0)
    behind_faster = (x > -25) & (x <= -15) & (vx > 0)
    ahead_slower = (x > 15) & (x <= 35) & (vx < 0)
    left_ok = (ego_y > 1.0) & ~any_(left_lane & (behind_faster | ((x > -15) & (x <= 15))
                                                 | ahead_slower))
    right_ok = (ego_y < 7.0) & ~any_(right_lane & (behind_faster | ((x > -15) & (x < 15))
                                                   | ahead_slower))
    return {
        "IDLE": ~any_(front & (x < 35) & (vx < 0)),
        "LANE_LEFT": left_ok,
        "LANE_RIGHT": right_ok,
        "FASTER": ~any_(front & (x < 45)),
        "SLOWER": ~any_(front & (x < 15) & (vx < 0)) | (~left_ok & ~right_ok),
    }


def near(rng, n, marks, spread):
    """Values at, just beside, and between the boundaries ``marks``."""
    pick = rng.choice(np.asarray(marks, dtype=float), size=n)
    offset = rng.choice([0.0, 0.0, 1e-9, -1e-9, 0.01, -0.01, 0.3, -0.3], size=n)
    uniform = rng.uniform(-spread, spread, size=n)
    return np.where(rng.random(n) < 0.8, pick + offset, uniform)


def random_columns(n: int, seed: int):
    """n random states near every boundary of Table 1, as columns and as raw arrays."""
    rng = np.random.default_rng(seed)
    shape = (n, 4)
    x = near(rng, n * 4, [-25, -15, 0, 15, 35, 45, 5, -5], 60).reshape(shape)
    y = near(rng, n * 4, [-6, -3.5, -2, 0, 2, 3.5, 6, -4, 4], 10).reshape(shape)
    vx = near(rng, n * 4, [0.0, 3.0, -3.0], 10).reshape(shape)
    present = rng.random(shape) < 0.8
    ego_y = near(rng, n, [0.0, 1.0, 4.0, 7.0, 8.0], 10)
    cols = Columns(n=n, elements=ELEMENTS)
    defined = np.ones((n, 5), dtype=bool)

    def with_ego(others, ego):
        return np.concatenate([ego[:, None], others], axis=1)

    zero = np.zeros(n)
    cols.functions["VehiclesX"] = (with_ego(x, rng.uniform(100, 300, n)), defined)
    cols.functions["VehiclesY"] = (with_ego(y, ego_y), defined)
    cols.functions["VehiclesVx"] = (with_ego(vx, rng.uniform(20, 30, n)), defined)
    for name in ("VehiclesVy", "VehiclesAx", "VehiclesAy"):
        cols.functions[name] = (np.zeros((n, 5)), defined)
    cols.masks["PresentVehicles"] = with_ego(present, np.ones(n, dtype=bool))
    cols.booleans["Crash"] = np.zeros(n, dtype=bool)
    cols.numbers["Reward"] = zero
    return cols, (x, y, vx, present, ego_y)


@pytest.fixture(scope="module")
def paper():
    return load_shield("paper").machine


def test_paper_equals_an_independent_encoding_of_table1_on_a_million_states(paper):
    for seed in range(4):
        cols, raw = random_columns(250_000, seed)
        ours = paper.enabled_batch(cols)
        reference = table1(*raw)
        for action in ACTIONS:
            diff = np.flatnonzero(ours[action] != reference[action])
            assert diff.size == 0, (action, seed, cols.row(int(diff[0])))


def test_batch_and_scalar_paths_agree_on_boundary_states(paper):
    cols, _ = random_columns(400, 99)
    batch = paper.enabled_batch(cols)
    for i in range(cols.n):
        scalar = paper.enabled(cols.row(i))
        assert scalar == {a for a in ACTIONS if batch[a][i]}, cols.row(i)


@pytest.fixture(scope="module")
def authors():
    if not AUTHORS.exists():
        pytest.skip(f"the authors' machines are not at {PAPER_MODELS}")
    return load_machine(AUTHORS)


def test_paper_equals_the_authors_machine_on_random_boundary_states(paper, authors):
    cols, _ = random_columns(100_000, 7)
    ours, theirs = paper.enabled_batch(cols), authors.enabled_batch(cols)
    for action in ACTIONS:
        diff = np.flatnonzero(ours[action] != theirs[action])
        assert diff.size == 0, (action, cols.row(int(diff[0])))


def test_paper_equals_the_authors_machine_on_the_paper_traces(paper, authors):
    if not PAPER_TRACES.is_dir():
        pytest.skip(f"the paper's traces are not at {PAPER_TRACES}")
    states = [{k: parse_literal(v) for k, v in act["fixedVariables"].items()}
              for f in sorted((PAPER_TRACES / "simb").rglob("*.json"))
              for act in json.loads(f.read_text())["activations"] if act.get("fixedVariables")]
    assert len(states) > 1000
    cols = Columns.from_states(states, ELEMENTS)
    ours, theirs = paper.enabled_batch(cols), authors.enabled_batch(cols)
    for action in ACTIONS:
        assert np.array_equal(ours[action], theirs[action]), action


_X = st.sampled_from([-25.0, -15.0, 0.0, 15.0, 35.0, 45.0]).flatmap(
    lambda b: st.sampled_from([b, b - 0.01, b + 0.01, b - 1e-9, b + 1e-9]))
_Y = st.sampled_from([-6.0, -3.5, -2.0, 2.0, 3.5, 6.0]).flatmap(
    lambda b: st.sampled_from([b, b - 0.01, b + 0.01]))
_VX = st.sampled_from([-1.0, 0.0, 1.0])


@settings(max_examples=300, deadline=None)
@given(others=st.lists(st.tuples(_X, _Y, _VX, st.booleans()), min_size=4, max_size=4),
       ego_y=st.sampled_from([0.0, 0.99, 1.0, 1.01, 4.0, 6.99, 7.0, 7.01, 8.0]))
def test_paper_decides_like_table1_on_states_at_the_boundaries(others, ego_y):
    machine = load_shield("paper").machine
    x, y, vx, present = (np.array([[o[i] for o in others]]) for i in range(4))
    expected = {a for a, ok in table1(x, y, vx, present.astype(bool), np.array([ego_y])).items()
                if ok[0]}
    names = ELEMENTS[1:]
    state = {
        "Crash": False, "Reward": 0.0,
        "PresentVehicles": frozenset([ELEMENTS[0]] + [n for n, o in zip(names, others) if o[3]]),
        "VehiclesX": FuncValue({ELEMENTS[0]: 200.0, **{n: o[0] for n, o in zip(names, others)}}),
        "VehiclesY": FuncValue({ELEMENTS[0]: ego_y, **{n: o[1] for n, o in zip(names, others)}}),
        "VehiclesVx": FuncValue({ELEMENTS[0]: 25.0, **{n: o[2] for n, o in zip(names, others)}}),
        **{v: FuncValue({e: 0.0 for e in ELEMENTS})
           for v in ("VehiclesVy", "VehiclesAx", "VehiclesAy")},
    }
    assert machine.enabled(state) == expected


def test_diff_of_paper_against_the_authors_machine_on_the_paper_traces_is_empty(tmp_path,
                                                                                capsys):
    from tracecheck.cli import main

    if not PAPER_TRACES.is_dir() or not AUTHORS.exists():
        pytest.skip("the paper's traces or the authors' machines are not in ../shared")
    run = tmp_path / "paper.mcap"
    with pytest.raises(SystemExit):
        main(["import", "simb", str(PAPER_TRACES / "simb" / "base"),
              str(PAPER_TRACES / "simb" / "base_shield"), "-o", str(run)])
    capsys.readouterr()
    with pytest.raises(SystemExit) as stop:
        main(["diff", str(run), "--shield", "paper", "--against", str(AUTHORS),
              "--fail-on-change"])
    out = " ".join(capsys.readouterr().out.split())  # lines wrap between words
    assert stop.value.code in (0, None), out
    assert "changed steps: 0" in out and "states whose enabled set differs: 0" in out


RSS = [PAPER_MODELS / "HighwayEnvironment" / "HighwayEnvironment_RSS_v2.mch",
       PAPER_MODELS / "HighwayEnvironment" / "HighwayEnvironment_RSS.mch"]


def _shield(spec):
    if isinstance(spec, Path):
        if not spec.exists():
            pytest.skip(f"the authors' machines are not at {PAPER_MODELS}")
        return load_machine(spec)
    return load_shield(spec).machine


def _paper_states() -> list[dict]:
    if not PAPER_TRACES.is_dir():
        pytest.skip(f"the paper's traces are not at {PAPER_TRACES}")
    return [{k: parse_literal(v) for k, v in act["fixedVariables"].items()}
            for f in sorted((PAPER_TRACES / "simb").rglob("*.json"))
            for act in json.loads(f.read_text())["activations"] if act.get("fixedVariables")]


def _scalar(machine, state):
    try:
        return frozenset(machine.enabled(state))
    except Exception as exc:  # noqa: BLE001 - the class is compared below
        return type(exc)


@pytest.mark.parametrize("spec", ["paper", "strict", *RSS],
                         ids=["paper", "strict", "RSS_v2", "RSS"])
@pytest.mark.parametrize("where", ["random", "paper traces"])
def test_batch_path_decides_like_the_scalar_path_state_by_state(spec, where):
    """The comprehension-heavy RSS shields (sets of vehicles per lane, images, min/max, LET,
    IF-ELSIF) on the batch path: the scalar path's answer in every state, and its error
    where a state makes a guard ill-defined."""
    machine = _shield(spec)
    if where == "random":
        cols, _ = random_columns(300, 5)
        states = [cols.row(i) for i in range(cols.n)]
    else:
        states = _paper_states()[::3]
    expected = [_scalar(machine, s) for s in states]
    good = [s for s, e in zip(states, expected) if isinstance(e, frozenset)]
    batch = machine.enabled_batch(Columns.from_states(good, ELEMENTS))
    got = [frozenset(a for a in batch if batch[a][i]) for i in range(len(good))]
    assert got == [e for e in expected if isinstance(e, frozenset)]
    for state, error in [(s, e) for s, e in zip(states, expected) if isinstance(e, type)][:20]:
        with pytest.raises(error):
            machine.enabled_batch(Columns.from_states([state], ELEMENTS))
