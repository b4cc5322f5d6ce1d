"""Proofs over every state with z3: obligations, counterexamples that tracecheck's evaluator
confirms, the symbolic diff, and constructs that cannot be translated."""

from __future__ import annotations

import json
import re

import pytest

from tests.helpers import ROOT, run
from tracecheck.b.machine import load_machine_text
from tracecheck.checking.shield import load_shield

pytest.importorskip("z3")

from tracecheck.checking.proving import prove, symbolic_diff  # noqa: E402

LIGHTS = """
MACHINE Lights
SETS Cars = {c1, c2, c3}
VARIABLES speed, waiting, X
INVARIANT speed : REAL & waiting <: Cars & X : Cars --> REAL & speed >= 0.0
INITIALISATION speed := 0.0 || waiting := {} || X := Cars * {0.0}
OPERATIONS
  GO = SELECT waiting = {} & speed < 30.0 THEN skip END;
  STOP = SELECT #c.(c : waiting & X(c) < 10.0) THEN skip END
END
"""


@pytest.fixture
def lights(tmp_path):
    path = tmp_path / "Lights.mch"
    path.write_text(LIGHTS)
    return path


def test_the_paper_shield_is_deadlock_free_and_keeps_its_distance():
    machine = load_shield("paper").machine
    results = prove(machine, deadlock_free=True, well_defined=True, implies=(
        ("FASTER", "not(#v.(v : PresentVehicles \\ {EgoVehicle} & VehiclesX(v) > 0.0 & "
                   "VehiclesX(v) < 40.0 & VehiclesY(v) < 3.5 & VehiclesY(v) > -3.5))"),))
    assert [(r.obligation[:14], r.status) for r in results] == [
        ("deadlock-free", "proved"), ("FASTER => not(", "proved"),
        ("well-defined g", "proved")]


def test_a_deadlock_is_a_state_the_evaluator_confirms(capsys, lights, tmp_path):
    folder = tmp_path / "cx"
    code, out, err = run(capsys, "prove", str(lights), "--deadlock-free", "--counterexamples",
                         str(folder))
    assert code == 1, err
    assert out.startswith("deadlock-free: counterexample\n  no operation is enabled: ")
    (state,) = folder.glob("*.json")
    code, out, _ = run(capsys, "guards", str(lights), "--state", str(state))
    assert code == 0 and out.splitlines()[0] == "enabled: (none: deadlock)"
    # the deadlock needs a waiting car at 10 m or more, or speed 30 or more: assume it away
    code, out, _ = run(capsys, "prove", str(lights), "--deadlock-free",
                       "--assume", "speed < 30.0", "--assume", "waiting = {}")
    assert code == 0 and out.strip() == "deadlock-free: proved"


def test_implications_and_their_counterexamples(capsys, lights):
    code, out, _ = run(capsys, "prove", str(lights), "--implies", "GO => speed < 30.0",
                       "--implies", "STOP => speed > 0.0", "--json")
    results = json.loads(out)
    assert code == 1
    assert [(r["obligation"], r["status"]) for r in results] == [
        ("GO => speed < 30.0", "proved"), ("STOP => speed > 0.0", "counterexample")]
    state = results[1]["state"]
    assert float(state["speed"]) <= 0.0 and state["waiting"] != "{}"


def test_what_cannot_be_translated_is_unknown_with_its_place(capsys, tmp_path):
    path = tmp_path / "Seq.mch"
    path.write_text(LIGHTS.replace("speed < 30.0 THEN", "size([1, 2]) < 2 THEN"))
    code, out, _ = run(capsys, "prove", str(path), "--deadlock-free", "--implies",
                       "STOP => speed >= 0.0")
    assert code == 3
    assert out.splitlines()[0].startswith(f"deadlock-free: unknown ({path}:8:")
    assert "cannot translate" in out.splitlines()[0]
    assert out.splitlines()[-1] == "STOP => speed >= 0.0: proved"  # the others still decided
    code, _, err = run(capsys, "prove", str(path), "--implies", "GO speed")
    assert code == 2 and "--implies takes 'OP => PREDICATE'" in err
    code, _, err = run(capsys, "prove", str(path), "--implies", "JUMP => speed > 0.0")
    assert code == 2 and "unknown operation 'JUMP' in --implies" in err
    code, _, err = run(capsys, "prove", str(path))
    assert code == 2 and "nothing to prove" in err


