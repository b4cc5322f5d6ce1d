"""The command line: exit codes, output, and messages for bad input (never a traceback)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.helpers import ROOT, run

TABLE1 = str(ROOT / "models" / "shields" / "paper.mch")


def test_version(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out.startswith("tracecheck 0.")


def test_check_model(capsys):
    code, out, _ = run(capsys, "check-model", TABLE1)
    assert code == 0
    assert "MACHINE PaperShield" in out
    assert "set Vehicles = {EgoVehicle, Vehicles2, Vehicles3, Vehicles4, Vehicles5}" in out
    assert "constant EgoVehicle = EgoVehicle" in out
    assert "VehiclesX" in out and "POW(Vehicles*REAL)" in out
    assert "operation FASTER: guard EgoVehicle : dom(VehiclesVx) & not(FrontWithin(40.0))" in out
    assert "ok: 5 operation(s), 9 variable(s)" in out


def test_check_model_json(capsys):
    code, out, _ = run(capsys, "check-model", TABLE1, "--json")
    data = json.loads(out)
    assert code == 0
    assert data["machine"] == "PaperShield"
    assert data["variables"]["Crash"] == {"type": "BOOL",
                                          "description": "TRUE when a crash occurred"}
    assert set(data["operations"]) == {"IDLE", "LANE_LEFT", "LANE_RIGHT", "FASTER", "SLOWER"}
    assert len(data["sha256"]) == 64


def test_check_model_syntax_error(capsys, tmp_path):
    bad = tmp_path / "bad.mch"
    bad.write_text("MACHINE Bad\nVARIABLES x\nINVARIANT x : BOOL & x = = TRUE\nEND\n")
    code, out, err = run(capsys, "check-model", str(bad))
    assert code == 2 and out == ""
    assert f"{bad}:3:26: unexpected '='" in err
    assert "    INVARIANT x : BOOL & x = = TRUE\n" in err
    assert "Traceback" not in err


def test_check_model_missing_file(capsys, tmp_path):
    code, _, err = run(capsys, "check-model", str(tmp_path / "none.mch"))
    assert code == 2 and "no such model file" in err


@pytest.mark.parametrize("expr,printed", [
    ("1 + 2", "3"), ("{x | x : 1..5 & x mod 2 = 0}", "{2,4}"), ("2 > 1", "TRUE"),
    ("{(a |-> 1.5)}", None), ("RSQRT(2.25)", "1.5"),
])
def test_eval(capsys, expr, printed):
    code, out, err = run(capsys, "eval", expr)
    if printed is None:  # `a` is no element here
        assert code == 2 and "<expr>:1:3: unknown identifier a" in err
        assert "hint: give it a value in the state (--state FILE)" in err
    else:
        assert code == 0 and out.strip() == printed


def test_eval_with_model_and_state(capsys, tmp_path):
    state = tmp_path / "s.json"
    state.write_text(json.dumps({
        "VehiclesX": "{(EgoVehicle↦100.0),(Vehicles2↦20.0),(Vehicles3↦50.0),"
                     "(Vehicles4↦-20.0),(Vehicles5↦90.0)}",
        "PresentVehicles": "{EgoVehicle,Vehicles2,Vehicles3,Vehicles4,Vehicles5}",
    }))
    code, out, _ = run(capsys, "eval", "card({v | v : Others & VehiclesX(v) > 0.0})",
                       "--model", TABLE1, "--state", str(state))
    assert code == 0 and out.strip() == "3"
    code, out, _ = run(capsys, "eval", "Others", "--model", TABLE1, "--state", str(state),
                       "--json")
    assert json.loads(out)["value"] == "{Vehicles2,Vehicles3,Vehicles4,Vehicles5}"


@pytest.mark.parametrize("expr,fragment", [
    ("1 +", "<expr>:1:4: unexpected end of the formula"),
    ("1 + 1.0", "<expr>:1:1: type mismatch in `1 + 1.0`: INTEGER vs REAL"),
    ("x + 1", "unknown identifier x"),
    ("1 / 0", "<expr>:1:1: division by zero in `1 / 0`"),
    ("min({})", "min of the empty set"),
    ("real(10 ** 400) > 0.0", "<expr>:1:1: 1000000000000000000000000000000000000000000000000000"),
    ("floor(1.0E308 * 10.0) > 0", "<expr>:1:7: the real result is out of range (overflow)"),
    ("1.0E400 > 0.0", "<expr>:1:1: the real 1.0E400 is out of range"),
    ("2.0 ** 0.5", "the exponent must be an INTEGER"),
    ("(-8.0) ** 0.5", "the exponent must be an INTEGER"),
    ("!x.(x : 1..3)", "<expr>:1:1: the body of `!x.(…)` must be an implication"),
    ("2 ** 100000000 > 0", "has more than 1,000,000 bits"),
    ("card({x | x : 1..10000000})", "has 10,000,000 elements"),
    ("card(POW(1..200000))", "is too large to compute"),
    ("POW(INTEGER) = POW(NATURAL)", "cannot decide whether POW(INTEGER) = POW(NATURAL)"),
    ("+".join(["1"] * 3000) + " > 0", "the formula nests more than 2000 levels deep"),
    ("+".join(["1"] * 10000) + " > 0", "the formula nests more than 2000 levels deep"),
    ("not(" * 2500 + "1 = 1" + ")" * 2500, "the formula nests more than 2000 levels deep"),
    ("iterate({(1|->2)}, 0) = {}", "<expr>:1:1: not supported: iterate(r, 0)"),
    ("card({x | x : NAT & x > 5})", "the set 0..2147483647 has 2,147,483,648 elements; "
                                    "tracecheck builds or walks at most 1,000,000 elements "
                                    "of one set"),
    ("10 ** 10 ** 10 > 0", "has more than 1,000,000 bits"),
    # * too: checked before it is computed (it ignored every limit)
    ("(10 ** 200000) * (10 ** 200000) > 0", "the integer result of * in `(10 ** 200000) * "
                                            "(10 ** 200000)` has more than 1,000,000 bits"),
    ("PI(x).(x : 1..300000 | x) > 0", "the integer result of PI in `PI(x).(x : 1..300000 | "
                                      "x)` has more than 1,000,000 bits"),
    ("card((1..100000) >-> (1..100000)) > 0", "has about 10^500000 elements"),
    # a card of 500 000 digits: refused before computing it (printing it was a traceback)
    ("card((1..100000) --> (1..100000)) > 0", "card((1..100000 --> 1..100000)) has more "
                                              "than 1,000,000 bits: too large to compute"),
    # refused by its length before the integer is read (a machine or state file: below)
    ("7" * 310_002 + " > 0", "<expr>:1:1: the formula is 310,006 characters long"),
], ids=lambda v: v[:40])
def test_eval_errors(capsys, expr, fragment):
    code, _, err = run(capsys, "eval", expr)
    assert code == 2 and fragment in err and "Traceback" not in err


@pytest.mark.parametrize("expr,printed", [
    (" & ".join(["1 + 1 = 2"] * 1900), "TRUE"),
    (" or ".join(["1 = 2"] * 1900), "FALSE"),
    ("not(" * 1900 + "1 = 1" + ")" * 1900, "TRUE"),
    ("+".join(["1"] * 1900), "1900"),
    ("(" * 1900 + "1" + ")" * 1900, "1"),
], ids=["conjunction", "disjunction", "not", "sum", "parentheses"])
def test_long_and_deep_formulas_work_up_to_the_limit(capsys, expr, printed):
    """A guard written out by a generator easily has hundreds of conjuncts: up to 2000 levels
    they are evaluated (scalar and batch), beyond that refused with a located error."""
    code, out, err = run(capsys, "eval", expr)
    assert code == 0 and out.strip() == printed, err


@pytest.mark.parametrize("expr,printed", [
    ("-3 + 5 = 2", "TRUE"), ("-2 ** 2", "4"), ("{1} \\/ {1} \\ {1} = {1}", "TRUE"),
    ("POW({1,2}) = {{}, {1}, {2}, {1,2}}", "TRUE"), ("(1..3)*{4}", "{(1↦4),(2↦4),(3↦4)}"),
    ("{(0|->0|->TRUE)}", "{(0↦0↦TRUE)}"),
    ("7" * 5000 + " mod 10", "7"), ("10 ** 5000 - 10 ** 5000 + 1", "1"),
])
def test_eval_values_as_prob_gives_them(capsys, expr, printed):
    code, out, err = run(capsys, "eval", expr)
    assert code == 0 and out.strip() == printed, err


def test_nan_in_a_state_file_is_refused(capsys, tmp_path):
    state = tmp_path / "s.json"
    state.write_text('{"r": NaN}')
    code, _, err = run(capsys, "eval", "r > 0.0", "--state", str(state))
    assert code == 2 and f"{state}:1:7: not valid JSON: NaN and Infinity are not JSON " \
                         "numbers, and B reals are finite" in err, err


def _state_file(tmp_path, x2):
    vs = ["EgoVehicle", "Vehicles2", "Vehicles3", "Vehicles4", "Vehicles5"]
    fn = lambda values: {v: x for v, x in zip(vs, values)}  # noqa: E731
    data = {
        "Crash": "FALSE", "PresentVehicles": vs, "Reward": 0.0,
        "VehiclesX": fn([100.0, x2, 200.0, 200.0, 200.0]),
        "VehiclesY": fn([4.0, 0.0, 0.0, 0.0, 0.0]),
        "VehiclesVx": fn([25.0, -3.0, 0.0, 0.0, 0.0]),
        **{k: fn([0.0] * 5) for k in ("VehiclesVy", "VehiclesAx", "VehiclesAy")},
    }
    path = tmp_path / "state.json"
    path.write_text(json.dumps(data))
    return str(path)


def test_guards(capsys, tmp_path):
    code, out, _ = run(capsys, "guards", TABLE1, "--state", _state_file(tmp_path, 8.0))
    assert code == 0
    assert out.splitlines() == ["enabled: LANE_LEFT, LANE_RIGHT",
                                "disabled: IDLE, FASTER, SLOWER"]
    code, out, _ = run(capsys, "guards", TABLE1, "--state", _state_file(tmp_path, 300.0),
                       "--json")
    assert json.loads(out)["enabled"] == ["IDLE", "LANE_LEFT", "LANE_RIGHT", "FASTER", "SLOWER"]


def test_guards_state_of_the_wrong_type(capsys, tmp_path):
    path = tmp_path / "ints.json"
    path.write_text(json.dumps({"VehiclesX": "{(EgoVehicle↦1),(Vehicles2↦2)}"}))
    code, _, err = run(capsys, "guards", TABLE1, "--state", str(path))
    assert code == 2
    assert (f"{path}: VehiclesX must be of type POW(Vehicles*REAL), but its value is of type "
            "POW(Vehicles*INTEGER)") in err
    path.write_text(json.dumps({"VehiclesX": "{(Car9↦1.0)}"}))
    code, _, err = run(capsys, "guards", TABLE1, "--state", str(path))
    assert "VehiclesX mentions Car9, which no set of PaperShield contains" in err
    path.write_text(json.dumps({"Speed": 1.0}))
    code, _, err = run(capsys, "guards", TABLE1, "--state", str(path))
    assert "gives a value for Speed, which the machine PaperShield does not declare" in err


def test_a_variable_missing_from_the_state_is_the_state_file_s_fault(capsys, tmp_path):
    path = tmp_path / "partial.json"
    data = json.loads(open(_state_file(tmp_path, 8.0)).read())
    del data["PresentVehicles"]
    path.write_text(json.dumps(data))
    code, _, err = run(capsys, "guards", TABLE1, "--state", str(path))
    assert code == 2 and err.startswith(
        f"error: {path}: the state gives no value for PresentVehicles, a variable of "
        f"PaperShield that a guard reads ({TABLE1}:"), err
    assert 'hint: add "PresentVehicles": … to the state file' in err


def test_guards_bad_state(capsys, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"VehiclesX": "{(EgoVehicle↦1.0"}')
    code, _, err = run(capsys, "guards", TABLE1, "--state", str(bad))
    assert code == 2
    assert f"{bad}: expected ')' but found 'end of text' in the B literal (variable " \
           "VehiclesX), at column 17 of the literal:" in err
    assert "    {(EgoVehicle↦1.0\n" in err


def test_console_script_end_to_end(tmp_path):
    bad = tmp_path / "bad.mch"
    bad.write_text("MACHINE Bad\nVARIABLES x\nINVARIANT x : REAL & x > 0\nEND\n")
    proc = subprocess.run([sys.executable, "-m", "tracecheck.cli", "check-model", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "type mismatch in `x > 0`: REAL vs INTEGER" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_usage_error_exit_code(capsys):
    code, _, err = run(capsys, "guards", TABLE1)
    assert code == 2 and "--state" in err


def test_control_characters_from_input_files_are_escaped(capsys, tmp_path):
    path = tmp_path / "ctl.json"
    path.write_text('{"Vehicles\\u001b[31mX\\u0000": 1.0}')
    code, _, err = run(capsys, "guards", TABLE1, "--state", str(path))
    assert code == 2 and "\x1b" not in err and "\x00" not in err
    assert "gives a value for Vehicles\\x1b[31mX\\x00, which the machine" in err


def test_state_files_that_are_too_deep_too_large_or_too_long(capsys, tmp_path, monkeypatch):
    state = tmp_path / "s.json"
    state.write_text('{"r": ' + "[" * 3000 + "]" * 3000 + "}")
    code, _, err = run(capsys, "eval", "r = r", "--state", str(state))
    assert code == 2 and f"{state}:1:1031: not valid JSON: depth limit exceeded" in err
    state.write_text('{"n": "' + "7" * 5000 + '"}')
    code, out, err = run(capsys, "eval", "n mod 10", "--state", str(state))
    assert code == 0 and out.strip() == "7", err
    state.write_text('{"n": "' + "7" * 400_000 + '"}')
    code, _, err = run(capsys, "eval", "n > 0", "--state", str(state))
    assert code == 2 and "an integer of 400000 digits is longer than the 310000 digits" in err
    import tracecheck.b.state as S

    monkeypatch.setattr(S, "MAX_STATE_BYTES", 100)
    state.write_text('{"n": "' + "7" * 200 + '"}')
    code, _, err = run(capsys, "eval", "n > 0", "--state", str(state))
    assert code == 2 and "has 209 bytes; tracecheck reads at most 100 for a state file" in err


@pytest.mark.parametrize("literal,message", [
    ("{" * 1500 + "}" * 1500, "the value nests more than 1000 levels deep in the B literal"),
    ("(" * 1500 + "1" + ")" * 1500, "the value nests more than 1000 levels deep"),
    ("{" * 900 + "}" * 900, None),
])
def test_deeply_nested_literals(capsys, tmp_path, literal, message):
    state = tmp_path / "s.json"
    state.write_text(json.dumps({"v": literal}))
    code, out, err = run(capsys, "eval", "v = v", "--state", str(state))
    if message is None:
        assert code == 0 and out.strip() == "TRUE", err
    else:
        assert code == 2 and message in err and "Traceback" not in err


def test_eval_several_formulas_and_a_file(capsys, tmp_path):
    code, out, err = run(capsys, "eval", "1 + 1", "card({1, 2, 3})", "2 > 3")
    assert code == 0 and out.splitlines() == ["2", "3", "FALSE"], err
    formulas = tmp_path / "f.txt"
    formulas.write_text("// one per line\n1 + 1\n\n2 ** 10\n")
    code, out, _ = run(capsys, "eval", "-f", str(formulas), "--json")
    assert [r["value"] for r in json.loads(out)] == ["2", "1024"]
    formulas.write_text("1 + 1\n\n1 +\n")
    code, _, err = run(capsys, "eval", "--file", str(formulas))
    assert code == 2 and f"{formulas}:3:4: unexpected end of the formula" in err
    assert "    1 +\n       ^" in err
    code, _, err = run(capsys, "eval", "1 = 1", "1 +")
    assert code == 2 and "<expr 2>:1:4: unexpected end" in err
    code, _, err = run(capsys, "eval")
    assert code == 2 and "give a formula to evaluate, or --file with formulas" in err


def test_values_and_file_names_are_printed_as_they_are(capsys, tmp_path):
    """Rich reads ``[bold]`` as markup and ``:smile:`` as an emoji: neither may change a value
    or a file name the user sees."""
    code, out, _ = run(capsys, "eval", '"a:smile:b"', '"[red]x[/red]"')
    assert code == 0 and out.splitlines() == ['"a:smile:b"', '"[red]x[/red]"']
    odd = tmp_path / "run[bold]:fire:.mcap"
    odd.write_bytes((ROOT / "sample_traces" / "base_none.mcap").read_bytes())
    other = tmp_path / "x[red]y.mcap"
    other.write_bytes((ROOT / "sample_traces" / "base_paper.mcap").read_bytes())
    code, out, _ = run(capsys, "info", str(odd), str(other), "--format", "csv")
    assert code == 0 and f"{odd},recorded" in out and f"{other},recorded" in out
    code, out, _ = run(capsys, "replay", str(odd), str(other), "--shield", "paper")
    assert code == 0 and " run[bold]:fir… " in out
    machine = tmp_path / "m[x].mch"
    machine.write_text(open(TABLE1).read())
    code, out, _ = run(capsys, "check-model", str(machine))
    assert code == 0 and f"MACHINE PaperShield  ({machine}, sha256" in out


# ------------------------------------------------------------------ issue 23: check-model
# shows every /*@desc*/ (bug 8), guards warns of states the invariant excludes

DESCRIBED = """
MACHINE D
SETS Mode /*@desc driving modes */ = {Eco, Sport}
CONSTANTS Lim /*@desc "the limit" */
PROPERTIES Lim = 3
VARIABLES x /*@desc the count */
INVARIANT x : 0..5
INITIALISATION x := 0
OPERATIONS
  Inc /*@desc after the name */ = SELECT x < Lim THEN x := x + 1 END;
  Dec = /*@desc after the equals */ SELECT x > 0 THEN x := x - 1 END;
  Set(v) /*@desc with a parameter */ = PRE v : 0..5 THEN x := v END;
  Reset = BEGIN x := 0 END /*@desc after the body */;
  Plain = skip
