"""Machines made of machines (tracecheck.b.composition): SEES, INCLUDES with renaming and
parameters, PROMOTES, EXTENDS, calls of included operations with arguments and outputs;
errors told in the included file; and the paper's shield split over three machines deciding
every step of the paper's traces exactly as the flat machine does, on both paths."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tracecheck.b import load_machine
from tracecheck.b.columns import Columns
from tracecheck.b.values import Elem
from tracecheck.errors import BScopeError, BSyntaxError, BTypeError

from tests.helpers import PAPER_SHIELD, PAPER_TRACES, ROOT, run, simb_states

SPLIT = ROOT / "tests" / "fixtures" / "composed" / "PaperSplit.mch"
FLAT = PAPER_SHIELD

CTX = """MACHINE Ctx
SETS COLOUR = {red, green}
CONSTANTS limit
PROPERTIES limit = 5
END"""

COUNTER = """MACHINE Counter(start)
CONSTRAINTS start : NATURAL
SEES Ctx
VARIABLES count
INVARIANT count : 0..limit
INITIALISATION count := start
OPERATIONS
  Inc(n) = PRE n : 1..2 & count + n <= limit THEN count := count + n END;
  v <-- Get = v := count
END"""

MAIN = """MACHINE Main
SEES Ctx
INCLUDES c.Counter(1)
PROMOTES c.Inc
VARIABLES light, seen
INVARIANT light : COLOUR & seen : NATURAL & c.count <= limit
INITIALISATION light := red || seen := 0
OPERATIONS
  Go = SELECT light = red & c.count < limit THEN light := green || c.Inc(1) END;
  Look = VAR v IN v <-- c.Get; seen := v END
END"""


def write(folder: Path, **machines: str) -> None:
    for name, text in machines.items():
        (folder / f"{name}.mch").write_text(text)


@pytest.fixture()
def main(tmp_path):
    write(tmp_path, Ctx=CTX, Counter=COUNTER, Main=MAIN)
    return load_machine(tmp_path / "Main.mch")


S = {"c.count": 1, "light": Elem("red"), "seen": 0}


def test_seen_sets_and_constants_and_renamed_included_variables(main):
    assert main.variables == ("c.count", "light", "seen")
    assert tuple(main.sets["COLOUR"]) == (Elem("red"), Elem("green"))
    assert main.evaluate("limit", S) == 5
    assert main.invariant(S) and not main.invariant({**S, "c.count": 6})


def test_the_included_initialisation_takes_the_parameter(main):
    assert main.initialisation_ok(S) and not main.initialisation_ok({**S, "c.count": 0})


def test_promoted_and_called_operations(main):
    assert main.enabled(S) == {"Go", "Look", "c.Inc"}
    assert main.enabled({**S, "c.count": 5}) == {"Look"}  # Inc's PRE is Go's guard too
    assert main.check_after("Go", S, {**S, "light": Elem("green"), "c.count": 2})
    assert not main.check_after("Go", S, {**S, "light": Elem("green"), "c.count": 3})
    assert main.check_after("c.Inc", S, {**S, "c.count": 3})
    assert main.check_after("Look", S, {**S, "seen": 1})  # v <-- c.Get: the output


def test_extends_promotes_every_operation(tmp_path):
    write(tmp_path, Ctx=CTX, Counter=COUNTER, Ext="""MACHINE Ext
