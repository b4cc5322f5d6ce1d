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


CONTINUOUS = load_machine_text("""MACHINE C
VARIABLES gap
INVARIANT gap : REAL
INITIALISATION gap := 30.0
OPERATIONS
  DRIVE(a, s) = PRE a : REAL & s : REAL & a <= gap / 10.0 - 2.0 THEN skip END
END""")


@pytest.mark.parametrize("bands,room", [
    # acceleration in [-1, 0.5]: -1 is the space's bound, 0.5 the guard's: the farthest
    # allowed value is 1.5 from where the guard flips; steering free: infinite room
    ({"a": ((-1.0, 0.5),), "s": ((-1.0, 1.0),)}, 1.5),
    ({"a": ((-0.2, 0.4),), "s": ((-1.0, 1.0),)}, 0.3),  # both ends the guard's: half of it
    ({"a": ((-1.0, -1.0),), "s": ((-1.0, 1.0),)}, 0.0),  # only full braking: no room
    ({"a": (), "s": ((-1.0, 1.0),)}, 0.0),  # nothing allowed: a deadlock
    ({"a": ((-1.0, -0.9), (0.1, 0.5)), "s": ((-1.0, 0.8),)}, 0.2),  # the roomiest interval
    ({"a": ((None, 0.5),), "s": ((-1.0, 1.0),)}, math.inf),  # unbounded below: no end there
])
def test_a_continuous_step_s_margin_is_the_room_its_guard_leaves(bands, room):
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    steps = (StepRecord(0, 0.0, None, {"gap": 25.0}, 0.0, False),
             StepRecord(1, 1.0, "DRIVE", {"gap": 25.0}, 0.0, False,
                        parameters={"a": -1.0, "s": 0.0}, allowed_intervals=bands))
    margins = GuardMargins(CONTINUOUS, {"DRIVE": ({"a": -1.0, "s": -1.0},
                                                   {"a": 1.0, "s": 1.0})})
    found = margins.episode(Episode(0, steps, make_end(steps)))
    assert found == (None if room == math.inf else pytest.approx(room))
    unrecorded = (steps[0], StepRecord(1, 1.0, "DRIVE", {"gap": 25.0}, 0.0, False,
                                       parameters={"a": 0.0, "s": 0.0}))
    assert margins.episode(Episode(0, unrecorded, make_end(unrecorded))) is None


def test_a_deadlock_is_as_close_as_can_be_whatever_the_set_s_shape():
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    steps = (StepRecord(0, 0.0, None, {"gap": 25.0}, 0.0, False),
             StepRecord(1, 1.0, "DRIVE", {"gap": 25.0}, 0.0, False, deadlock=True,
                        parameters={"a": -1.0, "s": 0.0}))  # no intervals recorded
    assert GuardMargins(CONTINUOUS).episode(Episode(0, steps, make_end(steps))) == 0.0