def test_symbolic_diff_of_paper_and_strict(capsys):
    results = symbolic_diff(load_shield("paper").machine, load_shield("paper").machine)
    assert {r.status for r in results} == {"equivalent"}
    code, out, err = run(capsys, "diff", "--symbolic", "--shield", "paper", "--against",
                         "strict", "--json")
    assert code == 1, err  # they differ
    for r in json.loads(out):
        assert r["status"] == "counterexample" and r["disagreement"] is None
        if r["reason"]:  # the solver's exact reals sit on a boundary floats round across
            assert r["reason"].startswith("over the exact reals, at a boundary")
        else:
            assert r["decisions"]["paper (MACHINE PaperShield)"] != \
                r["decisions"]["strict (MACHINE StrictRSSShield)"]
    code, _, err = run(capsys, "diff", "runs.mcap", "--symbolic", "--shield", "paper",
                       "--against", "strict")
    assert code == 2 and "give no run files" in err


def test_a_solver_the_evaluator_contradicts_is_reported(capsys, lights, monkeypatch):
    """A state the solver's constraints still hold in after rounding, which the evaluator
    does not confirm: that is a bug in one of the two, exit 4."""
    from tracecheck.b.machine import Machine

    monkeypatch.setattr(Machine, "is_enabled", lambda self, op, state: op == "GO")
    code, _, err = run(capsys, "prove", str(lights), "--deadlock-free")
    assert code == 4 and "the solver and the evaluator disagree" in err


def test_a_relation_the_invariant_does_not_make_a_function_is_unknown():
    machine = load_machine_text(LIGHTS.replace("X : Cars --> REAL", "X : Cars <-> REAL"),
                                file="R.mch")
    (result,) = prove(machine, deadlock_free=True)
    assert result.status == "unknown"
    assert "cannot translate X to SMT: it is a relation the invariant does not make a " \
           "function" in result.reason


PAPER = (ROOT / "models" / "shields" / "paper.mch").read_text()
FRONT = ("FASTER => not(#v.(v : PresentVehicles - {EgoVehicle} & VehiclesX(v) > 0.0 & "
         "VehiclesX(v) < {d} & VehiclesY(v) > -3.5 & VehiclesY(v) < 3.5))")


def test_as_a_new_user_tries_it(capsys, tmp_path):
    """The issue's walk-through: the paper shield proved deadlock-free; a copy whose SLOWER
    lost "unless a lane change is possible" deadlocks in a state `guards` confirms; FASTER
    keeps 45 m (centres) but not 50 m."""
    code, out, _ = run(capsys, "prove", "paper", "--deadlock-free")
    assert code == 0 and out.strip() == "deadlock-free: proved"
    broken = tmp_path / "broken.mch"
    broken.write_text(PAPER.replace("SlowerFrontWithin(10.0) => not(LEFT_OK) & not(RIGHT_OK)",
                                    "not(SlowerFrontWithin(10.0))"))
    folder = tmp_path / "cx"
    code, out, err = run(capsys, "prove", str(broken), "--deadlock-free",
                         "--counterexamples", str(folder))
    assert code == 1, err
    (state,) = folder.glob("*.json")
    code, out, _ = run(capsys, "guards", str(broken), "--state", str(state))
    assert out.splitlines()[0] == "enabled: (none: deadlock)"
    code, out, _ = run(capsys, "prove", "paper", "--implies", FRONT.replace("{d}", "45.0"),
                       "--implies", FRONT.replace("{d}", "50.0"), "--json")
    assert code == 1
    assert [r["status"] for r in json.loads(out)] == ["proved", "counterexample"]


