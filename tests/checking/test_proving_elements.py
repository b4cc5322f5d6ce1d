"""prove and diff --symbolic over enumerated sets and grid maps (issue 42): an element
variable, a function applied to one, a total function over a finite set of integers or
pairs of integers — the built-in grid shields included — and each counterexample confirmed
by the evaluator."""

from __future__ import annotations

import json

import pytest

from tests.helpers import run

pytest.importorskip("z3")

ENUM = """MACHINE EnumShield
SETS CELL = {FREE, WALL, GOAL}
VARIABLES ahead, x
INVARIANT ahead : CELL & x : 0..3
INITIALISATION ahead := FREE || x := 0
OPERATIONS
    Forward = SELECT ahead /= WALL & ahead : {FREE, GOAL} THEN skip END;
    Turn = SELECT ahead = WALL or x = 0 THEN skip END
END
"""

GRID = """MACHINE GridShield
SETS CELLS = {ICE, HOLE}
CONSTANTS cost
PROPERTIES cost : CELLS --> 0..3 & cost = {ICE |-> 1, HOLE |-> 3}
VARIABLES pos, map, here
INVARIANT pos : 0..15 & map : 0..15 --> CELLS & here : CELLS
INITIALISATION pos := 0 || map :: 0..15 --> CELLS || here := ICE
OPERATIONS
    Right = SELECT pos mod 4 < 3 & map(pos + 1) = ICE THEN skip END;
    Left = SELECT pos mod 4 > 0 & map(pos - 1) = ICE THEN skip END;
    Stay = SELECT map(pos) = ICE & cost(here) < 2 THEN skip END
END
"""


def write(tmp_path, text: str, name: str) -> str:
    path = tmp_path / f"{name}.mch"
    path.write_text(text)
    return str(path)


def test_an_enumerated_variable_proves_and_diffs(capsys, tmp_path):
    enum = write(tmp_path, ENUM, "enum")
    code, out, err = run(capsys, "prove", enum, "--deadlock-free")
    assert (code, out) == (0, "deadlock-free: proved\n"), err
    other = write(tmp_path, ENUM.replace("ahead /= WALL & ahead : {FREE, GOAL}",
                                         "ahead = FREE"), "other")
    code, out, err = run(capsys, "diff", "--symbolic", "--shield", enum, "--against", other)
    assert code == 1, err
    assert out.splitlines()[:2] == [
        "Forward: counterexample",
        f"  {enum} and {other} decide Forward differently: ahead = GOAL, x = 0"]
    assert "Turn: equivalent" in out
    code, out, _ = run(capsys, "prove", enum, "--implies", "Forward => ahead /= WALL")
    assert code == 0 and "proved" in out


def test_a_grid_map_proves_with_its_counterexample_confirmed(capsys, tmp_path):
    grid = write(tmp_path, GRID, "grid")
    code, out, err = run(capsys, "prove", grid, "--deadlock-free", "--json")
    assert code == 1, err
    (finding,) = json.loads(out)
    assert finding["status"] == "counterexample" and finding["disagreement"] is None
    assert finding["state"]["map"].startswith("{(0↦")  # a function over 0..15, read back
    code, out, err = run(capsys, "prove", grid, "--deadlock-free", "--assume",
                         "map(pos) = ICE & here = ICE")
    assert (code, out) == (0, "deadlock-free: proved\n"), err
    code, out, _ = run(capsys, "prove", grid, "--implies", "Right => pos < 15 & map(pos+1) /= HOLE")
    assert code == 0 and "proved" in out


@pytest.mark.parametrize("shield", ["frozenlake", "cliffwalking"])
def test_the_built_in_grid_shields_prove(capsys, shield):
    """Both were `unknown (cannot translate the variable field …)`: now the solver finds the
    agent hemmed in by holes (or the cliff), and the evaluator confirms it."""
    code, out, err = run(capsys, "prove", shield, "--deadlock-free")
    assert code == 1 and out.startswith("deadlock-free: counterexample\n"), (out, err)
    assert "disagree" not in out + err
    assert "entries, the whole value with --format json or --counterexamples)" in out
    assert max(len(line) for line in out.splitlines()) < 400  # the map cut, not 1000 wide
    code, out, err = run(capsys, "prove", shield, "--well-defined")
    assert (code, out) == (0, "well-defined guards: proved\n"), err


def test_a_function_s_range_is_part_of_the_invariant(capsys, tmp_path):
    """`f : S --> 0..3` was read as `f : S --> INTEGER` by the solver: a counterexample
    with f(A) = 5 the evaluator refused (exit 4)."""
    rng = write(tmp_path, """MACHINE Rng
SETS S = {A, B}
VARIABLES f
INVARIANT f : S --> 0..3
INITIALISATION f := {A |-> 0, B |-> 0}
OPERATIONS
    Op = SELECT f(A) < 5 THEN skip END
END
""", "rng")
    code, out, err = run(capsys, "prove", rng, "--deadlock-free")
    assert (code, out) == (0, "deadlock-free: proved\n"), err


