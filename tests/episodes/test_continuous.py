"""Continuous actions in the file format: the parameter values, proposal and projection distance
of each step in its message and in the columns (per episode and in the run blob), the run
header's action space; files written before them still read."""

from __future__ import annotations

import dataclasses
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.helpers import episode, from_blobs, walking
from tracecheck.episodes import EpisodeWriter, new_header, read_columns, read_header, read_run
from tracecheck.episodes import writer as W
from tracecheck.episodes.codec import decode_columns
from tracecheck.episodes.columns import episode_columns
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.episodes.records import Attachment, walk
from tracecheck.errors import InputError

#: written by tracecheck before continuous actions (the tests' three hand-made episodes)
BEFORE = Path(__file__).parent / "data" / "discrete_before_parameters.mcap"
ACTIONS = ["ACCELERATE", "STEER", "IDLE"]
HEADER = dict(actions=ACTIONS, action_parameters={"ACCELERATE": ["a"]}, action_low=[-4.0],
              action_high=[2.0], shield_mode="project", projection_scale=[2.0])


def acc_episode(eid: int, params=("a",), n: int = 3) -> Episode:
    """Steps of ACCELERATE(a) (or STEER(a, b) with two names, IDLE with none): the k-th
    proposal k, moved to k / 4 by the shield."""
    action = {1: "ACCELERATE", 2: "STEER", 0: "IDLE"}[len(params)]
    steps = [StepRecord(0, 0.0, None, {"Gap": 40.0, "Speed": 20.0}, 0.0, False)]
    for k in range(1, n + 1):
        extra = {}
        if params:
            extra = dict(parameters={p: k / 4 + i for i, p in enumerate(params)},
                         proposal={p: float(k) + i for i, p in enumerate(params)},
                         projection_distance=k * 0.75,
                         allowed_intervals={p: ((-4.0, 0.3), (1.0, None)) for p in params})
        steps.append(StepRecord(k, float(k), action, {"Gap": 40.0 - k, "Speed": 20.0 + k / 4},
                                0.5, False, **extra))
    steps = tuple(steps)
    return Episode(eid, steps, make_end(steps), seed=eid)


def write(path: Path, episodes, **header) -> Path:
    with EpisodeWriter(path, new_header("recorded", **{**HEADER, **header})) as w:
        for e in episodes:
            w.write(e)
    return path


def both_ways(path: Path, monkeypatch):
    """The columns of ``path`` from its run blob and from walking it episode by episode."""
    assert from_blobs(path)
    fast = read_columns(path)
    walking(monkeypatch)
    slow = read_columns(path)
    monkeypatch.undo()
    return fast, slow


def blobs(path: Path) -> dict[str, tuple[dict, dict]]:
    """Every columns attachment of a file by name: (header, arrays)."""
    data = path.read_bytes()
    return {r.name: decode_columns(r.data) for r in walk(path, data)
            if isinstance(r, Attachment)}


def test_messages_round_trip(tmp_path):
    eps = [acc_episode(0), acc_episode(1, ("a", "b")), acc_episode(2, ())]
    path = write(tmp_path / "run.mcap", eps)
    run = read_run(path)
    for got, want in zip(run.episodes, eps):
        assert got.steps == want.steps
    step = run.episodes[0].steps[2]
    assert step.parameters == {"a": 0.5} and step.proposal == {"a": 2.0}
    assert step.projection_distance == 1.5
    assert step.allowed_intervals == {"a": ((-4.0, 0.3), (1.0, None))}
    assert run.episodes[0].steps[0].parameters is None
    header = read_header(path)
    assert header.action_parameters == {"ACCELERATE": ["a"]}
    assert (header.action_low, header.action_high) == ([-4.0], [2.0])
    assert (header.shield_mode, header.projection_scale) == ("project", [2.0])


def test_columns_from_the_run_blob_and_the_walk(tmp_path, monkeypatch):
    path = write(tmp_path / "run.mcap", [acc_episode(0), acc_episode(1)])
    for cols in both_ways(path, monkeypatch):
        assert set(cols.parameters) == set(cols.proposals) == {"a"}
        nan = np.nan
        assert np.array_equal(cols.parameters["a"], [nan, .25, .5, .75] * 2, equal_nan=True)
        assert np.array_equal(cols.proposals["a"], [nan, 1., 2., 3.] * 2, equal_nan=True)
        assert np.array_equal(cols.distance, [nan, .75, 1.5, 2.25] * 2, equal_nan=True)
        assert cols.parameters["a"].dtype == np.float64


