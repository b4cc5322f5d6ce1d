"""Writing and reading runs: round trips, the columnar view, damaged and foreign files."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from mcap.reader import make_reader

from tests.helpers import ROOT, from_blobs, walking
from tracecheck.episodes.records import Attachment, walk
from tracecheck.episodes import EpisodeWriter, new_header, read_columns, read_episodes, read_run
from tracecheck.episodes.files import write_run
from tracecheck.errors import DamagedEpisode, InputError


def write(path, episodes, compress=True, **header):
    """``compress=False``: no chunks (the layout of earlier files), for tests that edit
    the bytes of messages."""
    with EpisodeWriter(path, new_header("recorded", actions=["IDLE", "FASTER"], **header),
                       compress=compress) as w:
        for e in episodes:
            w.write(e)
    return path


def test_round_trip(tmp_path, episodes):
    path = write(tmp_path / "run.mcap", episodes, agent_id="base", base_seed=1000)
    run = read_run(path)
    assert run.warnings == []
    assert run.header.agent_id == "base" and run.header.base_seed == 1000
    assert [e.id for e in run.episodes] == [0, 1, 2]
    for got, want in zip(run.episodes, episodes):
        assert got.steps == want.steps
        assert got.end == want.end and got.seed == want.seed
    live = run.episodes[1].steps[2]
    assert live.allowed_actions == ("IDLE", "SLOWER") and live.shield_time_us == 12.5
    assert run.episodes[1].end.crashed and run.episodes[1].end.reason == "crashed"


def test_any_mcap_tool_reads_it(tmp_path, episodes):
    path = write(tmp_path / "run.mcap", episodes)
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {c.topic for c in summary.channels.values()}
        assert topics == {"/tracecheck/run", "/tracecheck/episode", "/tracecheck/step",
                          "/tracecheck/episode_end"}
        assert all(s.encoding == "jsonschema" for s in summary.schemas.values())
        times = [m.log_time for _, _, m in reader.iter_messages(log_time_order=False)]
    assert times == sorted(times), "timestamps must be monotonic for playback"
    assert summary.statistics.message_count == 1 + 3 * 2 + (4 + 6 + 2)


def test_columnar_view(tmp_path, episodes):
    cols = read_columns(write(tmp_path / "run.mcap", episodes))
    assert list(cols.starts) == [0, 4, 10, 12] and cols.n == 12
    assert list(cols.episode_ids) == [0, 1, 2]
    assert list(cols.step[:5]) == [0, 1, 2, 3, 0]
    assert cols.action_names[cols.action[1]] == "IDLE" and cols.action[0] == -1
    x, defined = cols.states.functions["VehiclesX"]
    assert x.shape == (12, 3) and defined.all()
    assert x[5, 0] == 125.0 + 1  # episode 1, step 1, ego vehicle
    assert cols.crashed[9] and not cols.crashed[8]
    assert cols.states.masks["PresentVehicles"].all()
    assert cols.states.row(5) == episodes[1].steps[1].state


def test_write_run_leaves_no_partial_file(tmp_path, episodes):
    target = tmp_path / "run.mcap"
    target.write_bytes(b"old")

    def failing():
        yield episodes[0]
        raise InputError("bad input file")

    with pytest.raises(InputError, match="bad input file"):
        write_run(target, new_header("imported-simb"), failing(), force=True)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]  # no temporary file


def test_truncated_file_keeps_complete_episodes(tmp_path, episodes):
    path = write(tmp_path / "run.mcap", episodes, compress=False)
    data = path.read_bytes()
    # cut inside the third episode's step messages
    cut = tmp_path / "cut.mcap"
    marker = data.find(b'"episode":2,"step":1')
    cut.write_bytes(data[:marker + 5])
    with pytest.warns(DamagedEpisode, match=r"read 2 complete episode\(s\); lost the "
                                                r"unfinished episode 2 \(1 step message"):
        got = list(read_episodes(cut))
    assert [e.id for e in got] == [0, 1]
    cols = read_columns(cut)
    assert list(cols.episode_ids) == [0, 1] and "read 2 complete episode(s)" in cols.warnings[0]
    run = read_run(cut)
    assert len(run.episodes) == 2 and run.warnings


@pytest.mark.parametrize("content,fragment", [
    (b"", "is not an MCAP file"),
    (b"hello world, not mcap at all", "is not an MCAP file"),
])
def test_not_mcap(tmp_path, content, fragment):
    path = tmp_path / "bad.mcap"
    path.write_bytes(content)
    with pytest.raises(InputError, match=fragment):
        list(read_episodes(path))


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_run(tmp_path / "none.mcap")


def test_foreign_mcap(tmp_path):
    from mcap.writer import Writer

    path = tmp_path / "other.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        w.finish()
    with pytest.raises(InputError, match="not a tracecheck run"):
        read_run(path)


@pytest.mark.parametrize("good,bad,message", [
    (b'"reward":0.5', b'"reward":NaN', "bad tracecheck.Step message: reward: Input should be a "
                                       "finite number"),
    (b'"Vehicles2":-1.0', b'"Vehicles2":NaN', "nan is not a B real (variable VehiclesVx)"),
])
def test_nan_or_infinity_in_a_step_message(tmp_path, episodes, good, bad, message):
    """JSON parsers that accept NaN and Infinity do not make them B values."""
    path = write(tmp_path / "run.mcap", episodes[:1], compress=False)
    data = path.read_bytes()
    assert good in data and len(bad) <= len(good)
    path.write_bytes(data.replace(good, bad.ljust(len(good)), 1))  # the same record length
    with pytest.raises(InputError, match=re.escape(message)):
        read_run(path)


def test_message_that_breaks_the_schema(tmp_path, episodes):
    path = write(tmp_path / "run.mcap", episodes[:1], compress=False)
    data = path.read_bytes().replace(b'"crashed":false', b'"crashed":"nah"', 1)
    path.write_bytes(data)
    with pytest.raises(InputError, match=r"episode 0: bad tracecheck.Step message: crashed"):
        read_run(path)


WRITER = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, {root!r})
    sys.path.insert(0, {tests!r})
    from conftest import episode
    from tracecheck.episodes import EpisodeWriter, new_header
    with EpisodeWriter(sys.argv[1], new_header("recorded")) as w:
        for i in range(1000):
            w.write(episode(i, 4))
            print(i, flush=True)
            time.sleep(0.05)
""")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["kill", "ctrl-c"])
def test_killed_writer_keeps_every_finished_episode(tmp_path, sig):
    path = tmp_path / "run.mcap"
    script = WRITER.format(root=str(ROOT), tests=str(ROOT / "tests" / "episodes"))
    proc = subprocess.Popen([sys.executable, "-c", script, str(path)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    finished = []
    for line in proc.stdout:
        finished.append(int(line))
        if len(finished) == 5:
            os.kill(proc.pid, sig)
            break
    proc.wait(timeout=30)
    run = read_run(path)
    ids = [e.id for e in run.episodes]
    assert ids[:5] == [0, 1, 2, 3, 4], "every episode the writer finished is in the file"
    assert ids == list(range(len(ids)))
    assert all(len(e.steps) == 5 for e in run.episodes)
    cols = read_columns(path)
    assert list(cols.episode_ids) == ids


def test_reading_only_some_episodes(tmp_path, episodes):
    path = write(tmp_path / "run.mcap", episodes)
    run = read_run(path, only={1})
    assert [e.id for e in run.episodes] == [1]
    assert run.episodes[0].steps == episodes[1].steps
    assert run.warnings == []


def test_columns_keep_every_kind_of_value(tmp_path):
    """A grid world's state: a map keyed by pairs (the same in every step), integers, a
    string, a set of pairs. The columnar view gives back exactly the step messages' values,
    and the map is written once per episode."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.episodes.model import Episode, StepRecord, make_end
    from tracecheck.episodes.reader import read_pieces

    field = FuncValue({(x, y): Elem("HOLE" if (x, y) == (1, 1) else "ICE")
                       for x in range(3) for y in range(3)})
    steps = tuple(
        StepRecord(step=k, time=float(k), action=None if k == 0 else "Move_Right",
                   state={"x": k, "y": 0, "field": field, "note": f"step {k}",
                          "seen": frozenset((i, 0) for i in range(k + 1))},
                   reward=0.0, crashed=False)
        for k in range(3))
    path = tmp_path / "grid.mcap"
    with EpisodeWriter(path, new_header("recorded", actions=["Move_Right"])) as w:
        w.write(Episode(id=0, steps=steps, end=make_end(steps), seed=7))
    cols = read_columns(path)
    for k in range(3):
        assert cols.states.row(k) == steps[k].state
    (piece,) = read_pieces(path, decode=False)
    header, _ = piece.columns
    assert len(header["literals"]["field"]) == 1 and len(header["literals"]["note"]) == 3


def test_a_flipped_bit_in_a_columns_attachment_is_found(tmp_path, episodes):
    """The columns carry a checksum: one flipped bit is an error naming the file, not a
    silently different answer (old files without one are still read)."""
    path = write(tmp_path / "run.mcap", episodes)
    blob = next(r.data for r in walk(path, path.read_bytes()) if isinstance(r, Attachment))
    data = bytearray(path.read_bytes())
    at = data.find(blob[len(blob) // 2:len(blob) // 2 + 32])
    assert at > 0
    data[at + 3] ^= 0x04
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"broken.mcap, episode 0: damaged columns "
                                         r"attachment: its checksum does not match"):
        read_columns(broken)
    assert read_columns(ROOT / "sample_traces" / "base_none.mcap").n > 0  # TCC1, no checksum


def test_repeated_episode_ids_are_an_error(tmp_path, episodes):
    """Re-simulation looks episodes up by id: a file with an id twice would re-run the wrong
    seed, so it is refused."""
    import dataclasses

    twice = [episodes[0], dataclasses.replace(episodes[1], id=episodes[0].id)]
    path = write(tmp_path / "twice.mcap", twice)
    with pytest.raises(InputError, match=r"twice.mcap, episode 0: the episode id 0 "
                                         r"is used twice"):
        read_columns(path)


@pytest.mark.parametrize("change,message", [
    (lambda a: a.update(action=np.array([-1, 7, 0], dtype=np.int16)),
     "an action index lies outside the 2 actions"),
    (lambda a: a.update(reward=np.zeros(2)), "the array reward has shape (2,), not (3,)"),
    (lambda a: a.update({"num:x": np.zeros(4)}), "the array num:x has shape (4,), not (3,)"),
    (lambda a: a.update({"num:x": np.zeros(3, dtype=np.float32)}),
     "the array num:x has dtype <f4, not ('<f8', '<i8')"),
    (lambda a: a.update({"fun:x": np.zeros((3, 2))}), "the array fun:x has shape (3, 2), not "
                                                      "(3, 1)"),
    (lambda a: a.update({"cmd:x": np.zeros(3)}), "the array cmd:x is not one tracecheck writes"),
    (lambda a: a.pop("crashed"), "'crashed' is missing"),
    (lambda a: a.update({"num:x": np.array([0.0, np.nan, 1.0])}),
     "the array num:x holds NaN or an infinity (B reals are finite)"),
    (lambda a: a.update(reward=np.array([0.0, np.inf, 1.0])), "the array reward holds NaN"),
    (lambda a: a.update({"lit:x": np.array([0, 1, 2], dtype=np.uint32)}),
     "variable x refers to literal 2 of 2"),
])
def test_columns_that_do_not_fit_together_are_an_error(change, message):
    from tracecheck.episodes.column_checks import check_columns

    arrays = {"time": np.zeros(3), "action": np.array([-1, 0, 1], dtype=np.int16),
              "reward": np.zeros(3), "crashed": np.zeros(3, dtype=bool)}
    change(arrays)
    header = {"episode": 0, "actions": ["IDLE", "FASTER"], "elements": ["E"],
              "kinds": {"x": "lit"} if "lit:x" in arrays else {}, "literals": {"x": ["1", "2"]}}
    with pytest.raises(InputError, match="^damaged columns attachment: " + re.escape(message)):
        check_columns(header, arrays)


@pytest.mark.parametrize("change,message", [
    (dict(reward=float("nan")), "episode 0, step 1: reward: Input should be a finite number"),
    (dict(state_x=float("inf")), "episode 0, step 1: variable VehiclesX: the value inf cannot "
                                 "be stored: B has no NaN or infinity"),
])
def test_writing_nan_or_infinity_names_the_step(tmp_path, episodes, change, message):
    """A live environment that yields NaN or infinity: the writer says where."""
    import dataclasses

    from tracecheck.b.values import Elem, FuncValue

    ep = episodes[0]
    step = ep.steps[1]
    if "state_x" in change:
        x = dict(step.state["VehiclesX"].map)
        x[Elem("EgoVehicle")] = change["state_x"]
        step = dataclasses.replace(step, state={**step.state, "VehiclesX": FuncValue(x)})
    else:
        step = dataclasses.replace(step, **change)
    bad = dataclasses.replace(ep, steps=(ep.steps[0], step, *ep.steps[2:]))
    with pytest.raises(InputError) as info:
        write(tmp_path / "run.mcap", [bad])
    assert info.value.message == f"{tmp_path / 'run.mcap'}, {message}"


def test_a_finished_file_is_read_from_its_run_blob_with_the_walk_s_answer(tmp_path, episodes,
                                                                          monkeypatch):
    """A closed file carries every episode in one blob: read in a few array operations, and
    exactly what reading it episode by episode gives (which is what happens when any byte
    the blob stands for has changed)."""

    path = write(tmp_path / "run.mcap", episodes, compress=False)  # a bit of a message is flipped
    assert from_blobs(path)
    fast = read_columns(path)
    walking(monkeypatch)
    slow = read_columns(path)
    for key in ("episode_ids", "starts", "episode", "step", "time", "action", "reward",
                "crashed", "values"):
        assert np.array_equal(getattr(fast, key), getattr(slow, key), equal_nan=True), key
    assert fast.action_names == slow.action_names and fast.seeds == slow.seeds
    assert fast.reasons == slow.reasons == [ep.end.reason for ep in episodes]
    assert [fast.states.row(i) for i in range(fast.n)] == \
           [slow.states.row(i) for i in range(slow.n)]
    assert fast.states.label(5) == slow.states.label(5)
    monkeypatch.undo()
    data = bytearray(path.read_bytes())
    data[data.find(b'"episode":1,"step":2') + 30] ^= 1  # one bit in episode 1's messages
    path.write_bytes(bytes(data))
    assert not from_blobs(path)
    with pytest.raises(InputError, match="episode 1: "):
        read_columns(path)


def test_a_grid_worlds_map_is_read_once_and_foxgloves_messages_passed_over(tmp_path):
    """Issue 46: reading a grid world's episodes reads the map's literal once (the same text
    at every step is the same value: reading it again was nearly all the time, 24 s for 800
    FrozenLake episodes), and the walk gives the reader tracecheck's own messages only —
    the episodes are those a full walk gives."""
    from unittest import mock

    from tracecheck.b import notation
    from tracecheck.episodes.codec import decode_state
    from tracecheck.episodes.records import MessageRef, mapped
    from tracecheck.interop.foxglove import FoxgloveChannels
    from tracecheck.live.record import RecordSettings, record

    out = tmp_path / "lake.mcap"
    record(RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                          shield="frozenlake", env="frozenlake",
                          env_config={"is_slippery": True}, episodes=6, seed=2), out,
           channels=FoxgloveChannels)
    parsed = []
    real = notation.parse_literal

    def counted(text, **kw):
        parsed.append(text)
        return real(text, **kw)
    with mock.patch.object(notation, "parse_literal", counted):
        run_ = read_run(out)
    maps = [t for t in parsed if len(t) > 64]
    steps = sum(len(e.steps) for e in run_.episodes)
    assert steps > 30 and len(maps) <= 1
    field_ = run_.episodes[0].steps[0].state["field"]
    assert all(s.state["field"] is field_ for e in run_.episodes for s in e.steps)
    assert field_ == real(notation.format_value(field_))
    from tracecheck.episodes import reader as reader_module

    full = reader_module.walk
    with mock.patch.object(reader_module, "walk",
                           lambda path, buf, regions=None, wanted=None: full(path, buf, regions)):
        assert read_run(out).episodes == run_.episodes  # every message walked: the same
    with pytest.raises(Exception, match="variable field"):  # unreadable: said, not kept
        decode_state({"field": "{" + "(0 |-> 0) |-> ICE, " * 10 + "oops"})
    with pytest.raises(Exception, match="variable field"):
        decode_state({"field": "{" + "(0 |-> 0) |-> ICE, " * 10 + "oops"})
    with mapped(out) as buf:
        every = [r for r in walk(out, buf) if type(r) is MessageRef]
        assert not [r for r in walk(out, buf, wanted=set()) if type(r) is MessageRef]
    assert len(every) > 3 * steps  # Foxglove's messages are most of them


def test_a_message_is_bytes_not_a_number():
    """A message buffer keeps each message until its chunk is made: a number given as the
    data is refused, not written as that many zero bytes."""
    from tracecheck.episodes.mcap_out import MessageBuffer

    with pytest.raises(TypeError):
        MessageBuffer().add(1, 0, 5, 0)