def test_a_changed_distance_changes_only_that_operation(capsys, tmp_path):
    changed = tmp_path / "paper40.mch"
    changed.write_text(PAPER.replace("not(FrontWithin(40.0))", "not(FrontWithin(35.0))"))
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", "paper", "--against",
                       str(changed), "--json")
    assert code == 1
    assert {r["obligation"]: r["status"] for r in json.loads(out)} == {
        "IDLE": "equivalent", "LANE_LEFT": "equivalent", "LANE_RIGHT": "equivalent",
        "FASTER": "counterexample", "SLOWER": "equivalent"}
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", "paper", "--against", "paper")
    assert code == 0 and out.count(": equivalent") == 5


def test_obligations_from_a_file(capsys, tmp_path):
    path = tmp_path / "paper.toml"
    path.write_text('deadlock_free = true\nassume = ["Crash = FALSE"]\n[[implies]]\n'
                    'operation = "FASTER"\npredicate = "' + FRONT.split(" => ")[1].replace(
                        "{d}", "45.0") + '"\n')
    code, out, err = run(capsys, "prove", "paper", "--obligations", str(path))
    assert code == 0, err
    assert out.splitlines() == ["deadlock-free: proved",
                                "FASTER => " + FRONT.split(" => ")[1].replace("{d}", "45.0")
                                + ": proved"]
    path.write_text("deadlock_free = 1\n")
    code, _, err = run(capsys, "prove", "paper", "--obligations", str(path))
    assert code == 2 and "deadlock_free must be true or false" in err
    path.write_text("[[implies]]\noperation = \"FASTER\"\n")
    code, _, err = run(capsys, "prove", "paper", "--obligations", str(path))
    assert code == 2 and "implies[1] needs operation = \"OP\" and predicate" in err


def test_a_counterexample_reads_like_a_road(capsys):
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", "paper", "--against",
                       "strict")
    reading = out.splitlines()[1]
    # which state the solver finds depends on its time budget: one where the guards differ,
    # or one where strict's guard is ill-defined (named in parentheses); both read as a road
    assert re.search(r"decide IDLE differently( \(IDLE's guard in .+? is not well-defined "
                     r"there\))?: EgoVehicle at x = ", reading), reading
    assert ", vx = " in reading


def test_an_environment_s_declared_ranges_are_assumed(capsys, tmp_path):
    grid = tmp_path / "Grid.mch"
    grid.write_text("MACHINE Grid\nVARIABLES x, y\nINVARIANT x : INTEGER & y : INTEGER\n"
                    "INITIALISATION x := 0 || y := 0\nOPERATIONS\n"
                    "  Move = SELECT x : 0..11 & y <= 3 & y >= 0 THEN skip END\nEND\n")
    code, out, _ = run(capsys, "prove", str(grid), "--deadlock-free")
    assert code == 1 and out.startswith("deadlock-free: counterexample")
    code, out, _ = run(capsys, "prove", str(grid), "--deadlock-free", "--env", "cliffwalking")
    assert code == 0 and out.strip() == "deadlock-free: proved"


def _prove_third(capsys, tmp_path):
    """``prove --deadlock-free --json`` of a machine whose only states are x = √2 over the
    reals (no float): (exit code, its one result, stderr)."""
    path = tmp_path / "Third.mch"
    path.write_text("MACHINE Third\nVARIABLES x\nINVARIANT x : REAL & x * x = 2.0 & x > 0.0\n"
                    "INITIALISATION x := 0.0\nOPERATIONS\n"
                    "  A = SELECT x < 0.0 THEN skip END\nEND\n")
    code, out, err = run(capsys, "prove", str(path), "--deadlock-free", "--json")
    (r,) = json.loads(out)
    return code, r, err


def test_a_counterexample_that_rounding_moves_across_a_boundary_is_not_a_disagreement(
        capsys, tmp_path):
    """Over the reals x = √2 makes x * x = 2.0 true; as the nearest float it is false. The
    solver's counterexample is reported as one over the reals, not as a disagreement."""
    code, r, err = _prove_third(capsys, tmp_path)
    assert code == 1, err
    assert r["status"] == "counterexample" and r["disagreement"] is None
    assert r["reason"].startswith("over the exact reals, at a boundary")


