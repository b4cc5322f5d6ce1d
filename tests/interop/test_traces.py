"""ProB and SimB traces: the paper's files import; exports import back to the same states."""

from __future__ import annotations

import re

import json

import pytest

from tests.helpers import ROOT, episode as make_episode
from tracecheck.b.machine import load_machine
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.errors import InputError
from tracecheck.interop import export_prob2trace, export_simb, import_prob2trace, import_simb
from tracecheck.interop.common import vocabulary_of
from tracecheck.interop.prob2trace import prob2trace_document
from tracecheck.interop.simb import simb_document


def same(a, b):
    assert [s.state for s in a.steps] == [s.state for s in b.steps]
    assert a.actions == b.actions
    assert [s.time for s in a.steps] == [s.time for s in b.steps]
    assert a.end == b.end


def test_paper_simb_traces(paper_traces):
    base = list(import_simb([paper_traces / "simb" / "base"], vocab=HIGHWAY))
    shield = list(import_simb([paper_traces / "simb" / "base_shield"], vocab=HIGHWAY))
    assert len(base) == len(shield) == 20
    assert sum(e.end.steps for e in base) == 765
    assert sum(e.end.crashed for e in base) == 9 and sum(e.end.crashed for e in shield) == 1
    first = base[0]
    assert first.origin.endswith("Timed_Simulation_1.json")
    assert first.steps[0].action is None and first.steps[1].action == "FASTER"
    assert first.steps[1].time == 1.0 and first.steps[-1].time == 60.0
    assert first.end.reason == "time-limit"
    assert [e.end.reason for e in base if e.end.crashed] == ["crashed"] * 9


def test_paper_prob2traces(paper_traces):
    eps = list(import_prob2trace([paper_traces / "prob2trace"], vocab=HIGHWAY))
    assert len(eps) == 4
    names = [e.origin.rsplit("/", 1)[-1] for e in eps]
    assert names[0] == "Agent_Lane_Left_Collision.prob2trace"
    crash = eps[0]
    assert crash.end.crashed and crash.end.steps == 6
    # destState holds only what changed: the rest carries over
    assert crash.steps[2].state["PresentVehicles"] == crash.steps[1].state["PresentVehicles"]


def test_simb_round_trip(paper_traces, tmp_path):
    eps = list(import_simb([paper_traces / "simb" / "base_shield"], vocab=HIGHWAY))
    export_simb(eps, tmp_path / "out", HIGHWAY.name)
    back = list(import_simb([tmp_path / "out"], vocab=HIGHWAY))
    for a, b in zip(eps, back):
        same(a, b)
    doc = json.loads((tmp_path / "out" / "Timed_Simulation_1.json").read_text())
    assert doc["metadata"]["fileType"] == "Timed_Trace" and doc["metadata"]["formatVersion"] == 3
    assert [a["execute"] for a in doc["activations"][:3]] == [
        "$setup_constants", "$initialise_machine", eps[0].steps[1].action]
    assert doc["activations"][2]["after"] == "1000"


def test_prob2trace_round_trip(paper_traces, tmp_path):
    for k, ep in enumerate(import_prob2trace([paper_traces / "prob2trace"], vocab=HIGHWAY)):
        path = export_prob2trace(ep, tmp_path / f"{k}.prob2trace", HIGHWAY)
        (back,) = import_prob2trace([path], vocab=HIGHWAY)
        same(ep, back)
    doc = json.loads(path.read_text())
    assert doc["metadata"]["fileType"] == "Trace" and doc["metadata"]["formatVersion"] == 5
    assert doc["transitionList"][0]["name"] == "$setup_constants"


def test_round_trip_of_hand_made_episode(tmp_path):
    ep = make_episode(0, 4, crash_at_end=True)
    export_simb([ep], tmp_path, HIGHWAY.name)
    (back,) = import_simb([tmp_path / "Timed_Simulation_1.json"], vocab=HIGHWAY)
    assert [s.state for s in back.steps] == [s.state for s in ep.steps]
    (again,) = import_prob2trace([export_prob2trace(ep, tmp_path / "e.prob2trace", HIGHWAY)], vocab=HIGHWAY)
    assert [s.state for s in again.steps] == [s.state for s in ep.steps]


def test_prob2trace_only_writes_changes():
    doc = prob2trace_document(make_episode(0, 2), HIGHWAY)
    step1 = doc["transitionList"][2]
    assert "Crash" in step1["destStateNotChanged"] and "VehiclesX" in step1["destState"]


