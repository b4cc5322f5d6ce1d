"""Proofs that cannot pass wrongly: user formulas type-checked before the solver, vacuous
proofs named, a claim's own well-definedness part of it, ill-defined guards not enabling,
every operation of either shield compared, the timeout validated."""

from __future__ import annotations

import json

import pytest

from tests.helpers import run
from tracecheck.b.machine import load_machine_text
from tracecheck.errors import InputError

pytest.importorskip("z3")

from tracecheck.checking import proving as P  # noqa: N812 - the module, as in its tests before

COUNTER = """MACHINE M
VARIABLES x
INVARIANT x : INTEGER & x >= 0 & x <= 5
INITIALISATION x := 0
OPERATIONS
Inc = PRE x < 3 THEN x := x + 1 END
END
"""


def machine_file(tmp_path, text: str, name: str = "M") -> str:
    path = tmp_path / f"{name}.mch"
    path.write_text(text)
    return str(path)


@pytest.fixture
def counter(tmp_path):
    """Deadlocks at x = 3 (Inc needs x < 3; the invariant allows 0..5)."""
    return machine_file(tmp_path, COUNTER)


# ------------------------------------------------------------------ type-checked formulas

TYPE_ERRORS = {
    "real for an integer": (["--deadlock-free", "--assume", "x = 1.5"],
                            "error: --assume:1:1: type mismatch in `x = 1.5`: INTEGER vs REAL"),
    "bool for an integer": (["--deadlock-free", "--assume", "x = TRUE"],
                            "error: --assume:1:1: type mismatch in `x = TRUE`: INTEGER vs BOOL"),
    "a claim": (["--implies", "Inc => x = 2.5"],
                "error: --implies:1:1: type mismatch in `x = 2.5`: INTEGER vs REAL"),
    "unknown name in a claim": (["--implies", "Inc => y = 2"],
                                "error: --implies:1:1: unknown identifier y"),
    "unknown name assumed": (["--deadlock-free", "--assume", "y = 1"],
                             "error: --assume:1:1: unknown identifier y"),
    "an expression": (["--deadlock-free", "--assume", "x + 1"],
                      "error: --assume:1:1: the formula must be a predicate, but `x + 1` is an "
                      "expression"),
    "syntax": (["--deadlock-free", "--assume", "x = = 1"], "error: --assume:1:5: unexpected '='"),
}


@pytest.mark.parametrize("args, message", TYPE_ERRORS.values(), ids=TYPE_ERRORS.keys())
def test_user_formulas_are_type_checked_before_the_solver(capsys, counter, monkeypatch, args,
                                                          message):
    def no_solver(*a, **k):
        raise AssertionError("the solver was asked")

    from tracecheck.checking import confirming

    monkeypatch.setattr(P, "check_satisfiable", no_solver)
    monkeypatch.setattr(confirming, "solve", no_solver)
    code, out, err = run(capsys, "prove", counter, *args)
    assert code == 2 and out == ""
    assert err.startswith(message), err
    text = args[-1].partition("=>")[2].strip() if "=>" in args[-1] else args[-1]
    assert f"\n    {text}\n    " in err  # the caret is under the formula, not the machine
    assert "cannot translate" not in err and "MACHINE M" not in err


def test_an_unknown_name_lists_the_machine_s_names(capsys, counter):
    code, _, err = run(capsys, "prove", counter, "--implies", "Inc => x > 0 & y = 2")
    assert code == 2
    assert err.splitlines()[1:] == ["    x > 0 & y = 2", "            ^",
                                    "  hint: the variables and constants of M are x"]


def test_removing_the_type_check_brings_the_wrong_proof_back(capsys, counter, monkeypatch):
    """The mutation the tests must catch: without the type check z3 reads `x = TRUE` as
    x = 1 and proves deadlock freedom for a machine that deadlocks at x = 3."""
    code, out, _ = run(capsys, "prove", counter, "--deadlock-free", "--assume", "x = TRUE")
    assert code == 2 and "proved" not in out
    import tracecheck.b.typecheck

    monkeypatch.setattr(tracecheck.b.typecheck, "typecheck_formula", lambda *a, **k: None)
    code, out, _ = run(capsys, "prove", counter, "--deadlock-free", "--assume", "x = TRUE")
    assert (code, out) == (0, "deadlock-free: proved\n")  # the wrong answer the check prevents