def test_a_disagreement_rounding_cannot_explain_is_reported_without_asking_again(
        capsys, tmp_path, monkeypatch):
    """Integers only: rounding to floats moves nothing, so an unconfirmed counterexample is a
    disagreement (exit 4) at once — even where the solver could not have re-checked it in
    time (it is not asked)."""
    import tracecheck.checking.confirming as confirming
    from tracecheck.b.machine import Machine

    asked = []
    holds_at = confirming.holds_at
    monkeypatch.setattr(confirming, "holds_at", lambda tr, model, cons, timeout_s, terms=():
                        asked.append(1)
                        or holds_at(tr, model, cons, 1e-9))
    monkeypatch.setattr(Machine, "is_enabled", lambda self, op, state: True)
    path = tmp_path / "Count.mch"
    path.write_text("MACHINE Count\nVARIABLES n\nINVARIANT n : INTEGER & n >= 0\n"
                    "INITIALISATION n := 0\nOPERATIONS\n"
                    "  Up = SELECT n < 10 THEN n := n + 1 END\nEND\n")
    code, _, err = run(capsys, "prove", str(path), "--deadlock-free")
    assert asked and code == 4 and "the solver and the evaluator disagree" in err


def test_a_counterexample_the_solver_cannot_place_in_time_is_unknown(capsys, tmp_path,
                                                                     monkeypatch):
    """Where the evaluator does not confirm the solver's state and the solver does not
    decide in time whether rounding to floats is why: not known, and not a disagreement
    (which says one of the two has a bug, exit 4) — as a loaded machine once reported."""
    import tracecheck.checking.confirming as confirming

    holds_at = confirming.holds_at
    monkeypatch.setattr(confirming, "holds_at",
                        lambda tr, model, cons, timeout_s, terms=(): holds_at(tr, model, cons, 1e-9))
    code, r, err = _prove_third(capsys, tmp_path)
    assert code == 3, err
    assert r["status"] == "unknown" and r["disagreement"] is None
    assert "did not decide in time whether rounding" in r["reason"]


def _distinct_terms(term) -> int:
    seen, todo = set(), [term]
    while todo:
        t = todo.pop()
        if t.get_id() not in seen:
            seen.add(t.get_id())
            todo.extend(t.children())
    return len(seen)


@pytest.mark.parametrize("n, value", [(0, 1), (1, 3), (5, 243), (64, 3 ** 64)])
def test_a_power_is_translated_by_repeated_squaring(n, value):
    """x ** n is about log n products (x ** 100000 unrolled hung past --timeout), and right."""
    import z3

    from tracecheck.checking.smt import Translator

    machine = load_machine_text("MACHINE P\nVARIABLES x\nINVARIANT x : INTEGER\n"
                                "INITIALISATION x := 0\nEND\n", file="P.mch")
    tr = Translator(machine)
    term = tr.translate(machine.parse(f"x ** {n}", kind="expression"), {})
    assert _distinct_terms(term) <= 2 * max(n, 1).bit_length() + 2
    assert z3.simplify(z3.substitute(term, (tr.variables["x"], z3.IntVal(3)))).as_long() == value


def test_a_power_above_the_limit_is_not_translated():
    from tracecheck.checking.smt import MAX_EXPONENT, Translator
    from tracecheck.errors import UnsupportedError

    machine = load_machine_text("MACHINE P\nVARIABLES x\nINVARIANT x : INTEGER\n"
                                "INITIALISATION x := 0\nEND\n", file="P.mch")
    with pytest.raises(UnsupportedError, match=f"a power with exponent {MAX_EXPONENT + 1} "
                                               f"\\(at most {MAX_EXPONENT}"):
        Translator(machine).translate(machine.parse(f"x ** {MAX_EXPONENT + 1}", kind="expression"),
                               {})