def _simb(tmp_path, activations, name="t.json"):
    path = tmp_path / name
    path.write_text(json.dumps({"activations": activations}))
    return path


def _init(state):
    return {"id": "$initialise_machine", "execute": "$initialise_machine", "after": "0",
            "fixedVariables": state}


GOOD = simb_document(make_episode(0, 1), HIGHWAY.name)["activations"][1]["fixedVariables"]


@pytest.mark.parametrize("activations,fragment", [
    ([_init({**GOOD, "VehiclesX": "{(EgoVehicle↦1.0"})],
     "t.json, step 0, variable VehiclesX: expected ')' but found 'end of text'"),
    ([_init({**GOOD, "Speed": "1.0"})], "t.json, step 0: unknown variable 'Speed'"),
    ([_init({k: v for k, v in GOOD.items() if k != "Reward"})], "step 0: no value for Reward"),
    ([_init(GOOD), {"execute": "JUMP", "after": "1000", "fixedVariables": GOOD}],
     "t.json, step 1: unknown operation 'JUMP'; the actions are LANE_LEFT, IDLE"),
    ([_init(GOOD), {"execute": "IDLE", "after": "soon", "fixedVariables": GOOD}],
     "activation 1: 'after' must be a delay in ms between 0 and 31536000000 (a year), not "
     "'soon'"),
    *[([_init(GOOD), {"execute": "IDLE", "after": after, "fixedVariables": GOOD}],
       f"activation 1: 'after' must be a delay in ms between 0 and 31536000000 (a year), not "
       f"{after!r}") for after in ("nan", "inf", "-inf", "1e30", "-5", True, [1])],
    ([{"execute": "IDLE", "after": "0", "fixedVariables": GOOD}],
     "does not start with $initialise_machine"),
    ([_init({**GOOD, "Crash": "1.0"})], "step 0: Crash must be TRUE or FALSE, not 1.0"),
    ([], "the trace has no initial state"),
])
def test_bad_simb(tmp_path, activations, fragment):
    with pytest.raises(InputError) as info:
        list(import_simb([_simb(tmp_path, activations)], vocab=HIGHWAY))
    assert fragment in str(info.value)


def test_json_nested_too_deeply_or_too_large(tmp_path, monkeypatch):
    path = tmp_path / "deep.json"
    path.write_text('{"activations": ' + "[" * 5000 + "]" * 5000 + "}")
    with pytest.raises(InputError) as info:
        list(import_simb([path], vocab=HIGHWAY))
    assert info.value.message == "not valid JSON: depth limit exceeded"
    assert (info.value.file, info.value.line, info.value.column) == (str(path), 1, 1041)
    import tracecheck.inputs as inputs

    monkeypatch.setattr(inputs, "MAX_TEXT_BYTES", 1000)
    monkeypatch.setattr(inputs.read_json, "__defaults__", (1000,))
    big = tmp_path / "big.json"
    big.write_text(" " * 2000)
    with pytest.raises(InputError, match=r"the trace file .*big.json has 2,000 bytes; "
                                         r"tracecheck reads at most 1,000 for a trace file"):
        list(import_simb([big], vocab=HIGHWAY))


def test_malformed_json_is_located(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"activations": [\n  {"execute": "IDLE",}\n]}')
    with pytest.raises(InputError) as info:
        list(import_simb([path], vocab=HIGHWAY))
    assert (info.value.file, info.value.line) == (str(path), 2)
    assert "not valid JSON" in info.value.message


@pytest.mark.parametrize("doc,fragment", [
    ({"nothing": 1}, "not a ProB trace (no 'transitionList')"),
    ({"transitionList": [{"name": "FASTER", "destState": {}}]},
     "does not start with $initialise_machine"),
    ({"transitionList": [{"destState": {}}]}, "a transition is a JSON object with a 'name'"),
])
def test_bad_prob2trace(tmp_path, doc, fragment):
    path = tmp_path / "t.prob2trace"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=fragment.replace("(", r"\(").replace(")", r"\)")
                       .replace("$", r"\$")):
        list(import_prob2trace([path], vocab=HIGHWAY))


def test_missing_paths(tmp_path):
    with pytest.raises(InputError, match="no such file or folder"):
        list(import_simb([tmp_path / "nope"], vocab=HIGHWAY))
    with pytest.raises(InputError, match="holds no \\*.json files"):
        list(import_simb([tmp_path], vocab=HIGHWAY))


