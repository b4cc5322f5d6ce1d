"""tune where states, episodes and numbers are tricky: files whose columns differ in order or
elements, episodes alike in what the tuned guards read but not in what the others do, whole
numbers, numbers the PROPERTIES read, floats far larger than the number — each against
replay of the machine with the value written in."""

from __future__ import annotations

from fractions import Fraction

import pytest

from tests.helpers import run
from tracecheck.b import load_machine_text
from tracecheck.b.values import Elem, FuncValue
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import Shield, ShieldMachine
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.episodes.writer import new_header
from tracecheck.errors import InputError
from tracecheck.search.tune_target import check_range, resolve_target
from tracecheck.search.tuning import shield_with, tune


def _shield(text: str) -> Shield:
    machine = load_machine_text(text, kind=ShieldMachine)
    return Shield("edge", machine.sha256, "edge.mch", machine)


def _run(path, variables, actions, episodes) -> None:
    """Each episode: a list of (action, state); the last crashes."""
    eps = []
    for eid, rows in enumerate(episodes):
        steps = tuple(StepRecord(step=k, time=float(k), action=a, state=st, reward=0.0,
                                 crashed=k == len(rows) - 1) for k, (a, st) in enumerate(rows))
        eps.append(Episode(id=eid, steps=steps, end=make_end(steps), seed=eid))
    write_run(path, new_header("imported-simb", variables=variables, actions=actions), eps)


def _figures(paths, shield) -> tuple:
    r = replay(paths, shield)
    return r.infeasible_steps, r.infeasible_episodes, r.crashes_after_infeasible, \
        r.deadlock_states


def _check(paths, shield, target, values, low, high) -> None:
    result = tune(paths, shield, target, low, high, at=values)
    for v in values:
        want = _figures(paths, shield_with(shield, target, v))
        got = result.at[float(v)]
        assert (got.steps_blocked, got.episodes_blocked, got.crashes_after_blocked,
                got.deadlock_states) == want, v
        piece = next(p for p in result.pieces if p.contains(Fraction(v)))
        f = piece.figures
        assert (f.steps_blocked, f.episodes_blocked, f.crashes_after_blocked,
                f.deadlock_states) == want, v


XY = """MACHINE XY
CONSTANTS Lim
PROPERTIES Lim = 1.0
VARIABLES x, y
INVARIANT x : REAL & y : REAL
INITIALISATION x, y := 0.0, 0.0
OPERATIONS Go = SELECT x - y < Lim THEN skip END; Stop = SELECT x > 100.0 THEN skip END
END"""


def test_files_whose_columns_come_in_another_order_are_not_mixed_up(tmp_path):
    shield = _shield(XY)
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    _run(a, ["x", "y"], ["Go", "Stop"], [[(None, {"x": 2.0, "y": 5.0}),
                                          ("Go", {"x": 2.0, "y": 5.0})]])
    _run(b, ["y", "x"], ["Go", "Stop"], [[(None, {"y": 2.0, "x": 5.0}),
                                          ("Go", {"y": 2.0, "x": 5.0})]])
    _check([a, b], shield, resolve_target(shield.machine, param="Lim"),
           [-5.0, -3.0, 0.0, 2.0, 3.0, 5.0], -10.0, 10.0)


CARS = """MACHINE Cars
SETS C = {e1, e2, e3}
CONSTANTS Lim
PROPERTIES Lim = 5.0
VARIABLES f
INVARIANT f : C +-> REAL
INITIALISATION f := {}
OPERATIONS Go = SELECT e2 : dom(f) & f(e2) < Lim THEN skip END; Stay = SELECT 1 = 2 THEN skip END
END"""


def test_files_whose_functions_range_over_other_elements_are_not_mixed_up(tmp_path):
    shield = _shield(CARS)
    e1, e2, e3 = (Elem(n) for n in ("e1", "e2", "e3"))
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    _run(a, ["f"], ["Go", "Stay"], [[(None, {"f": FuncValue({e1: 1.0, e2: 9.0})}),
                                     ("Go", {"f": FuncValue({e1: 1.0, e2: 9.0})})]])
    _run(b, ["f"], ["Go", "Stay"], [[(None, {"f": FuncValue({e2: 1.0, e3: 9.0})}),
                                     ("Go", {"f": FuncValue({e2: 1.0, e3: 9.0})})]])
    _check([a, b], shield, resolve_target(shield.machine, param="Lim"),
           [0.5, 1.0, 5.0, 9.0, 9.5], 0.0, 10.0)


DEAD = """MACHINE Dead
CONSTANTS Lim
PROPERTIES Lim = 1.0
VARIABLES x, z
INVARIANT x : REAL & z : REAL
INITIALISATION x, z := 0.0, 0.0
OPERATIONS Go = SELECT x < Lim THEN skip END; Other = SELECT z > 0.0 THEN skip END
END"""