END
"""


def test_check_model_shows_every_description(capsys, tmp_path):
    path = tmp_path / "d.mch"
    path.write_text(DESCRIBED)
    code, out, _ = run(capsys, "check-model", str(path))
    assert code == 0
    for line in ["  set Mode = {Eco, Sport} — driving modes", "  constant Lim = 3 — the limit",
                 "  operation Inc (after the name): guard x < Lim",
                 "  operation Dec (after the equals): guard x > 0",
                 "  operation Set(v) (with a parameter): guard v : 0..5",
                 "  operation Reset (after the body): guard TRUE",
                 "  operation Plain: guard TRUE"]:
        assert line in out.splitlines()
    code, out, _ = run(capsys, "check-model", str(path), "--json")
    data = json.loads(out)
    assert data["descriptions"] == {"Mode": "driving modes", "Lim": "the limit",
                                    "x": "the count", "Inc": "after the name",
                                    "Dec": "after the equals", "Set": "with a parameter",
                                    "Reset": "after the body"}
    assert data["operations"]["Reset"]["description"] == "after the body"
    assert data["operations"]["Plain"]["description"] is None
    code, out, _ = run(capsys, "check-model", str(path), "--format", "csv")
    assert "constant,Lim,3,,the limit" in out and "operation,Inc,,x < Lim,after the name" in out


def test_check_model_shows_the_paper_shields_constant_description(capsys):
    code, out, _ = run(capsys, "check-model", "paper")
    assert code == 0 and "constant EgoVehicle = EgoVehicle — the vehicle the agent drives" in out


INVARIANT3 = """
MACHINE T
VARIABLES Gap, EgoSpeed, Lead
INVARIANT Gap : REAL & EgoSpeed : REAL & Lead : REAL & EgoSpeed >= 0.0 & Lead >= 0.0
INITIALISATION Gap := 1.0 || EgoSpeed := 1.0 || Lead := 0.0
OPERATIONS
  KEEP = SELECT Gap > 10.0 THEN skip END;
  BRAKE = SELECT EgoSpeed > 0.0 THEN skip END