# ------------------------------------------------------------------ continuous actions

PUSH = """MACHINE Push
CONSTANTS VMAX, A, DT
PROPERTIES VMAX = 10.0 & A = 2.0 & DT = 0.5
VARIABLES V
INVARIANT V : REAL & V >= 0.0 & V <= VMAX
INITIALISATION V := 0.0
OPERATIONS
    PUSH(u) = PRE u : REAL & V + A*DT*u <= VMAX & V + A*DT*u >= 0.0 THEN V := V + A*DT*u END
END
"""

#: the throttle environment's action space is Box(-4, 2); this guard allows only a >= 3
#: while EgoSpeed < 5: the live shield deadlocks there
OUTSIDE = """MACHINE Outside
VARIABLES Gap, EgoSpeed, LeadSpeed
INVARIANT Gap : REAL & EgoSpeed : REAL & LeadSpeed : REAL & EgoSpeed >= 0.0 & LeadSpeed >= 0.0
INITIALISATION Gap, EgoSpeed, LeadSpeed := 40.0, 20.0, 20.0
OPERATIONS
    ACCELERATE(a) = PRE a : REAL & (EgoSpeed < 5.0 => a >= 3.0) & a <= 10.0 THEN skip END
END
"""


def test_a_claim_about_every_allowed_action(capsys, tmp_path):
    push = write(tmp_path, PUSH, "push")
    code, out, err = run(capsys, "prove", push, "--implies", "PUSH(u) => V + A*DT*u <= VMAX")
    assert (code, out) == (0, "PUSH(u) => V + A*DT*u <= VMAX: proved\n"), err
    code, out, err = run(capsys, "prove", push, "--implies", "PUSH(v) => v <= 1.0", "--json")
    (finding,) = json.loads(out)
    assert code == 1 and finding["status"] == "counterexample"
    assert finding["reading"].startswith("PUSH allows v = ") and finding["disagreement"] is None
    code, _, err = run(capsys, "prove", push, "--implies", "PUSH => V + A*DT*u <= VMAX")
    assert code == 2 and "unknown identifier u" in err
    assert "hint: PUSH has the parameter(s) u: write 'PUSH(u) => …'" in err
    code, _, err = run(capsys, "prove", push, "--implies", "PUSH(u, w) => u < 1.0")
    assert code == 2 and "PUSH has 1 parameter(s) (u); PUSH(u, w) names 2" in err
    code, _, err = run(capsys, "prove", push, "--implies", "PUSH(V) => V < 1.0")
    assert code == 2 and "apart from each other and from the machine's names (V is one)" in err
    obligations = tmp_path / "obs.toml"
    obligations.write_text('[[implies]]\noperation = "PUSH(u)"\npredicate = "u <= 10.0"\n')
    code, out, err = run(capsys, "prove", push, "--obligations", obligations)
    assert (code, out) == (0, "PUSH(u) => u <= 10.0: proved\n"), err


def test_prove_with_the_environment_takes_its_action_space(capsys, tmp_path, acc_env):
    """`prove --deadlock-free` said proved for a shield whose allowed set lies outside the
    action space where the live shield deadlocks — without a word."""
    outside = write(tmp_path, OUTSIDE, "outside")
    code, out, err = run(capsys, "prove", outside, "--deadlock-free")
    assert (code, out) == (0, "deadlock-free: proved\n")
    assert "warning: ACCELERATE.a is bounded by no action space: the proof takes every real " \
           "as an action" in err
    env = "acc_cruise.throttle:Throttle"
    code, out, err = run(capsys, "prove", outside, "--deadlock-free", "--env", env, "--json")
    (finding,) = json.loads(out)
    assert code == 1 and finding["status"] == "counterexample", err
    assert finding["disagreement"] is None and finding["state"]["EgoSpeed"] < 5.0
    assert "bounded by no action space" not in err
    code, out, err = run(capsys, "prove", outside, "--implies", "ACCELERATE(a) => a <= 2.0",
                         "--env", env)
    assert (code, out) == (0, "ACCELERATE(a) => a <= 2.0: proved\n"), err
    code, out, _ = run(capsys, "prove", outside, "--implies", "ACCELERATE(a) => a <= 2.0")
    assert code == 1 and "ACCELERATE allows a = " in out