def test_import_checked_against_a_machine(paper_traces, tmp_path):
    machine = load_machine(ROOT / "models" / "shields" / "paper.mch")
    vocab = vocabulary_of(machine)
    assert set(vocab.variables) == set(HIGHWAY.variables)
    eps = list(import_simb([paper_traces / "simb" / "base" / "Timed_Simulation_1.json"],
                           vocab=vocab, machine=machine))
    assert eps[0].end.steps == 60
    wrong = _simb(tmp_path, [_init({**GOOD, "Reward": "1"})])
    with pytest.raises(InputError, match="step 0: Reward must be of type REAL"):
        list(import_simb([wrong], vocab=vocab, machine=machine))


def test_an_episode_that_did_not_end_by_its_time_limit_is_not_read_back_as_one(tmp_path):
    """ENDING_TIME is written only for an episode that ended by its time limit: a crash in
    states without a Crash variable (a new user's tank) was read back as 'time-limit'."""
    from tracecheck.episodes.model import Episode, StepRecord, make_end
    from tracecheck.episodes.vocabulary import Vocabulary

    def episode(reason):
        steps = tuple(StepRecord(step=k, time=float(k), action=None if k == 0 else "Fill",
                                 state={"level": k}, reward=0.0, crashed=k == 2)
                      for k in range(3))
        return Episode(id=0, steps=steps, end=make_end(steps, reason), seed=0)

    tank = Vocabulary(("level",), ("Fill",), "Tank")
    for reason, expected in (("crashed", "end-of-trace"), ("time-limit", "time-limit")):
        folder = tmp_path / reason
        export_simb([episode(reason)], folder, tank.name, lossy=True)
        (back,) = import_simb([folder], vocab=tank)
        assert back.end.reason == expected, reason


def test_a_trace_export_that_would_drop_crashes_rewards_or_proposals_refuses(tmp_path):
    """Issue 42: export prob2trace then import dropped the crash flag, the rewards and the
    proposals with exit 0 (export simb refused only continuous values)."""
    from tracecheck.episodes.model import Episode, StepRecord, make_end
    from tracecheck.episodes.vocabulary import Vocabulary
    from tracecheck.errors import InputError
    from tracecheck.interop import export_prob2trace

    def episode(**last):
        steps = tuple(StepRecord(step=k, time=float(k), action=None if k == 0 else "Fill",
                                 state={"level": k}, **{"reward": 0.0, "crashed": False,
                                                        **(last if k == 2 else {})})
                      for k in range(3))
        return Episode(id=4, steps=steps, end=make_end(steps, "end-of-trace"), seed=0)

    tank = Vocabulary(("level",), ("Fill",), "Tank")
    for i, (extra, said) in enumerate((({"crashed": True}, "has no place for the crash (episode 4, step 2; "
                                             "the states have no Crash variable)"),
                        ({"reward": 1.5}, "has no place for the rewards (episode 4, step 2: 1.5;"),
                        ({"proposal": {"u": 0.5}}, "the agent's proposals"))):
        trace = tmp_path / f"t{i}.prob2trace"
        with pytest.raises(InputError, match=re.escape(said)):
            export_prob2trace(episode(**extra), trace, tank)
        with pytest.raises(InputError, match="exporting would drop it"):
            export_simb([episode(**extra)], tmp_path / "simb", tank.name)
        assert not trace.exists()
        export_prob2trace(episode(**extra), trace, tank, lossy=True)
    export_prob2trace(episode(), tmp_path / "plain.prob2trace", tank)  # nothing to lose


CORRIDOR = """MACHINE Corridor
VARIABLES pos, Crash, Reward
INVARIANT pos : 0..4 & Crash : BOOL & Reward : REAL
INITIALISATION pos := 0 || Crash := FALSE || Reward := 0.0
OPERATIONS
  Right = SELECT pos < 4 THEN pos := pos + 1 END;
  Jump(n) = PRE n : 1..2 & pos + n <= 4 THEN pos := pos + n END;
  Push(f) = PRE f : REAL & f <= 1.0 THEN skip END
END"""


