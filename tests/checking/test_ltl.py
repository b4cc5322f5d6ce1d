"""LTL on recorded episodes: ProB's syntax, finite-trace semantics, the scans against the
obvious position-by-position definition, the authors' ASSERT_LTL assumptions."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.helpers import ROOT, run
from tracecheck.b.machine import load_machine_text
from tracecheck.b.columns import Columns
from tracecheck.checking.ltl import check_ltl, evaluate_ltl, parse_ltl, reference_ltl
from tracecheck.episodes.columns import RunColumns
from tracecheck.errors import BSyntaxError, BTypeError, InputError

TOY = load_machine_text("""
MACHINE Toy
VARIABLES p, q
INVARIANT p : BOOL & q : BOOL
INITIALISATION p := FALSE || q := FALSE
OPERATIONS
  A = SELECT p = TRUE THEN skip END;
  B = SELECT q = TRUE THEN skip END
END
""", file="Toy.mch")

ATOMS = ["{p = TRUE}", "{q = TRUE}", "BA({p$0 = TRUE => q = TRUE})", "[A]", "[B]", "e(A)",
         "deadlock", "true", "false"]


def formulas():
    leaf = st.sampled_from(ATOMS)
    unary = st.sampled_from(["not ", "G ", "F ", "X ", "Y ", "H ", "O ", "G[0,2] ", "F[1,3] "])
    binary = st.sampled_from([" & ", " or ", " => ", " U ", " W ", " R ", " S ", " T "])
    return st.recursive(
        leaf, lambda inner: st.one_of(
            st.tuples(unary, inner).map(lambda t: f"{t[0]}({t[1]})"),
            st.tuples(inner, binary, inner).map(lambda t: f"({t[0]}){t[1]}({t[2]})")),
        max_leaves=6)


episodes = st.lists(st.lists(st.tuples(st.booleans(), st.booleans(), st.sampled_from("AB")),
                             min_size=1, max_size=6), min_size=1, max_size=4)


def columns(eps) -> RunColumns:
    rows = [r for ep in eps for r in ep]
    n = len(rows)
    starts = np.concatenate([[0], np.cumsum([len(e) for e in eps])]).astype(np.int64)
    states = Columns(n=n, elements=())
    states.booleans["p"] = np.array([r[0] for r in rows])
    states.booleans["q"] = np.array([r[1] for r in rows])
    action = np.array([-1 if k == 0 else "AB".index(r[2]) for e in eps
                       for k, r in enumerate(e)], dtype=np.int16)
    lengths = np.diff(starts)
    return RunColumns(path="toy", episode_ids=np.arange(len(eps)), starts=starts,
                      episode=np.repeat(np.arange(len(eps)), lengths),
                      step=np.concatenate([np.arange(m) for m in lengths]),
                      time=np.zeros(n), action=action, action_names=("A", "B"),
                      reward=np.zeros(n), crashed=np.zeros(n, dtype=bool), states=states)


def trace(ep) -> list[dict]:
    out = []
    for k, (p, q, a) in enumerate(ep):
        nxt = ep[k + 1] if k + 1 < len(ep) else None
        out.append({
            "atoms": {"p = TRUE": p, "q = TRUE": q},
            "before_after": {"p$0 = TRUE => q = TRUE": nxt is None or (not p or nxt[1])},
            "action": None if k == 0 else a,
            "enabled": {n for n, on in (("A", p), ("B", q)) if on},
        })
    return out


@settings(max_examples=300, deadline=None)
@given(text=formulas(), eps=episodes)
def test_the_scans_give_the_position_by_position_semantics(text, eps):
    f = parse_ltl(text, TOY)
    got = evaluate_ltl(f, columns(eps), TOY)
    want = [v for ep in eps for v in reference_ltl(f, trace(ep))]
    assert list(got) == want, text


def test_finite_trace_conventions():
    eps = [[(True, False, "A"), (False, True, "B")]]
    cols = columns(eps)
    value = {t: list(evaluate_ltl(parse_ltl(t, TOY), cols, TOY)) for t in
             ["X true", "Y true", "[B]", "BA({1 = 2})", "G[5,9] false", "F[5,9] true"]}
    assert value == {"X true": [True, False], "Y true": [False, True], "[B]": [True, False],
                     "BA({1 = 2})": [False, True], "G[5,9] false": [True, True],
                     "F[5,9] true": [False, False]}


def test_the_first_violating_step_of_an_always_formula():
    eps = [[(False, False, "A")] * 3 + [(True, False, "A")], [(False, False, "A")] * 2]
    result = check_ltl("x", "G({p = FALSE})", parse_ltl("G({p = FALSE})", TOY), columns(eps),
                       TOY)
    assert (result.episodes, result.satisfied, result.violations) == (2, 1, ((0, 3),))


HUGE = "99999999999999999999"  # beyond int64: numpy overflowed on it (a traceback)


@settings(max_examples=100, deadline=None)
@given(eps=episodes, lo=st.sampled_from([0, 1, 2, 5, 10 ** 18, 10 ** 40]),
       span=st.sampled_from([0, 1, 3, 10 ** 18, 10 ** 60]), op=st.sampled_from("GF"))
def test_bounds_of_any_size_give_the_reference_semantics(eps, lo, span, op):
    """A bound past the episode's end is its end: any integer the parser reads, with the
    reference (plain Python, no numpy) as the judge."""
    text = f"{op}[{lo},{lo + span}]({{p = TRUE}} or [B])"
    f = parse_ltl(text, TOY)
    got = evaluate_ltl(f, columns(eps), TOY)
    assert list(got) == [v for ep in eps for v in reference_ltl(f, trace(ep))], text


def test_a_bound_past_every_end_is_the_unbounded_operator(capsys, tmp_path):
    eps = [[(True, False, "A"), (True, True, "B"), (False, True, "A")], [(True, True, "A")]]
    cols = columns(eps)
    for op in "GF":
        for text in (f"{op}[0,{HUGE}] {{p = TRUE}}", f"{op}[0,{'9' * 5000}] {{p = TRUE}}"):
            assert list(evaluate_ltl(parse_ltl(text, TOY), cols, TOY)) == list(
                evaluate_ltl(parse_ltl(f"{op} {{p = TRUE}}", TOY), cols, TOY)), text
    late = parse_ltl(f"G[{HUGE},{HUGE}1] false", TOY)
    assert list(evaluate_ltl(late, cols, TOY)) == [True] * 4  # no position: G holds
    with pytest.raises(BSyntaxError, match=r"the bounds \[999999999999…\(5000 digits\),5\] "
                                           "are empty"):
        parse_ltl(f"F[{'9' * 5000},5] true", TOY)
    from tests.helpers import episode
    from tracecheck.episodes import EpisodeWriter, new_header

    path = tmp_path / "run.mcap"
    with EpisodeWriter(path, new_header("recorded")) as w:
        w.write(episode(0, 3, crash_at_end=True))
    code, out, err = run(capsys, "replay", str(path), "--shield", "paper", "--json",
                         "--ltl", f"G[0,{HUGE}] true", "--ltl", f"G[0,{HUGE}] {{Crash = FALSE}}")
    assert code == 0, err
    assert [e["satisfied"] for e in json.loads(out)["ltl"]] == [1, 0]


@pytest.mark.parametrize("text,error,message", [
    ("G({p = TRUE}", BSyntaxError, "<ltl>:1:13: expected ')' but found 'the end of the "
                                   "formula'"),
    ("G({p = TRUE}) X", BSyntaxError, "<ltl>:1:15: unexpected 'X' after the formula"),
    ("{p = TRUE", BSyntaxError, "<ltl>:1:1: this '{' is never closed"),
    ("G[3,1] {p = TRUE}", BSyntaxError, "<ltl>:1:2: the bounds [3,1] are empty"),
    ("F [C]", InputError, "<ltl>:1:3: unknown operation 'C'; the operations of Toy are A, B"),
    ("e(C)", InputError, "unknown operation 'C'"),
    ("G({p})", BTypeError, "<ltl>:1:4: in the atom {p}: the formula must be a predicate"),
    ("G({r = TRUE})", Exception, "in the atom {r = TRUE}: unknown identifier r"),
    ("G(" * 300 + "true" + ")" * 300, BSyntaxError, "nests more than 200 levels"),
    ("", InputError, "an LTL formula is empty"),
])
def test_formulas_with_mistakes_are_located(text, error, message):
    with pytest.raises(error) as info:
        parse_ltl(text, TOY)
    assert message in str(info.value)


def test_replay_checks_formulas_on_every_episode(capsys, tmp_path):
    from tests.helpers import episode
    from tracecheck.episodes import EpisodeWriter, new_header

    path = tmp_path / "run.mcap"
    with EpisodeWriter(path, new_header("recorded")) as w:
        for i in range(3):
            w.write(episode(i, 3, crash_at_end=i == 1))
    code, out, err = run(capsys, "replay", str(path), "--shield", "paper", "--json",
                         "--ltl", "G({Crash = FALSE})", "--ltl", "F [IDLE]")
    assert code == 0, err
    ltl = json.loads(out)["ltl"]
    assert [(e["name"], e["satisfied"], e["episodes"]) for e in ltl] == \
        [("--ltl 1", 2, 3), ("--ltl 2", 3, 3)]
    assert ltl[0]["violations"] == [{"file": str(path), "episode": 1, "first_step": 3}]
    code, out, _ = run(capsys, "replay", str(path), "--shield", "paper",
                       "--ltl", "G({Crash = FALSE})")
    assert "LTL --ltl: G({Crash = FALSE}) — 2 of 3 episode(s) satisfy it; violated in " \
           "episode 1 (step 3)" in " ".join(out.split())  # lines wrap between words
    code, _, err = run(capsys, "replay", str(path), "--shield", "paper", "--ltl", "G({Crash")
    assert code == 2 and "--ltl:1:3: this '{' is never closed" in err
    code, _, err = run(capsys, "replay", str(path), "--shield", "paper", "--ltl-assertions")
    assert code == 2 and "the shield paper has no ASSERT_LTL definitions" in err


def test_replay_ltl_over_a_run_without_a_complete_episode(capsys, tmp_path):
    """A run killed in its first episode has no complete one: --ltl beside a good run
    crashed with numpy's "cannot reshape array of size 0" (a new user's warehouse)."""
    from tests.helpers import episode
    from tracecheck.episodes import EpisodeWriter, new_header

    empty, good = tmp_path / "empty.mcap", tmp_path / "good.mcap"
    with EpisodeWriter(empty, new_header("recorded")):
        pass
    with EpisodeWriter(good, new_header("recorded")) as w:
        w.write(episode(0, 3))
    for paths in ([empty], [empty, good]):
        code, out, err = run(capsys, "replay", *map(str, paths), "--shield", "paper",
                             "--json", "--ltl", "G({Crash = FALSE})")
        assert code == 0, err
        assert json.loads(out)["ltl"][0]["episodes"] == len(paths) - 1
    assert Columns.from_states([]).distinct()[0].tolist() == []


PAPER = ROOT.parent / "shared" / "data"
RSS = PAPER / "paper-models" / "HighwayEnvironment" / "HighwayEnvironment_RSS_v2.mch"


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    simb = PAPER / "paper-traces" / "simb"
    if not simb.is_dir() or not RSS.exists():
        pytest.skip(f"the paper's traces and machines are not at {PAPER}")
    out = tmp_path_factory.mktemp("ltl") / "paper.mcap"
    from tracecheck.cli import main

    with pytest.raises(SystemExit):
        main(["import", "simb", str(simb / "base"), str(simb / "base_shield"), "-o", str(out)])
    return out


def test_always_formulas_give_the_shares_of_the_paper_s_properties(capsys, paper_run):
    code, out, _ = run(capsys, "stats", str(paper_run), "--json")
    props = json.loads(out)["runs"][0]["properties"]
    code, out, _ = run(capsys, "replay", str(paper_run), "--shield", "paper", "--json",
                       "--ltl", "G({Crash = FALSE})", "--ltl",
                       "G(BA({Crash = FALSE => VehiclesVx$0(EgoVehicle) - VehiclesVx(EgoVehicle)"
                       " <= 5.0}))")
    ltl = json.loads(out)["ltl"]
    assert (ltl[0]["satisfied"], ltl[0]["episodes"]) == (props["SAF1"]["holds"], 40) == (30, 40)
    assert ltl[1]["satisfied"] == props["SAF4"]["holds"] == 40


def test_the_authors_assumptions_and_a_recording_edited_to_break_one(capsys, paper_run,
                                                                     tmp_path):
    code, out, err = run(capsys, "replay", str(paper_run), "--shield", str(RSS), "--json",
                         "--ltl-assertions")
    assert code == 0, err
    ltl = {e["name"]: e for e in json.loads(out)["ltl"]}
    assert sorted(ltl) == ["ASSERT_LTL1", "ASSERT_LTL2", "ASSERT_LTL3", "ASSERT_LTL4"]
    assert ltl["ASSERT_LTL3"]["satisfied"] == 40  # no step speeds up by more than aBrakeMax
    assert all(v["episode"] != 0 for e in ltl.values() for v in e["violations"]
               if e["name"] in ("ASSERT_LTL1", "ASSERT_LTL3"))
    # episode 0 edited: at step 5 the ego vehicle is 20 m/s slower than at step 4
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.episodes import EpisodeWriter
    from tracecheck.episodes.reader import read_run

    r = read_run(paper_run)
    ep = r.episodes[0]
    steps = list(ep.steps)
    vx = dict(steps[5].state["VehiclesVx"].map)
    vx[Elem("EgoVehicle")] = steps[4].state["VehiclesVx"].map[Elem("EgoVehicle")] - 20.0
    steps[5] = dataclasses.replace(steps[5], state={**steps[5].state,
                                                    "VehiclesVx": FuncValue(vx)})
    edited = tmp_path / "edited.mcap"
    with EpisodeWriter(edited, r.header) as w:
        w.write(dataclasses.replace(ep, steps=tuple(steps)))
    code, out, _ = run(capsys, "replay", str(edited), "--shield", str(RSS), "--json",
                       "--ltl-assertions")
    ltl = {e["name"]: e for e in json.loads(out)["ltl"]}
    # braking 20 m/s in one step breaks LTL1 at step 4 (the step from 4 to 5), speeding up
    # again breaks LTL3 at step 5; the episode as recorded broke neither
    assert ltl["ASSERT_LTL1"]["violations"] == [{"file": str(edited), "episode": 0,
                                                 "first_step": 4}]
    assert ltl["ASSERT_LTL3"]["violations"] == [{"file": str(edited), "episode": 0,
                                                 "first_step": 5}]