def test_eval_takes_the_same_path(capsys, counter, monkeypatch):
    """`eval --model` and `prove` share the type check: one function."""
    code, _, err = run(capsys, "eval", "--model", counter, "x = 1.5")
    assert code == 2 and "error: <expr>:1:1: type mismatch in `x = 1.5`: INTEGER vs REAL" in err
    import tracecheck.b.typecheck

    seen = []
    real = tracecheck.b.typecheck.check_formula
    monkeypatch.setattr(tracecheck.b.typecheck, "check_formula",
                        lambda *a, **k: seen.append(k["file"]) or real(*a, **k))
    run(capsys, "eval", "--model", counter, "x = 1")
    run(capsys, "prove", counter, "--deadlock-free", "--assume", "x = 1")
    assert seen == ["<expr>", "--assume"]


def test_errors_in_an_obligations_file_name_the_file_and_entry(capsys, counter, tmp_path):
    path = tmp_path / "obs.toml"
    cases = {
        'deadlock_free = true\nassume = ["x >= 0", "x = TRUE"]\n':
            f"error: {path}: assume[2]:1:1: type mismatch in `x = TRUE`: INTEGER vs BOOL",
        '[[implies]]\noperation = "Inc"\npredicate = "x < 3"\n'
        '[[implies]]\noperation = "Inc"\npredicate = "x < y"\n':
            f"error: {path}: implies[2].predicate:1:5: unknown identifier y",
        '[[implies]]\noperation = "Inc"\npredicate = "x < 3"\n'
        '[[implies]]\noperation = "Jump"\npredicate = "x < 3"\n':
            f"error: {path}: implies[2].operation: unknown operation 'Jump'; the operations "
            "of M are Inc",
        '[[implies]]\noperation = "Inc"\npredicate = "x <"\n':
            f"error: {path}: implies[1].predicate:1:4: unexpected end of the formula",
    }
    for text, message in cases.items():
        path.write_text(text)
        code, out, err = run(capsys, "prove", counter, "--obligations", str(path))
        assert code == 2 and out == "", err
        assert err.startswith(message), err
        assert "<input>" not in err


def test_prove_refuses_an_operation_it_does_not_have_by_option(counter):
    machine = load_machine_text(COUNTER, file="M.mch")
    with pytest.raises(InputError, match="unknown operation 'Jump' in --implies"):
        P.prove(machine, implies=(("Jump", "x > 0"),))


# ------------------------------------------------------------------ vacuity

VACUOUS = COUNTER.replace("x >= 0 & x <= 5", "x > 5 & x < 3")


def test_an_unsatisfiable_invariant_is_vacuous_not_proved(capsys, tmp_path):
    path = machine_file(tmp_path, VACUOUS, "V")
    code, out, _ = run(capsys, "prove", path, "--deadlock-free", "--implies", "Inc => x = 7",
                       "--well-defined")
    assert code == 5
    assert out.splitlines() == [
        "vacuous: no state satisfies the invariant and assumptions (the invariant alone is "
        "unsatisfiable)",
        "deadlock-free: vacuous", "Inc => x = 7: vacuous", "well-defined guards: vacuous"]
    code, out, _ = run(capsys, "prove", path, "--deadlock-free", "--json")
    assert code == 5 and [r["status"] for r in json.loads(out)] == ["vacuous"]


def test_contradictory_assumptions_are_vacuous_and_named(capsys, counter):
    code, out, _ = run(capsys, "prove", counter, "--deadlock-free", "--assume", "x > 4",
                       "--assume", "x < 4", "--assume", "x >= 0")
    assert code == 5 and "proved" not in out
    assert out.splitlines()[0] == ("vacuous: no state satisfies the invariant and assumptions "
                                   "(these contradict each other: --assume 'x > 4'; --assume "
                                   "'x < 4')")
    # an assumption that is itself never defined removes every state
    code, out, _ = run(capsys, "prove", counter, "--deadlock-free", "--assume", "1 / 0 = 7")
    assert code == 5 and out.startswith("vacuous: ")