def test_a_guard_not_linear_with_linear_bounds_is_bounded(capsys, tmp_path):
    """A new user's boat: `thrust >= -1.0 & thrust <= 1.0 & … & thrust * thrust + rudder *
    rudder <= 1.0` bounds both parameters, yet prove warned that no action space bounds
    them: the range of the guard's own conjuncts was dropped whole for the one not linear."""
    shield = tmp_path / "disc.mch"
    shield.write_text("""MACHINE Disc
VARIABLES S
INVARIANT S : REAL
INITIALISATION S := 0.0
OPERATIONS
  STEER(t, r) = PRE t : REAL & r : REAL & t >= -1.0 & t <= 1.0 & r >= -1.0 &
    t * t + r * r <= 1.0 & S + t <= 4.5 THEN skip END
END""")
    code, _, err = run(capsys, "prove", str(shield), "--deadlock-free")
    assert code in (0, 1) and "Traceback" not in err
    assert "warning: STEER.r is bounded by no action space" in " ".join(err.split())
    assert "STEER.t" not in err  # r has no upper bound of its own; t has both


def test_guards_with_the_environment_cut_the_allowed_set_to_its_action_space(capsys, tmp_path,
                                                                             acc_env):
    outside = write(tmp_path, OUTSIDE, "outside")
    state = tmp_path / "s.json"
    state.write_text('{"Gap": "40.0", "EgoSpeed": "2.0", "LeadSpeed": "20.0"}')
    code, out, _ = run(capsys, "guards", outside, "-s", state)
    assert code == 0 and out.splitlines() == ["enabled: ACCELERATE", "disabled: (none)",
                                              "ACCELERATE: a ∈ [3.0, 10.0]"]
    code, out, _ = run(capsys, "guards", outside, "-s", state, "--env",
                       "acc_cruise.throttle:Throttle")
    assert code == 0 and out.splitlines() == [
        "enabled: (none: deadlock)", "disabled: ACCELERATE",
        "ACCELERATE: a ∈ ∅ (the action space: a ∈ [-4.0, 2.0] float32)"]
    code, _, err = run(capsys, "guards", outside, "-s", state, "--env", "frozenlake")
    assert code == 2 and "frozenlake takes discrete actions" in err


def test_a_map_applied_to_two_arguments_and_assumed_whole(capsys, tmp_path):
    """A new user's `grid(x-1, y)` (B's f(a, b) for f(a |-> b)) was `unknown`, and a whole
    map assumed (`grid = {…}`) "cannot translate a number that is not one"."""
    text = """MACHINE Lava
SETS CELL = {Floor, Lava}
VARIABLES x, y, grid
INVARIANT x : 0..1 & y : 0..1 & grid : (0..1)*(0..1) --> CELL
INITIALISATION x := 0 || y := 0 || grid := (0..1)*(0..1) * {Floor}
OPERATIONS
    Left = SELECT x > 0 & grid(x-1, y) /= Lava THEN skip END;
    Right = SELECT x < 1 & grid(x+1, y) /= Lava THEN skip END;
    Stay = SELECT grid(x, y) = Floor THEN skip END
END
"""
    shield = write(tmp_path, text, "lava")
    code, out, err = run(capsys, "prove", shield, "--deadlock-free")
    assert code == 1 and out.startswith("deadlock-free: counterexample"), (out, err)
    whole = "grid = {((0|->0)|->Floor), ((0|->1)|->Lava), ((1|->0)|->Lava), ((1|->1)|->Floor)}"
    code, out, err = run(capsys, "prove", shield, "--deadlock-free", "--assume", whole)
    assert (code, out) == (0, "deadlock-free: proved\n"), err
    code, out, _ = run(capsys, "prove", shield, "--implies", "Left => grid(0, y) = Floor",
                       "--assume", whole)
    assert code == 0 and "proved" in out
    code, out, _ = run(capsys, "prove", shield, "--deadlock-free", "--assume",
                       "grid = {((0|->0)|->Lava)}")  # another domain: no such state
    assert code == 5 and "vacuous" in out


def test_guards_says_the_action_space_once_for_a_set_the_solver_decides(capsys, tmp_path,
                                                                        acc_env):
    square = write(tmp_path, OUTSIDE.replace("(EgoSpeed < 5.0 => a >= 3.0) & a <= 10.0",
                                             "a * a <= EgoSpeed"), "square")
    state = tmp_path / "s.json"
    state.write_text('{"Gap": "40.0", "EgoSpeed": "2.0", "LeadSpeed": "20.0"}')
    code, out, _ = run(capsys, "guards", square, "-s", state, "--env",
                       "acc_cruise.throttle:Throttle")
    flat = " ".join(out.split())
    assert code == 0 and flat.count("within the action space") == 1, out
    assert "decided by the solver (searched within the action space: a ∈ [-4.0, 2.0])" in flat