EXTENDS Counter(0)
END""")
    m = load_machine(tmp_path / "Ext.mch")
    assert set(m.operations) == {"Inc", "Get"} and m.variables == ("count",)
    assert m.check_after("Inc", {"count": 0}, {"count": 2})


def test_an_error_in_an_included_machine_is_told_in_its_file(tmp_path):
    write(tmp_path, Ctx=CTX, Main=MAIN,
          Counter=COUNTER.replace("count := start", "count := TRUE"))
    with pytest.raises(BTypeError) as err:
        load_machine(tmp_path / "Main.mch")
    assert err.value.file == str(tmp_path / "Counter.mch") and err.value.line == 6
    assert "INITIALISATION count := TRUE" in str(err.value)


@pytest.mark.parametrize("change,message,line", [
    (("c.Counter(1)", "c.Counter"), r"Counter has parameters \(start\); give their values",
     3),
    (("c.Counter(1)", "c.Counter(1, 2)"), r"Counter has 1 parameter\(s\), 2 given", 3),
    (("c.Counter(1)", "c.Nope(1)"), "no machine Nope: Nope.mch is in none of", 3),
    (("PROMOTES c.Inc", "PROMOTES c.Dec"), "PROMOTES c.Dec: no included machine has", 4),
    (("c.Inc(1) END", "c.Inc(1, 2) END"), r"c.Inc takes 1 argument\(s\) and gives 0", 9),
])
def test_composition_errors_name_the_place(tmp_path, change, message, line):
    write(tmp_path, Ctx=CTX, Counter=COUNTER, Main=MAIN.replace(*change))
    with pytest.raises(BScopeError, match=message) as err:
        load_machine(tmp_path / "Main.mch")
    assert err.value.file == str(tmp_path / "Main.mch") and err.value.line == line


def test_a_machine_that_includes_itself_is_an_error(tmp_path):
    write(tmp_path, A="MACHINE A INCLUDES B END", B="MACHINE B INCLUDES A END")
    with pytest.raises(BScopeError, match="includes itself"):
        load_machine(tmp_path / "A.mch")


def test_machines_are_found_on_the_search_path(tmp_path, monkeypatch):
    lib = tmp_path / "lib"
    lib.mkdir()
    write(lib, Ctx=CTX)
    write(tmp_path, Main="MACHINE Main SEES Ctx CONSTANTS k PROPERTIES k = limit END")
    with pytest.raises(BScopeError, match="no machine Ctx"):
        load_machine(tmp_path / "Main.mch")
    monkeypatch.setenv("TRACECHECK_MACHINE_PATH", str(lib))
    assert load_machine(tmp_path / "Main.mch").evaluate("k", {}) == 5


def test_own_parameters_are_constants_and_deferred_sets(tmp_path):
    write(tmp_path, P="""MACHINE P(ITEM, n)
CONSTRAINTS n = 3
VARIABLES x
INVARIANT x : ITEM
INITIALISATION x :: ITEM
END""")
    m = load_machine(tmp_path / "P.mch")
    assert m.evaluate("n", {"x": Elem("ITEM1")}) == 3 and "ITEM" in m.sets


# ------------------------------------------------------------------ the paper's shield, split


def _traces():
    if not PAPER_TRACES.is_dir():
        pytest.skip(f"the paper's traces are not at {PAPER_TRACES}")
    for f in sorted((PAPER_TRACES / "simb").rglob("*.json")):
        yield f.name, simb_states(f)


def _renamed(state: dict) -> dict:
    return {f"cars.{k}": v for k, v in state.items()}


def test_the_split_shield_decides_every_step_of_the_paper_traces_as_the_flat_one():
    flat, split = load_machine(FLAT), load_machine(SPLIT)
    steps = enabled = 0
    states = []
    for name, trace in _traces():
        for (_, before), (op, after) in zip(trace, trace[1:]):
            states.append(before)
            assert split.enabled(_renamed(before)) == flat.enabled(before), name
            if op in flat.operations:
                steps += 1
                got = split.check_after(op, _renamed(before), _renamed(after))
                assert got == flat.check_after(op, before, after), (name, op)
                enabled += got
    assert steps > 1000 and enabled > 0
    # the batch path, over the same states
    elements = tuple(flat.sets["Vehicles"])
    a = flat.enabled_batch(Columns.from_states(states, elements))
    b = split.enabled_batch(Columns.from_states([_renamed(s) for s in states], elements))
    assert {k: v.tolist() for k, v in a.items()} == {k: v.tolist() for k, v in b.items()}


def test_replay_and_diff_of_the_paper_traces_see_no_change_with_the_composed_shield(
        tmp_path, capsys):
    """Through the CLI, with the included machine not renamed (the traces name the variables
    as the flat machine does): `diff` finds no changed step and `replay` the same figures."""
    if not PAPER_TRACES.is_dir():
        pytest.skip(f"the paper's traces are not at {PAPER_TRACES}")
    for name in ("PaperCtx", "PaperCars"):
        (tmp_path / f"{name}.mch").write_text((SPLIT.parent / f"{name}.mch").read_text())
    split = tmp_path / "Split.mch"
    split.write_text(SPLIT.read_text().replace("cars.PaperCars", "PaperCars")
                     .replace("cars.", "").replace("MACHINE PaperSplit", "MACHINE Split"))
    paper = tmp_path / "paper.mcap"
    run(capsys, "import", "simb", PAPER_TRACES / "simb" / "base",
        PAPER_TRACES / "simb" / "base_shield", "-o", paper)
    code, out, _ = run(capsys, "diff", paper, "--shield", FLAT, "--against", split,
                       "--fail-on-change")
    out = " ".join(out.split())
    assert code == 0, out
    assert "changed steps: 0" in out and "states whose enabled set differs: 0" in out
    reports = []
    for shield in (FLAT, split):
        report = json.loads(run(capsys, "replay", paper, "--shield", shield, "--format",
                                "json")[1])
        reports.append({k: v for k, v in report.items() if "shield" not in k
                        and k not in ("model", "provenance", "elapsed_s", "steps_per_s")})
    assert reports[0] == reports[1] and reports[0]["episodes"] == 40


def test_definition_files_of_the_user_s_own(tmp_path, monkeypatch):
    (tmp_path / "common.def").write_text('DEFINITIONS\n  LIMIT == 5;\n  ok(v) == v < LIMIT;\n'
                                         '  "more.def"\n')
    (tmp_path / "more.def").write_text("DEFINITIONS TWICE(v) == 2 * v")
    write(tmp_path, M="""MACHINE M
