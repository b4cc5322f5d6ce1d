"""Crash attribution by branching re-simulation (tracecheck.search.attribution) on a corridor
where the answer is known: the agent's choice, a state no allowed action escapes, a shield
gap — and through falsify, each violation attributed in the run file."""

from __future__ import annotations

import pytest

from tests.search import corridor
from tracecheck.checking.shield import load_shield
from tracecheck.episodes.reader import read_run
from tracecheck.live.rollout import RecordSettings, Session
from tracecheck.search.attribution import attribute
from tracecheck.search.falsify import FalsifySettings, falsify
from tracecheck.search.objective import load_objective

ENV = "tests.search.corridor:Corridor"


def _episode(tmp_path, machine: str):
    shield_file = tmp_path / "corridor.mch"
    shield_file.write_text(machine)
    settings = RecordSettings(agent=corridor.agent_file(tmp_path), shield=str(shield_file),
                              episodes=1, env=ENV)
    shield = load_shield(str(shield_file), actions=corridor.Corridor.actions)
    session = Session(settings, shield=shield)
    episode = session.episode(0)
    objective = load_objective(None, shield.machine, corridor.Corridor.actions)
    return session, episode, objective


@pytest.mark.parametrize("machine,kind,step,action,avoiding", [
    (corridor.OPEN, "agent's choice", 5, "STEP", ("EXIT",)),
    (corridor.ONLY_STEP, "unavoidable under the shield", 1, "STEP", ()),
    (corridor.GAP, "shield gap", 4, "STEP", ("EXIT",)),
], ids=["choice", "unavoidable", "gap"])
def test_the_known_cause_of_each_crash(tmp_path, machine, kind, step, action, avoiding):
    session, episode, objective = _episode(tmp_path, machine)
    assert episode.end.crashed and episode.end.steps == corridor.PIT
    got = attribute(session, episode, objective, window=5)
    assert (got.kind, got.step, got.action, got.avoiding) == (kind, step, action, avoiding)


def test_a_narrow_window_says_the_doom_came_before_it(tmp_path):
    session, episode, objective = _episode(tmp_path, corridor.GAP)
    got = attribute(session, episode, objective, window=1)
    assert got.kind == "unavoidable under the shield" and got.step == 5
    assert "doomed at step 5 or before" in got.detail


def test_the_branches_are_the_allowed_actions_tried(tmp_path):
    session, episode, objective = _episode(tmp_path, corridor.GAP)
    got = attribute(session, episode, objective, window=2)
    # step 5 (at 4): only STEP allowed, the one taken: no branch; step 4 (at 3): EXIT avoids,
    # WAIT (then STEP, STEP) does not
    assert {(b.step, b.action, b.violated) for b in got.branches} == {
        (4, "EXIT", False), (4, "WAIT", True)}


def test_falsify_attributes_every_violation_in_the_file(tmp_path):
    shield_file = tmp_path / "gap.mch"
    shield_file.write_text(corridor.GAP)
    settings = FalsifySettings(
        RecordSettings(agent=corridor.agent_file(tmp_path), shield=str(shield_file),
                       episodes=1, env=ENV),
        ("start={0,1,2,6}",), None, budget=8, optimizer="random", baseline=False)
    result = falsify(settings, tmp_path / "f.mcap")
    episodes = read_run(tmp_path / "f.mcap").episodes
    crashed = [ep for ep in episodes if ep.end.crashed]
    assert crashed and all(ep.search.violated for ep in crashed)
    for ep in episodes:
        if ep.end.crashed:  # from any start before the pit: STEP into 4 sealed it
            assert (ep.search.attribution, ep.search.attribution_step) == \
                ("shield gap", 4 - ep.config["start"])
        else:  # started past the pit
            assert ep.config["start"] == 6 and ep.search.attribution is None
    assert result.summaries[0].attributions == {"shield gap": len(crashed)}