def test_the_environment_s_ranges_count_for_vacuity(capsys, tmp_path):
    grid = machine_file(tmp_path, "MACHINE Grid\nVARIABLES x, y\nINVARIANT x : INTEGER & "
                        "y : INTEGER\nINITIALISATION x := 0 || y := 0\nOPERATIONS\n"
                        "  Move = SELECT x : 0..11 THEN skip END\nEND\n", "Grid")
    code, out, _ = run(capsys, "prove", grid, "--deadlock-free", "--env", "cliffwalking",
                       "--assume", "x > 20")
    assert code == 5
    assert out.splitlines()[0] == ("vacuous: no state satisfies the invariant and assumptions "
                                   "(these contradict each other: --assume 'x > 20'; --env "
                                   "cliffwalking 'x : 0..11')")


def test_when_satisfiability_is_unknown_nothing_is_proved(capsys, tmp_path):
    """No integers satisfy x⁵ + y⁵ = z⁵ (x, y, z > 1), which the solver cannot show: deadlock
    freedom follows from the invariant at once, but it may be vacuous — unknown, exit 3."""
    path = machine_file(tmp_path, "MACHINE F\nVARIABLES x, y, z\nINVARIANT x : INTEGER & "
                        "y : INTEGER & z : INTEGER & x > 1 & y > 1 & z > 1 & "
                        "x ** 5 + y ** 5 = z ** 5\nINITIALISATION x := 2 || y := 2 || z := 2\n"
                        "OPERATIONS\n  Go = PRE x > 1 THEN skip END\nEND\n", "F")
    code, out, _ = run(capsys, "prove", path, "--deadlock-free", "--timeout", "0.5")
    assert code == 3
    assert out.startswith("deadlock-free: unknown (proved, but the solver could not tell "
                          "whether any state satisfies the invariant and assumptions (")
    assert out.rstrip().endswith("that may be vacuous)")


def test_disjoint_invariants_make_the_diff_vacuous(capsys, tmp_path):
    a = machine_file(tmp_path, COUNTER.replace("x <= 5", "x <= 2"), "A")
    b = machine_file(tmp_path, COUNTER.replace("x >= 0", "x >= 4"), "B")
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", a, "--against", b)
    assert code == 5 and "equivalent" not in out
    assert out.splitlines() == [
        f"vacuous: no state satisfies both shields' invariants (these contradict each other: "
        f"the invariant of {a}; the invariant of {b})", "Inc: vacuous"]


# ------------------------------------------------------------------ well-definedness


def test_a_claim_s_own_well_definedness_is_part_of_the_claim(capsys, counter):
    code, out, err = run(capsys, "prove", counter, "--implies", "Inc => 1 / 0 = 7")
    assert code == 1, err
    lines = out.splitlines()
    assert lines[0] == "Inc => 1 / 0 = 7: not well-defined"
    assert lines[1].startswith("  Inc is enabled and 1 / 0 = 7 is not well-defined: x = ")
    code, out, err = run(capsys, "prove", counter, "--implies", "Inc => 10 / x > 1", "--json")
    (r,) = json.loads(out)
    assert code == 1 and r["status"] == "not well-defined" and r["state"] == {"x": 0}
    # defined where it is reached: proved
    code, out, _ = run(capsys, "prove", counter, "--implies", "Inc => (x > 0 => 10 / x > 1)")
    assert code == 0 and out == "Inc => (x > 0 => 10 / x > 1): proved\n"


GUARDED = COUNTER.replace("x < 3 THEN x := x + 1", "10 / x > 1 THEN x := x")