def test_a_mixed_file_fills_nan_where_an_episode_has_no_such_parameter(tmp_path, monkeypatch):
    """Episodes of one file with other parameters (or none): every column over every row."""
    eps = [acc_episode(0), acc_episode(1, ("a", "b"), n=2), acc_episode(2, ())]
    path = write(tmp_path / "run.mcap", eps)
    fast, slow = both_ways(path, monkeypatch)
    memory = episode_columns(eps, ACTIONS)
    nan = np.nan
    for cols in (fast, slow, memory):
        assert set(cols.parameters) == {"a", "b"}
        assert np.array_equal(cols.parameters["a"],
                              [nan, .25, .5, .75, nan, .25, .5, nan, nan, nan, nan],
                              equal_nan=True)
        assert np.array_equal(cols.parameters["b"],
                              [nan] * 5 + [1.25, 1.5] + [nan] * 4, equal_nan=True)
        assert np.array_equal(cols.proposals["b"], [nan] * 5 + [2., 3.] + [nan] * 4,
                              equal_nan=True)
        assert np.array_equal(cols.distance, [nan, .75, 1.5, 2.25, nan, .75, 1.5] + [nan] * 4,
                              equal_nan=True)
    # each episode's own attachment holds just its own parameters
    found = blobs(path)
    assert {k for k in found["episode-1.columns"][1] if ":" in k and k[:4] != "num:"} == \
        {"par:a", "par:b", "prop:a", "prop:b"}
    assert not any(k.startswith(("par:", "prop:", "dist"))
                   for k in found["episode-2.columns"][1])


def test_a_discrete_run_has_no_columns_of_parameters(tmp_path, monkeypatch):
    """The layout of a discrete file is what it was: no array of continuous actions."""
    eps = [episode(0), episode(1, 5, crash_at_end=True, live=True), episode(2, 1)]
    path = tmp_path / "run.mcap"
    with EpisodeWriter(path, new_header("recorded", actions=["IDLE", "FASTER"])) as w:
        for e in eps:  # the episodes of BEFORE, written now
            w.write(e)
    for name, (_, arrays) in blobs(path).items():
        assert not any(k.startswith(("par:", "prop:", "dist")) for k in arrays), name
    # every array where it was, of the same dtype and shape
    assert [h["arrays"] for h, _ in blobs(path).values()] == \
        [h["arrays"] for h, _ in blobs(BEFORE).values()]
    for cols in both_ways(path, monkeypatch):
        assert cols.parameters == {} and cols.proposals == {} and cols.distance is None


def test_a_file_written_before_continuous_actions_still_reads(tmp_path, monkeypatch):
    path = shutil.copy(BEFORE, tmp_path / "before.mcap")
    run = read_run(path)
    assert [e.id for e in run.episodes] == [0, 1, 2] and run.warnings == []
    assert run.episodes[1].steps == episode(1, 5, crash_at_end=True, live=True).steps
    assert all(s.parameters is None for e in run.episodes for s in e.steps)
    assert run.header.action_parameters is None and run.header.shield_mode is None
    for cols in both_ways(Path(path), monkeypatch):
        assert cols.n == 4 + 6 + 2
        assert cols.parameters == {} and cols.proposals == {} and cols.distance is None


def change_last(args):
    args["parameters"] = list(args["parameters"])
    args["parameters"][-1] = {"a": 9.0}


def change_middle(args):
    args["parameters"] = list(args["parameters"])
    args["parameters"][1] = {"a": 9.0}


def drop_distance(args):
    args["distances"] = [None] * len(args["distances"])


def write_changed(path: Path, change) -> Path:
    """Write three ACCELERATE episodes, the columns of episode 1 changed by ``change``."""
    real = W.encode_columns

    def encode(ep, *args, **kwargs):
        if ep == 1:
            change(kwargs)
        return real(ep, *args, **kwargs)

    W.encode_columns = encode
    try:
        return write(path, [acc_episode(0), acc_episode(1), acc_episode(2)])
    finally:
        W.encode_columns = real


@pytest.mark.parametrize("change,first", [(change_last, 3), (drop_distance, 1)],
                         ids=["parameter", "distance"])
def test_columns_that_say_other_parameters_than_the_last_step(tmp_path, change, first):
    """Reading the columns compares the last step's message (step 3); decoding the steps
    finds the first that differs."""
    path = write_changed(tmp_path / "run.mcap", change)
    for read, step in ((read_columns, 3), (read_run, first)):
        with pytest.raises(InputError) as info:
            read(path)
        assert info.value.message == (
            f"{path}, episode 1: step {step}: the step message and the columns disagree on "
            "its action's parameters, proposal or projection distance")
    assert list(read_columns(path, salvage=True).episode_ids) == [0, 2]


def test_decoded_steps_are_each_compared(tmp_path):
    """Only the last step is compared without decoding; decoding compares every one."""
    path = write_changed(tmp_path / "run.mcap", change_middle)
    with pytest.raises(InputError, match=r"episode 1: step 1: the step message and the columns "
                                         r"disagree on its action's parameters"):
        read_run(path)