END
"""


def test_guards_warns_of_a_state_the_invariant_excludes(capsys, tmp_path):
    model, state = tmp_path / "t.mch", tmp_path / "s.json"
    model.write_text(INVARIANT3)
    state.write_text('{"Gap": 30.0, "EgoSpeed": -1.0, "Lead": 2.0}')
    code, out, err = run(capsys, "guards", str(model), "--state", str(state))
    assert code == 0 and "enabled: KEEP" in out
    assert (f"warning: {state} breaks the INVARIANT of T: EgoSpeed >= 0.0 does not hold"
            in " ".join(err.split()))
    code, out, err = run(capsys, "guards", str(model), "--state", str(state), "--json")
    data = json.loads(out)
    assert data["invariant_holds"] is False and data["invariant_violations"] == ["EgoSpeed >= 0.0"]
    state.write_text('{"Gap": 30.0, "EgoSpeed": 2.0}')
    code, out, err = run(capsys, "guards", str(model), "--state", str(state))
    assert code == 0 and "enabled: KEEP, BRAKE" in out
    assert (f"warning: {state} gives no value for Lead (a variable of T): no guard reads it; "
            "the INVARIANT is not checked where it does (Lead : REAL; Lead >= 0.0)"
            in " ".join(err.split()))
    code, out, _ = run(capsys, "guards", str(model), "--state", str(state), "--json")
    data = json.loads(out)
    assert data["missing_variables"] == ["Lead"] and data["invariant_holds"] is None
    assert [u["conjunct"] for u in data["invariant_unchecked"]] == ["Lead : REAL", "Lead >= 0.0"]
    state.write_text('{"Gap": 30.0, "EgoSpeed": 2.0, "Lead": 1.0}')
    code, out, err = run(capsys, "guards", str(model), "--state", str(state), "--json")
    assert code == 0 and err == "" and json.loads(out)["invariant_holds"] is True


def test_guards_prints_the_values_real_parameters_may_take(tmp_path, capsys):
    model = tmp_path / "acc.mch"
    model.write_text('''MACHINE Acc
VARIABLES Gap, Speed
INVARIANT Gap : REAL & Speed : REAL
INITIALISATION Gap, Speed := 50.0, 20.0
OPERATIONS
  ACCELERATE(a) = PRE a : REAL & a >= -4.0 & a <= 2.0 & Gap - (Speed + a) * 1.5 > 10.0
                  THEN Speed := Speed + a END
END''')
    state = tmp_path / "s.json"
    state.write_text('{"Gap": 40.0, "Speed": 20.0}')
    code, out, _ = run(capsys, "guards", model, "--state", state)
    assert code == 0 and "enabled: ACCELERATE" in out and "ACCELERATE: a ∈ [-4.0, 0.0)" in out
    code, out, _ = run(capsys, "guards", model, "--state", state, "--json")
    assert json.loads(out)["allowed"]["ACCELERATE"]["intervals"] == [
        {"low": -4.0, "high": 0.0, "low_open": False, "high_open": True}]
    state.write_text('{"Gap": 10.0, "Speed": 20.0}')
    code, out, _ = run(capsys, "guards", model, "--state", state)
    assert code == 0 and "(none: deadlock)" in out and "ACCELERATE: a ∈ ∅" in out


def test_guards_says_undecided_where_no_float_of_an_allowed_set_passes(tmp_path, capsys):
    """Over the reals a ∈ (0.5, 1.0]; in floats a + 1.0E300 - 1.0E300 is 0.0 for every such
    a: not "nothing allowed" (a deadlock) but undecided, exit 3."""
    model = tmp_path / "round.mch"
    model.write_text("""MACHINE Round
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS
  PUSH(a) = PRE a : REAL & a >= 0.0 & a <= 1.0 & a + 1.0E300 - 1.0E300 > 0.5 THEN skip END;
  IDLE = skip
END""")
    state = tmp_path / "s.json"
    state.write_text('{"x": 0.0}')
    code, out, _ = run(capsys, "guards", model, "--state", state)
    assert code == 3 and "enabled: IDLE" in out and "deadlock" not in out
    assert "undecided: PUSH (undecided: the guard allows values over the reals" in out
    code, out, _ = run(capsys, "guards", model, "--state", state, "--json")
    assert code == 3 and list(json.loads(out)["undecided"]) == ["PUSH"]


def test_timeout_bounds_the_evaluation_itself(capsys):
    """10^8 pairs, each set within the size limit: --timeout stopped only the solver."""
    import time

    start = time.monotonic()
    code, out, err = run(capsys, "eval", "--timeout", "1",
                         "card({x, y | x : 1..10000 & y : 1..10000 & x + y = 3}) = 2")
    assert code == 3 and out == ""  # unknown: it could not tell
    assert "--timeout: tracecheck's evaluation took longer than 1 s" in err
    assert time.monotonic() - start < 5
