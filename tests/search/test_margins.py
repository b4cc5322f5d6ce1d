"""The shield's guard margins (tracecheck.search.margins): a guard's robustness as STL reads
an atom, an episode's smallest over the actions taken, and the guide it gives falsify."""

from __future__ import annotations

import math

import pytest

from tracecheck.b import load_machine_text
from tracecheck.b.parser import parse_formula
from tracecheck.search.margins import GuardMargins

MACHINE = load_machine_text("""MACHINE M
VARIABLES gap, speed, ok
INVARIANT gap : REAL & speed : REAL & ok : BOOL
INITIALISATION gap := 30.0 || speed := 20.0 || ok := TRUE
OPERATIONS
  KEEP = SELECT gap > 10.0 & speed <= 25.0 THEN skip END;
  BRAKE = SELECT speed > 0.0 or ok = TRUE THEN skip END;
  TURN = SELECT ok = TRUE => gap >= 5.0 THEN skip END
END""")


@pytest.mark.parametrize("text,margin", [
    ("gap > 10.0", 20.0), ("gap < 10.0", -20.0), ("speed <= 25.0", 5.0),
    ("gap > 10.0 & speed <= 25.0", 5.0), ("gap > 40.0 or speed >= 15.0", 5.0),
    ("not(gap > 10.0)", -20.0), ("ok = TRUE => gap >= 5.0", 25.0),
    ("ok = TRUE", math.inf), ("ok = FALSE", -math.inf),
])
def test_a_guard_s_margin_is_its_robustness(text, margin):
    margins = GuardMargins(MACHINE)
    env = MACHINE.env({"gap": 30.0, "speed": 20.0, "ok": True})
    assert margins.margin(parse_formula(text, file="<t>"), env) == margin


def test_an_episode_s_margin_is_the_smallest_over_the_actions_taken():
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    states = [{"gap": 30.0, "speed": 20.0, "ok": True}, {"gap": 12.0, "speed": 24.0, "ok": True},
              {"gap": 11.0, "speed": 0.0, "ok": True}]
    steps = (StepRecord(0, 0.0, None, states[0], 0.0, False),
             StepRecord(1, 1.0, "KEEP", states[1], 0.0, False),  # in states[0]: min(20, 5)
             StepRecord(2, 2.0, "KEEP", states[2], 0.0, False))  # in states[1]: min(2, 1)
    episode = Episode(0, steps, make_end(steps))
    assert GuardMargins(MACHINE).episode(episode) == 1.0
    # BRAKE's guard is speed > 0.0 or ok = TRUE: a true atom with no distance: unbounded
    unbounded = (steps[0], StepRecord(1, 1.0, "BRAKE", states[1], 0.0, False))
    assert GuardMargins(MACHINE).episode(Episode(1, unbounded, make_end(unbounded))) is None


def test_the_guide_values_episodes_that_keep_the_property(tmp_path):
    from tests.search import corridor
    from tracecheck.episodes.reader import read_run
    from tracecheck.live.rollout import RecordSettings
    from tracecheck.search.falsify import FalsifySettings, falsify

    shield = tmp_path / "open.mch"
    shield.write_text(corridor.OPEN)
    values = {}
    for guide in ("margin", "none"):
        settings = FalsifySettings(
            RecordSettings(agent=corridor.agent_file(tmp_path), shield=str(shield),
                           episodes=1, env="tests.search.corridor:Corridor"),
            ("start={0,6}",), None, budget=4, optimizer="random", baseline=False,
            attribute=0, guide=guide)
        falsify(settings, tmp_path / f"{guide}.mcap")
        values[guide] = {ep.config["start"]: ep.search.objective
                         for ep in read_run(tmp_path / f"{guide}.mcap").episodes}
    # from 0 it crashes (-1 either way); from 6 it keeps it: STEP's guard pos >= 0 at 6, 7
    assert values["none"] == {0: -1.0, 6: 1.0}
    assert values["margin"] == {0: -1.0, 6: 6.0}