def test_episodes_alike_in_what_the_tuned_guards_read_keep_their_own_deadlocks(tmp_path):
    shield = _shield(DEAD)
    path = tmp_path / "d.mcap"
    one = [(None, {"x": 2.0, "z": 1.0}), ("Go", {"x": 2.0, "z": 1.0})]
    two = [(None, {"x": 2.0, "z": -1.0}), ("Go", {"x": 2.0, "z": -1.0})]
    _run(path, ["x", "z"], ["Go", "Other"], [one, two])
    _check([path], shield, resolve_target(shield.machine, param="Lim"), [0.5, 1.0, 3.0],
           0.0, 5.0)


INT = """MACHINE Int
CONSTANTS Reach
PROPERTIES Reach = 1
VARIABLES n
INVARIANT n : INTEGER
INITIALISATION n := 0
OPERATIONS Up = SELECT 2 * n < 2 * Reach + 1 THEN n := n + 1 END; Down = SELECT n > 0 THEN n := n - 1 END
END"""


def test_an_integer_is_tuned_over_whole_numbers_only(tmp_path, capsys):
    shield = _shield(INT)
    path = tmp_path / "i.mcap"
    _run(path, ["n"], ["Up", "Down"], [[(None, {"n": k}), ("Up", {"n": k + 1})]
                                        for k in range(4)])
    target = resolve_target(shield.machine, param="Reach")
    result = tune([path], shield, target, 0.0, 4.0, knee_too=True)
    assert all(p.whole and p.low.denominator == 1 and p.high.denominator == 1
               for p in result.pieces)
    assert [p.text() for p in result.pieces] == ["0", "1", "2", "3..4"]
    assert result.knee.value == int(result.knee.value)
    _check([path], shield, target, [0, 1, 2, 3, 4], 0.0, 4.0)
    mch = tmp_path / "int.mch"
    mch.write_text(INT)
    code, out, err = run(capsys, "tune", path, "-s", mch, "--param", "Reach=0..3", "--at", "1.5")
    assert code == 2 and "Reach is an INTEGER; give a whole number" in err
    code, out, err = run(capsys, "tune", path, "-s", mch, "--param", "Reach=0..3", "--grid",
                         "10000", "--format", "csv")
    assert code == 0, err
    assert out.splitlines()[1:] and [line.split(",")[0] for line in out.splitlines()[1:]] == \
        ["0", "1", "2", "3"]
    code, out, err = run(capsys, "tune", path, "-s", mch, "--param", "Reach=0..3")
    assert code == 0 and "exact for every value in [0, 3]: " in out  # not [0.0, 3.0]
    assert "  at 1 (the machine's; replay says the same)" in out, out


PROPS = """MACHINE Props
CONSTANTS Lim, Sq, Derived
PROPERTIES Lim = MARGIN * 2.0 & Sq = 2 & Derived = Sq + 1
DEFINITIONS MARGIN == 3.0
VARIABLES x, n
INVARIANT x : REAL & n : INTEGER
INITIALISATION x := 0.0 || n := 0
OPERATIONS Go = SELECT x < Lim + MARGIN & n < Derived + Sq THEN skip END
END"""


def test_a_number_the_properties_compute_other_constants_from_is_refused_saying_so():
    m = load_machine_text(PROPS)
    with pytest.raises(InputError, match="MARGIN is read by the PROPERTIES"):
        resolve_target(m, param="MARGIN")
    target = resolve_target(m, param="Sq")
    with pytest.raises(InputError, match=r"the PROPERTIES compute Derived from it "
                       r"\(`Derived = Sq \+ 1`\)"):
        check_range(m, target, 1.0, 3.0)


BIG = """MACHINE Big
CONSTANTS Off
PROPERTIES Off = 0.5
VARIABLES t, s
INVARIANT t : REAL & s : REAL
INITIALISATION t, s := 0.0, 0.0
OPERATIONS Go = SELECT t < s + Off THEN skip END; Wait = SELECT 1 = 1 THEN skip END
END"""


def test_a_value_reported_on_its_own_is_what_replay_says_even_where_floats_round(tmp_path):
    """``s + Off`` rounds at s = 1.7e9: a value within rounding of the exact breakpoint is
    reported as replay of the rewritten machine gives it."""
    shield = _shield(BIG)
    s = 1.7e9
    path = tmp_path / "b.mcap"
    _run(path, ["t", "s"], ["Go", "Wait"], [[(None, {"t": s + 0.5, "s": s}),
                                            ("Go", {"t": s + 0.5, "s": s})]])
    target = resolve_target(shield.machine, param="Off")
    values = [0.5, 0.50000001, 0.5000001, 0.6]
    result = tune([path], shield, target, 0.0, 1.0, at=values)
    for v in values:
        assert result.at[v].steps_blocked == _figures([path], shield_with(shield, target, v))[0]