def test_an_ill_defined_guard_does_not_enable_its_operation(capsys, tmp_path):
    path = machine_file(tmp_path, GUARDED, "D")
    folder = tmp_path / "cx"
    code, out, err = run(capsys, "prove", path, "--deadlock-free", "--counterexamples",
                         str(folder))
    assert code == 1, err  # not 4: the evaluator raising on 10 / 0 counts as not enabled
    assert out.splitlines()[:2] == [
        "deadlock-free: counterexample",
        "  no operation is enabled (the guard of Inc is not well-defined there): x = 0"]
    (state,) = folder.glob("*.json")
    code, _, err = run(capsys, "guards", path, "--state", str(state))
    assert code == 2 and "division by zero" in err  # what `guards` says there
    code, out, _ = run(capsys, "prove", path, "--well-defined")
    assert code == 1 and "the guard of Inc is not well-defined: x = 0" in out
    # another operation enabled where the guard is ill-defined: deadlock-free
    other = machine_file(tmp_path, GUARDED.replace("END\nEND", "END;\nStay = PRE x = 0 THEN "
                                                   "skip END\nEND"), "D2")
    code, out, _ = run(capsys, "prove", other, "--deadlock-free")
    assert code == 0 and out == "deadlock-free: proved\n"


def test_the_evaluator_counts_an_erroring_guard_as_not_enabled():
    machine = load_machine_text(GUARDED, file="D.mch")
    from tracecheck.checking.confirming import decides

    assert decides(machine, "Inc", {"x": 0}) is None
    assert decides(machine, "Inc", {"x": 2}) is True


# ------------------------------------------------------------------ symbolic diff

TWO = COUNTER.replace("MACHINE M", "MACHINE A").replace(
    "VARIABLES", "SETS V = {v1, v2, v3}\nVARIABLES").replace(
    "END\nEND", "END;\nDec = PRE x > 0 THEN x := x - 1 END\nEND")


def test_the_diff_covers_the_operations_of_either_shield(capsys, tmp_path):
    a = machine_file(tmp_path, TWO, "A")
    c = machine_file(tmp_path, TWO.replace("Dec = PRE x > 0", "Reset = PRE x > 4"), "C")
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", a, "--against", c)
    assert code == 1
    assert out.splitlines() == ["Inc: equivalent", f"Dec: only in {a}", f"Reset: only in {c}"]
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", a, "--against", c, "--json")
    assert [r["status"] for r in json.loads(out)] == ["equivalent", f"only in {a}",
                                                      f"only in {c}"]
    e = machine_file(tmp_path, TWO.replace("Dec", "Up").replace("Inc", "Down"), "E")
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", a, "--against", e)
    assert code == 1
    assert out.splitlines() == [f"Inc: only in {a}", f"Dec: only in {a}", f"Down: only in {e}",
                                f"Up: only in {e}"]


@pytest.mark.parametrize("variables", ["x", "x, s"], ids=["sets only", "a subset variable"])
def test_shields_over_different_sets_are_refused_by_name(capsys, tmp_path, variables):
    text = TWO
    if variables != "x":
        text = TWO.replace("VARIABLES x", "VARIABLES x, s").replace(
            "x : INTEGER", "s <: V & x : INTEGER").replace("x := 0", "x := 0 || s := {}").replace(
            "PRE x < 3", "PRE x < 3 & v3 : s")
    a = machine_file(tmp_path, text, "A")
    b = machine_file(tmp_path, text.replace("v3}", "v3, v4}"), "B")
    code, _, err = run(capsys, "diff", "--symbolic", "--shield", a, "--against", b)
    assert code == 2
    assert err.startswith(f"error: the shields' sets differ: V is {{v1,v2,v3}} in {a} and "
                          f"{{v1,v2,v3,v4}} in {b}; diff --symbolic compares shields over the "
                          "same sets and constants")
    assert "Traceback" not in err and "membership" not in err


def test_constants_are_compared_by_name_each_shield_with_its_own(capsys, tmp_path):
    text = TWO.replace("VARIABLES", "CONSTANTS lim\nPROPERTIES lim = 3\nVARIABLES").replace(
        "x < 3", "x < lim")
    a = machine_file(tmp_path, text, "A")
    b = machine_file(tmp_path, text.replace("lim = 3", "lim = 4"), "B")
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", a, "--against", b)
    assert code == 1
    assert out.splitlines()[:3] == ["Inc: counterexample",
                                    f"  {a} and {b} decide Inc differently: x = 3",
                                    f"  {a} blocks it, {b} enables it"]  # both named A


