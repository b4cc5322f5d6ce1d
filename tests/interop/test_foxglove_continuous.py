"""Foxglove's plots of continuous actions: per parameter the proposal, the executed value and
the first allowed interval's ends, and the projection distance — in a recording and in an
export, each message valid against the scalar schema; none of these channels for a discrete
run."""

from __future__ import annotations


import jsonschema
import pytest

from tests.helpers import run
from tests.interop.foxglove_schemas import PUBLISHED, channels_and_messages
from tests.stats.continuous_run import record_throttle, write_hand_run
from tracecheck.episodes import new_header
from tracecheck.episodes.model import StepRecord
from tracecheck.episodes.reader import read_run
from tracecheck.interop.foxglove import (SCHEMAS, TOPICS, FoxgloveChannels, continuous_topics,
                                         step_messages)

PLOTS = ("/plot/a/proposal", "/plot/a/executed", "/plot/a/allowed_low", "/plot/a/allowed_high",
         "/plot/projection_distance")


def _values(found, topic) -> list:
    name, encoding, messages = found[topic]
    assert (name, encoding) == ("tracecheck.Scalar", "jsonschema"), topic
    for m in messages:
        jsonschema.Draft202012Validator(PUBLISHED[name]).validate(m)
        jsonschema.Draft202012Validator(SCHEMAS[name]).validate(m)
    return [m["value"] for m in messages]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Two episodes of 25 steps of full throttle under throttle_v1.mch."""
    return record_throttle(tmp_path_factory.mktemp("throttle"), steps=25, episodes=2)


def test_a_continuous_recording_plots_proposal_execution_band_and_distance(recorded):
    found = channels_and_messages(recorded)
    steps = [s for e in read_run(recorded).episodes for s in e.steps[1:]]
    assert len(steps) == 50
    assert _values(found, "/plot/a/proposal") == [s.proposal["a"] for s in steps] == [2.0] * 50
    assert _values(found, "/plot/a/executed") == [s.parameters["a"] for s in steps]
    assert _values(found, "/plot/projection_distance") == \
        [s.projection_distance for s in steps]
    bands = [s.allowed_intervals["a"] for s in steps]
    assert _values(found, "/plot/a/allowed_low") == [b[0][0] for b in bands if b]
    assert _values(found, "/plot/a/allowed_high") == [b[0][1] for b in bands if b]
    assert any(not b for b in bands)  # a step where nothing was allowed: no message there
    logs = [m["message"] for m in found["/foxglove/log"][2]]
    assert any(m.startswith("episode 0, step 5: the shield moved the proposal a = 2 to -1.46")
               for m in logs), logs[:6]


def test_an_export_draws_the_hand_made_run_s_ends(tmp_path, capsys):
    hand = write_hand_run(tmp_path / "hand.mcap", action_low=[-4.0], action_high=[2.0])
    out = tmp_path / "hand-fox.mcap"
    code, _, err = run(capsys, "export", "foxglove", hand, "-o", out)
    assert code == 0, err
    found = channels_and_messages(out)
    assert set(PLOTS) <= set(found)
    # the first interval's ends; none where nothing was allowed (episode 1, step 1) or for
    # the unbounded low end of (-inf, 0] (episode 1, step 2)
    assert _values(found, "/plot/a/allowed_low") == [-4.0, -4.0, -4.0, -3.0, -4.0, -3.0]
    assert _values(found, "/plot/a/allowed_high") == [2.0, 1.0, -1.0, 0.0, -1.0, 1.5 + 1e-4,
                                                      2.0]
    assert _values(found, "/plot/a/executed")[3] == -4.0
    assert _values(found, "/plot/projection_distance") == [0.0, 1.0, 0.5, 6.0, 1.0, 0.0, 0.0,
                                                           0.5]
    logs = [m["message"] for m in found["/foxglove/log"][2]]
    assert "episode 1, step 1: the shield moved the proposal a = 2 to -4" in logs
    assert "episode 0, step 3: the shield moved the proposal a = 0 to 0.5" in logs


def test_a_discrete_run_has_none_of_these_channels():
    header = new_header("recorded", actions=["KEEP", "BRAKE"], variables=["x"])
    assert continuous_topics(header) == {} and FoxgloveChannels(header).topics == TOPICS
    step = StepRecord(2, 2.0, "BRAKE", {"x": 1.0}, 0.5, False, preferred_action="KEEP",
                      allowed_actions=("BRAKE",))
    topics = {m.topic for m in step_messages(step, episode=0, stamp_ns=0)}
    assert topics == {"/foxglove/log", "/plot/reward", "/plot/allowed_actions"}
    continuous = new_header("recorded", actions=["ACCELERATE"], variables=["x"],
                            action_parameters={"ACCELERATE": ["a"]})
    assert list(continuous_topics(continuous)) == list(PLOTS)


def test_parameters_the_header_does_not_declare_are_left_out():
    """A step with a parameter its run's header does not name has no channel to go to."""
    header = new_header("recorded", actions=["ACCELERATE"], variables=["x"])
    step = StepRecord(1, 1.0, "ACCELERATE", {"x": 1.0}, 0.0, False, parameters={"a": 1.0},
                      proposal={"a": 1.0}, projection_distance=0.0,
                      allowed_intervals={"a": ((None, None),)})
    messages = dict(FoxgloveChannels(header).messages(step, episode=0, stamp_ns=0,
                                                      previous_crashed=False))
    assert set(messages) == {"/plot/reward"}
    found = {m.topic: m.data["value"] for m in step_messages(step, episode=0, stamp_ns=0)}
    assert found == {"/plot/reward": 0.0, "/plot/a/proposal": 1.0, "/plot/a/executed": 1.0,
                     "/plot/projection_distance": 0.0}  # (-inf, inf): no ends to plot