DEFINITIONS "common.def"; "LibraryStrings.def"; STEP == TWICE(1)
VARIABLES x
INVARIANT x : 0..10
INITIALISATION x := 0
OPERATIONS Up = SELECT ok(x) THEN x := x + STEP END
END""")
    m = load_machine(tmp_path / "M.mch")
    assert m.is_enabled("Up", {"x": 4}) and not m.is_enabled("Up", {"x": 5})
    assert m.check_after("Up", {"x": 1}, {"x": 3})
    assert m.evaluate('STRING_LENGTH("abc")', {"x": 0}) == 3  # the library still built in
    # an error in a definition file is told there
    (tmp_path / "more.def").write_text("DEFINITIONS\nTWICE(v) == 2 *")
    with pytest.raises(BSyntaxError) as err:
        load_machine(tmp_path / "M.mch")
    assert err.value.file == str(tmp_path / "more.def") and err.value.line == 2
    (tmp_path / "M.mch").write_text((tmp_path / "M.mch").read_text().replace("common", "gone"))
    with pytest.raises(BScopeError, match="no definition file gone.def: gone.def is in none"):
        load_machine(tmp_path / "M.mch")


def test_a_call_of_no_operation_is_an_error_at_load(tmp_path):
    write(tmp_path, Ctx=CTX, Counter=COUNTER, Main=MAIN.replace("c.Inc(1) END", "c.Nope(1) END"))
    with pytest.raises(BScopeError, match="unknown operation or substitution c.Nope") as err:
        load_machine(tmp_path / "Main.mch")
    assert err.value.line == 9


def test_renamed_names_in_eval_and_a_parameter_breaking_constraints(tmp_path, capsys):
    write(tmp_path, Ctx=CTX, Counter=COUNTER, Main=MAIN)
    state = tmp_path / "s.json"
    state.write_text('{"c.count": "2", "light": "red", "seen": "0"}')
    assert run(capsys, "eval", "-m", tmp_path / "Main.mch", "-s", state, "c.count + 1",
               "c.count < limit")[:2] == (0, "3\nTRUE\n")
    write(tmp_path, E="MACHINE E SEES Ctx INCLUDES Counter(-1) END")
    code, _, err = run(capsys, "check-model", tmp_path / "E.mch")
    assert code == 2 and "`(-1) : NATURAL` is false" in err and "E.mch:1:37" in err


@pytest.mark.parametrize("text,message", [
    ("MACHINE Z SEES END", "the SEES clause is empty"),
    ("MACHINE Z SEES Ctx OPERATIONS END", "the OPERATIONS clause is empty"),
    ("MACHINE Z(a SEES Ctx END", r"expected the machine's name, or M\(p, …\)"),
    ("MACHINE Z SEES Ctx OPERATIONS = skip END", "an operation needs a name before its '='"),
    ("MACHINE Z INCLUDES a.b.Ctx END", "expected a machine's name, or r.M to rename it"),
    ("MACHINE Z REFINES Y SEES Ctx END", "the clause REFINES is not supported"),
])
def test_a_composed_machine_s_syntax_errors_are_located(tmp_path, text, message):
    write(tmp_path, Ctx=CTX, Z=text)
    with pytest.raises(BSyntaxError, match=message) as err:
        load_machine(tmp_path / "Z.mch")
    assert err.value.file == str(tmp_path / "Z.mch") and err.value.line == 1