def test_an_ill_defined_guard_is_a_difference_in_the_diff(capsys, tmp_path):
    a = machine_file(tmp_path, GUARDED, "A")
    b = machine_file(tmp_path, GUARDED.replace("10 / x > 1", "x >= 0"), "B")
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", a, "--against", b)
    assert code == 1
    assert out.splitlines()[:2] == [
        "Inc: counterexample",
        f"  {a} and {b} decide Inc differently (Inc's guard in {a} is not well-defined "
        "there): x = 0"]


# ------------------------------------------------------------------ timeouts


@pytest.mark.parametrize("value", ["inf", "nan", "0", "-1", "1e300"])
@pytest.mark.parametrize("command", ["prove", "diff"])
def test_the_timeout_is_a_finite_number_of_seconds(capsys, counter, command, value):
    args = ["prove", counter, "--deadlock-free"] if command == "prove" else \
        ["diff", "--symbolic", "--shield", counter, "--against", counter]
    code, out, err = run(capsys, *args, "--timeout", value)
    assert code == 2 and out == ""
    assert err.startswith("error: --timeout must be a finite number of seconds above 0 (at "
                          "most 4,294,967), not "), err
    assert "Traceback" not in err


def test_the_library_checks_the_timeout_too(counter):
    machine = load_machine_text(COUNTER, file="M.mch")
    with pytest.raises(InputError, match="the timeout must be a finite number"):
        P.prove(machine, deadlock_free=True, timeout_s=float("inf"))
    assert P.check_timeout(0.5) == 0.5


def test_a_huge_exponent_is_unknown_at_once_with_its_place(capsys, tmp_path):
    path = machine_file(tmp_path, COUNTER.replace("PRE x < 3", "PRE x ** 100000 > 1"), "P")
    code, out, _ = run(capsys, "prove", path, "--deadlock-free", "--timeout", "1")
    assert code == 3
    assert out.startswith(f"deadlock-free: unknown ({path}:6:11: cannot translate a power "
                          "with exponent 100000 (at most 64")
    counter = machine_file(tmp_path, COUNTER)
    code, out, _ = run(capsys, "prove", counter, "--implies", "Inc => x >= 0 & x ** 65 >= 0",
                       "--timeout", "1")
    assert code == 3
    assert "--implies:1:10: cannot translate a power with exponent 65" in out


NESTED = "((((x ** 64) ** 64) ** 64) ** 64) ** 64 > 1"  # x to the 64^5: z3 ran 96 s, 14 GB


@pytest.mark.parametrize("claim, degree, column", [
    (NESTED, "4,096", 4), ("(x * x) ** 33 > 1", "66", 1), ("x ** 64 * x > 0", "65", 1),
    ("(x ** 8) ** 8 / x > 0", "65", 1),
], ids=["nested-powers", "square-power", "product", "quotient"])
def test_nested_powers_are_unknown_at_once_naming_the_term(capsys, counter, claim, degree,
                                                           column):
    """Each power is within its limit, but nested they multiply: the degree of the whole
    term is bounded, and the construct and its place named, before z3 sees it."""
    import time

    start = time.monotonic()
    code, out, err = run(capsys, "prove", counter, "--implies", f"Inc => {claim}",
                         "--timeout", "1")
    assert code == 3 and "Traceback" not in err
    assert f"unknown (--implies:1:{column}: cannot translate a term of degree {degree} " \
           "(its powers and products multiply; at most 64" in out, out
    assert time.monotonic() - start < 1.0  # the solver was never asked


def test_the_timeout_bounds_z3_s_work_while_asserting_too(monkeypatch):
    """z3's own timeout counts only in check(); asserting a huge term took 2 s more at
    x ** 64^4 (and minutes at 64^5). With the degree bound lifted, the question still ends
    near the timeout: a timer interrupts z3 at the deadline."""
    import time

    from tracecheck.checking import smt

    monkeypatch.setattr(smt, "MAX_DEGREE", 10**12)
    machine = load_machine_text(COUNTER, file="M.mch")
    start = time.monotonic()
    [result] = P.prove(machine, implies=(("Inc", "(((x ** 64) ** 64) ** 64) ** 64 > 1"),),
                       timeout_s=0.3)
    assert (result.status, result.reason) == ("unknown", "timeout")
    assert time.monotonic() - start < 1.8  # without the timer: 2.8 s here