@pytest.mark.parametrize("name, params, fragment", [
    ("Jump", {"n": "2"}, "Jump(n = 2): a run keeps the values of REAL parameters only"),
    ("Jump", {"zz": "1"}, "Jump takes n; the trace gives zz"),
    ("Jump", {}, "Jump takes n; the trace gives none"),
    ("Right", {"x": "1.0"}, "Right takes no parameters; the trace gives x"),
    ("Push", {"f": "0.5"}, None),  # a continuous action's value: kept
])
def test_a_prob2traces_parameters_are_kept_or_refused_never_dropped(tmp_path, name, params,
                                                                    fragment):
    """Jump(n) with n = 2 was imported as Jump, its n dropped (a wrong n = 7, a parameter
    the operation lacks, none at all: all accepted); replay then said "n has no value
    here" (a new user's corridor)."""
    mch = tmp_path / "Corridor.mch"
    mch.write_text(CORRIDOR)
    machine = load_machine(mch)
    state = {"pos": "0", "Crash": "FALSE", "Reward": "0.0"}
    path = tmp_path / "t.prob2trace"
    path.write_text(json.dumps({"transitionList": [
        {"name": "$initialise_machine", "params": {}, "destState": state},
        {"name": name, "params": params, "destState": {"pos": "1"}}]}))
    if fragment is None:
        (ep,) = import_prob2trace([path], vocab=vocabulary_of(machine), machine=machine)
        assert ep.steps[1].parameters == {"f": 0.5}
        return
    with pytest.raises(InputError) as info:
        list(import_prob2trace([path], vocab=vocabulary_of(machine), machine=machine))
    assert fragment in info.value.message and "step 1" in info.value.message


def test_a_reward_too_large_for_a_float_is_said_where(tmp_path):
    path = tmp_path / "t.prob2trace"
    path.write_text(json.dumps({"transitionList": [
        {"name": "$initialise_machine", "destState": {**GOOD, "Reward": "1" + "0" * 400}}]}))
    with pytest.raises(InputError, match=r"t.prob2trace, step 0: Reward is an integer of 401 "
                                         r"digits, too large for the float"):
        list(import_prob2trace([path], vocab=HIGHWAY))


def test_a_traces_setup_constants_must_be_the_machines(tmp_path):
    """Limit = 5 in the trace, 4 in the machine: imported and replayed as clean, where
    project says the trace fails (a new user's corridor); now refused, saying which."""
    mch = tmp_path / "Lim.mch"
    mch.write_text(CORRIDOR.replace("MACHINE Corridor", "MACHINE Lim CONSTANTS Limit "
                                    "PROPERTIES Limit = 4"))
    machine = load_machine(mch)
    state = {"pos": "0", "Crash": "FALSE", "Reward": "0.0"}
    for limit, fragment in (("5", "$setup_constants gives Limit = 5, not 4 — the trace was "
                                  "made with another machine than Lim"),
                            ("TRUE", "Limit must be of type INTEGER"), ("4", None)):
        path = tmp_path / "t.prob2trace"
        path.write_text(json.dumps({"transitionList": [
            {"name": "$setup_constants", "destState": {"Limit": limit}},
            {"name": "$initialise_machine", "destState": state}]}))
        simb = _simb(tmp_path, [{"id": "$setup_constants", "execute": "$setup_constants",
                                 "after": "0", "fixedVariables": {"Limit": limit}},
                                _init(state)])
        for read, p in ((import_prob2trace, path), (import_simb, simb)):
            if fragment is None:
                assert len(list(read([p], vocab=vocabulary_of(machine), machine=machine))) == 1
                continue
            with pytest.raises(InputError) as info:
                list(read([p], vocab=vocabulary_of(machine), machine=machine))
            assert fragment in info.value.message



def test_setup_constants_that_are_not_literals_are_not_judged(tmp_path):
    """ProB prints NATURAL, 1..1000000 and /*@symbolic*/ lambdas: such values are not read
    as literals of the constant's type, so they are not compared (a review found them
    refused: 'N must be of type POW(INTEGER)', "unexpected '.'")."""
    mch = tmp_path / "C.mch"
    mch.write_text(CORRIDOR.replace("MACHINE Corridor", "MACHINE C CONSTANTS N, Big, f "
                                    "PROPERTIES N = NATURAL & Big = 1..1000000 & "
                                    "f = %x.(x : NATURAL | x + 1)"))
    machine = load_machine(mch)
    path = tmp_path / "t.prob2trace"
    path.write_text(json.dumps({"transitionList": [
        {"name": "$setup_constants", "destState": {
            "N": "NATURAL", "Big": "1..1000000", "f": "/*@symbolic*/ %x.(x : NATURAL|x + 1)"}},
        {"name": "$initialise_machine",
         "destState": {"pos": "0", "Crash": "FALSE", "Reward": "0.0"}}]}))
    assert len(list(import_prob2trace([path], vocab=vocabulary_of(machine),
                                      machine=machine))) == 1