@pytest.mark.parametrize("change,message", [
    (lambda a: a.update({"par:a": np.array([np.nan, np.inf, 1.0])}),
     "the array par:a holds an infinity"),
    (lambda a: a.update({"prop:a": np.array([np.nan, -np.inf, 1.0])}),
     "the array prop:a holds an infinity"),
    (lambda a: a.update(dist=np.array([np.nan, -1.0, 1.0])),
     "the array dist holds a negative distance"),
    (lambda a: a.update({"par:a": np.zeros(2)}), "the array par:a has shape (2,), not (3,)"),
    (lambda a: a.update({"par:a": np.zeros(3, dtype=np.int64)}),
     "the array par:a has dtype <i8, not <f8"),
    (lambda a: a.update({"par:1a": np.zeros(3)}), "the array par:1a is not one tracecheck "
                                                  "writes"),
    (lambda a: a.update({"dist:a": np.zeros(3)}), "the array dist:a is not one tracecheck "
                                                  "writes"),
], ids=["inf", "-inf", "negative", "shape", "dtype", "name", "dist-name"])
def test_columns_of_parameters_that_are_refused(change, message):
    from tracecheck.episodes.column_checks import check_columns

    arrays = {"time": np.zeros(3), "action": np.array([-1, 0, 0], dtype=np.int16),
              "reward": np.zeros(3), "crashed": np.zeros(3, dtype=bool)}
    header = {"episode": 0, "actions": ["ACCELERATE"], "elements": [], "kinds": {}}
    check_columns(header, {**arrays, "par:a": np.array([np.nan, 1.0, 2.0]),
                           "dist": np.array([np.nan, 0.0, 2.0])})  # NaN: none in that row
    change(arrays)
    with pytest.raises(InputError, match="^damaged columns attachment: " + re.escape(message)):
        check_columns(header, arrays)


@pytest.mark.parametrize("change,message", [
    (dict(parameters={"a": float("nan")}), "parameters.a: Input should be a finite number"),
    (dict(proposal={"a": float("inf")}), "proposal.a: Input should be a finite number"),
    (dict(projection_distance=-1.0),
     "projection_distance: Input should be greater than or equal to 0"),
    (dict(parameters={"a b": 1.0}), "parameters.a b.[key]: String should match pattern"),
    (dict(allowed_intervals={"a": ((1.0, 0.0),)}),
     "Value error, an allowed interval of a has its low end above its high end"),
], ids=["nan", "inf", "negative", "name", "interval"])
def test_a_step_that_cannot_be_written_names_the_step(tmp_path, change, message):
    ep = acc_episode(0)
    bad = dataclasses.replace(ep, steps=(ep.steps[0], dataclasses.replace(ep.steps[1], **change),
                                         *ep.steps[2:]))
    with pytest.raises(InputError) as info:
        write(tmp_path / "run.mcap", [bad])
    assert info.value.message.startswith(f"{tmp_path / 'run.mcap'}, episode 0, step 1: "
                                         f"{message}")


@pytest.mark.parametrize("fields,message", [
    (dict(action_low=[-1.0, 0.0]), "different lengths"),
    (dict(action_low=[3.0]), "an action_low bound lies above its action_high bound"),
    (dict(projection_scale=[0.0]), "a projection_scale is not positive"),
    (dict(shield_mode="clip"), "Input should be 'project', 'replace' or 'mask'"),
    (dict(action_high=[float("inf")]), "Input should be a finite number"),
])
def test_run_headers_that_do_not_describe_an_action_space(fields, message):
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match=re.escape(message)):
        new_header("recorded", **{**HEADER, **fields})


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(0, 7)),
                      min_size=1, max_size=4))
def test_a_damaged_continuous_file_never_reads_as_other_parameters(tmp_path_factory, flips):
    """Flipped bits: an error naming the file, or the intact file's parameters for the
    episodes read — never other values."""
    folder = tmp_path_factory.mktemp("flips")
    intact = write(folder / "intact.mcap", [acc_episode(0), acc_episode(1, ("a", "b"))])
    want = read_columns(intact)
    data = bytearray(intact.read_bytes())
    for where, bit in flips:
        data[int(where * len(data))] ^= 1 << bit
    path = folder / "damaged.mcap"
    path.write_bytes(bytes(data))
    for read in (read_columns, read_run):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                got = read(path)
        except InputError:
            continue
        if read is read_run:
            for e in got.episodes:
                assert e.steps == acc_episode(e.id, ("a",) if e.id == 0 else ("a", "b")).steps
            continue
        rows = np.isin(want.episode, got.episode_ids)
        for name, arr in got.parameters.items():
            assert np.array_equal(arr, want.parameters[name][rows], equal_nan=True)
        if got.distance is None:  # no row read has one (none read at all: a cut first chunk)
            assert np.all(np.isnan(want.distance[rows]))
        else:
            assert np.array_equal(got.distance, want.distance[rows], equal_nan=True)