ACC = '''MACHINE Acc
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL & Gap >= 0.0 & Gap <= 200.0 & Speed >= 0.0 &
          Speed <= 40.0
INITIALISATION Gap, Speed := 50.0, 20.0
OPERATIONS
  ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 & Gap - (Speed + a) * 1.5 {rel} 10.0
                  THEN Speed := Speed + a END;
  BRAKE = PRE Speed > 0.0 THEN Speed := 0.0 END
END'''


def test_real_parameters_some_value_enables_the_operation(capsys, tmp_path):
    model = machine_file(tmp_path, ACC.format(rel=">"), "Acc")
    code, out, _ = run(capsys, "prove", model, "--deadlock-free")
    # no a in [-4, 2] when Gap < 10 + (Speed - 4) * 1.5, and BRAKE needs Speed > 0
    assert code == 1 and "no operation is enabled" in out and "Speed = 0.0" in out
    code, out, _ = run(capsys, "prove", model, "--implies", "ACCELERATE => Gap > 4.0")
    assert code == 0 and "ACCELERATE => Gap > 4.0: proved" in out
    code, out, _ = run(capsys, "prove", model, "--implies", "ACCELERATE => Speed < 40.0")
    assert code == 1 and "ACCELERATE is enabled and Speed < 40.0 does not hold" in out


def test_symbolic_diff_compares_the_actions_allowed_not_only_whether_some_are(capsys,
                                                                              tmp_path):
    strict = machine_file(tmp_path, ACC.format(rel=">"), "Strict")
    loose = machine_file(tmp_path, ACC.format(rel=">="), "Loose")
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", strict, "--against", strict)
    assert code == 0 and "ACCELERATE: equivalent" in out
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", strict, "--against", loose)
    text = " ".join(out.split())
    assert code == 1 and "ACCELERATE: counterexample" in text
    assert "allow different actions of ACCELERATE" in text and "BRAKE: equivalent" in text
    # the action and the state it names are confirmed by tracecheck's evaluator
    [result] = [r for r in P.symbolic_diff(load_machine_text(ACC.format(rel=">")),
                                           load_machine_text(ACC.format(rel=">=")))
                if r.obligation == "ACCELERATE"]
    action, s = result.extra["action"], result.state
    assert load_machine_text(ACC.format(rel=">=")).allowed("ACCELERATE", s).contains(action)
    assert not load_machine_text(ACC.format(rel=">")).allowed("ACCELERATE", s).contains(action)
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", strict, "--against", loose,
                       "--json")
    assert "action" in out and code == 1
    code, out, _ = run(capsys, "diff", "--symbolic", "--shield", strict, "--against", loose)
    assert "Strict.mch refuses it, " in " ".join(out.split()) and "Loose.mch allows it" in out


def test_a_counterexample_of_a_guard_not_linear_is_confirmed_by_the_solvers_set(capsys,
                                                                               tmp_path):
    """A guard not linear in its REAL parameter: z3 finds a deadlock, and the allowed set in
    that state — the solver's, since the guard is not linear — proves nothing allowed: the
    counterexample is confirmed (exit 1)."""
    path = tmp_path / "quad.mch"
    path.write_text("""MACHINE Quad
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL & Gap >= 0.0 & Speed >= 0.0
INITIALISATION Gap, Speed := 1.0, 1.0
OPERATIONS ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 &
    Gap > (Speed + a) * (Speed + a) THEN skip END
END""")
    code, out, err = run(capsys, "prove", path, "--deadlock-free")
    assert code == 1, out + err
    assert "deadlock-free: counterexample no operation is enabled: Gap = 0.0, Speed = 0.0" in \
        " ".join(out.split())
    assert "please report" not in out + err
