"""Run files whose parts disagree: the columns against the step messages and end records,
missing attachments, repeated ids, chunked files and decompression bombs. Each is an error
naming the file and episode, or with salvaging an episode left out with a warning — and
every reader (columns, step messages) sees the same episodes."""

from __future__ import annotations

import dataclasses
import re
import struct
import warnings

import lz4.frame
import pytest

from tests.helpers import episode, run
from tracecheck.episodes import (EpisodeWriter, new_header, read_columns, read_episodes,
                                 read_run)
from tracecheck.episodes import writer as W
from tracecheck.errors import SalvagedEpisodeWarning
from tracecheck.episodes.records import MAX_CHUNK_RATIO, MessageRef, walk
from tracecheck.errors import InputError

ACTIONS = ["IDLE", "FASTER", "SLOWER"]


def episodes():
    return [episode(0), episode(1, 4, crash_at_end=True), episode(2, 2)]


def write(path, eps, columns=None, compress=True):
    """Write ``eps``; ``columns(kwargs)`` may change what episode 1's columns say;
    ``compress=False``: no chunks (the layout of earlier files)."""
    real = W.encode_columns

    def encode(ep, times, actions, rewards, crashed, cols, names, values=None, seed=None,
               checksums=None, **continuous):
        args = dict(times=list(times), actions=list(actions), rewards=list(rewards),
                    crashed=list(crashed), seed=seed, **continuous)
        if ep == 1 and columns is not None:
            columns(args)
        return real(ep, args["times"], args["actions"], args["rewards"], args["crashed"], cols,
                    names, values, seed=args["seed"], checksums=checksums,
                    **{k: args[k] for k in continuous})

    W.encode_columns = encode
    try:
        with EpisodeWriter(path, new_header("recorded", actions=ACTIONS),
                           compress=compress) as w:
            for e in eps:
                w.write(e)
    finally:
        W.encode_columns = real
    return path


def flip_last_crash(a):
    a["crashed"][-1] = not a["crashed"][-1]


def last_action(a):
    a["actions"][-1] = "SLOWER"


def other_seed(a):
    a["seed"] = 99


def other_reason(a):
    a["reason"] = "deadlock"


CASES = [
    (flip_last_crash, "the columns, end record and last step disagree on whether it crashed "
                      "(False, True, True)"),
    (last_action, "the last step's action is 'IDLE' in its message and 'SLOWER' in the columns"),
    (other_seed, "the columns say seed 99, the episode header 1001"),
    (other_reason, "the columns say it ended by 'deadlock', the end record by 'crashed'"),
]


@pytest.mark.parametrize("change,message", CASES, ids=["crash", "action", "seed", "reason"])
def test_columns_that_contradict_the_messages(tmp_path, change, message):
    path = write(tmp_path / "run.mcap", episodes(), change)
    for read in (read_columns, lambda p: list(read_episodes(p))):
        with pytest.raises(InputError) as info:
            read(path)
        assert info.value.message == f"{path}, episode 1: {message}"
        assert "--salvage" in info.value.hint
    cols = read_columns(path, salvage=True)
    assert list(cols.episode_ids) == [0, 2]
    assert cols.warnings == [f"{path}, episode 1: {message}; the episode is left out"]
    with pytest.warns(SalvagedEpisodeWarning, match="episode 1: .*; the episode is left out"):
        assert [e.id for e in read_episodes(path, salvage=True)] == [0, 2]


def test_a_step_the_columns_tell_differently(tmp_path):
    """Decoding the steps (render, export) compares every step, not only the last."""
    def middle(a):
        a["actions"][2] = "FASTER"
    path = write(tmp_path / "run.mcap", episodes(), middle)
    with pytest.raises(InputError, match=r"run.mcap, episode 1: step 2: the step message and "
                                         r"the columns disagree"):
        read_run(path)


def test_an_end_record_with_another_length(tmp_path):
    eps = episodes()
    eps[1] = dataclasses.replace(eps[1], end=dataclasses.replace(eps[1].end, steps=3))
    path = write(tmp_path / "run.mcap", eps)
    with pytest.raises(InputError, match=r"episode 1: the step messages \(5\), end record "
                                         r"\(3 steps after the initial state\) and columns "
                                         r"\(5 rows\) disagree on its length"):
        read_columns(path)


def test_a_missing_attachment_is_not_a_silently_missing_episode(tmp_path, monkeypatch):
    real = W.EpisodeWriter._write

    def without_columns(self, ep, *rest):
        if ep.id == 1:
            add = self._writer.add_attachment
            self._writer.add_attachment = lambda **kw: None
            try:
                return real(self, ep, *rest)
            finally:
                self._writer.add_attachment = add
        return real(self, ep, *rest)

    monkeypatch.setattr(W.EpisodeWriter, "_write", without_columns)
    path = write(tmp_path / "run.mcap", episodes())
    with pytest.raises(InputError, match=r"run.mcap, episode 1: the episode ends without its "
                                         r"columns attachment"):
        read_columns(path)
    with pytest.raises(InputError, match="episode 1: the episode ends without its columns"):
        read_run(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SalvagedEpisodeWarning)
        assert list(read_columns(path, salvage=True).episode_ids) == [0, 2]
        assert [e.id for e in read_run(path, salvage=True).episodes] == [0, 2]


def test_every_command_agrees_with_and_without_salvage(capsys, tmp_path):
    """Without --salvage every reading command stops with exit 2 naming the episode; with it
    they all leave out the same episode."""
    path = write(tmp_path / "run.mcap", episodes(), flip_last_crash)
    commands = [["info", str(path)], ["replay", str(path), "--shield", "none"],
                ["stats", str(path)], ["diff", str(path), "--shield", "none", "--against",
                                       "none"],
                ["render", str(path), "--episode", "1", "-o", str(tmp_path / "v.html")],
                ["export", "simb", str(path), "-o", str(tmp_path / "simb")]]
    for args in commands:
        code, _, err = run(capsys, *args)
        assert code == 2, args
        assert f"{path}, episode 1: the columns, end record and last step disagree" in err
        assert "Traceback" not in err
    code, _, err = run(capsys, "render", str(path), "--episode", "1", "--salvage", "-o",
                       str(tmp_path / "v.html"))
    assert code == 2 and f"{path} has no episode 1; it has 0, 2" in err
    assert f"hint: {path}, episode 1: the columns, end record and last step disagree" in err
    commands[4][3] = "2"
    for args in commands:
        code, out, err = run(capsys, *args, "--salvage")
        assert code == 0, (args, err)
        if args[0] != "render":  # rendering episode 2 reads only episode 2
            assert "episode 1: the columns" in err and "left out" in err
    code, out, _ = run(capsys, "info", str(path), "--salvage", "--json")
    assert '"episodes": 2' in out
    assert len(list((tmp_path / "simb").glob("*.json"))) == 2


# ------------------------------------------------------------------ chunks


def _chunk_record(inner: bytes, declared: int, compression: str = "lz4",
                  data: bytes | None = None) -> bytes:
    data = lz4.frame.compress(inner) if data is None else data
    name = compression.encode()
    body = (struct.pack("<QQQI", 0, 0, declared, 0) + struct.pack("<I", len(name)) + name
            + struct.pack("<Q", len(data)) + data)
    return struct.pack("<BQ", 6, len(body)) + body


def _rechunk(path, out, make_chunk):
    """``path`` with its episode records (everything after the run header) in one chunk, as
    another MCAP tool may write it: without the old summary, whose offsets no longer hold (a
    footer that names no summary)."""
    data = path.read_bytes()
    msgs = [r for r in walk(path, data) if type(r) is MessageRef]
    begin = msgs[1].start - 9  # the first episode header's record
    end = _data_end(path, data)  # the data end record
    footer = struct.pack("<BQQQI", 2, 20, 0, 0, 0) + data[-8:]
    out.write_bytes(data[:begin] + make_chunk(data[begin:end]) + data[end:end + 13] + footer)
    assert end > begin
    return out


def _data_end(path, data: bytes) -> int:
    at = 8
    while True:
        op, length = struct.unpack_from("<BQ", data, at)
        if op == 15:
            return at
        at += 9 + length


def test_a_chunked_file_reads_the_same(tmp_path):
    path = write(tmp_path / "run.mcap", episodes(), compress=False)
    chunked = _rechunk(path, tmp_path / "chunked.mcap",
                       lambda inner: _chunk_record(inner, len(inner)))
    assert chunked.read_bytes() != path.read_bytes()
    a, b = read_columns(path), read_columns(chunked)
    assert list(a.episode_ids) == list(b.episode_ids) == [0, 1, 2] and a.n == b.n
    assert [e.steps for e in read_episodes(chunked)] == [e.steps for e in read_episodes(path)]


def test_a_decompression_bomb_is_refused(tmp_path):
    """A chunk whose contents are refused (its record whole): an error that says why, and
    with salvaging the episodes in it left out with that warning."""
    path = write(tmp_path / "run.mcap", episodes(), compress=False)
    bomb = _rechunk(path, tmp_path / "bomb.mcap",
                    lambda inner: _chunk_record(b"\0" * 1000, 10 ** 12))
    assert MAX_CHUNK_RATIO == 1000
    with pytest.raises(InputError, match=r"a chunk would decompress to 1000000000000 bytes "
                                         r"from \d+ \(more than tracecheck's limit"):
        read_columns(bomb)
    cols = read_columns(bomb, salvage=True)
    assert cols.n == 0 and "a chunk would decompress" in cols.warnings[0]
    liar = _rechunk(path, tmp_path / "liar.mcap", lambda inner: _chunk_record(
        b"", 1000, data=lz4.frame.compress(b"\0" * (50 << 20), store_size=False)))
    with pytest.raises(InputError, match="a chunk decompresses to 1001 bytes, not the 1000"):
        read_columns(liar)
    sized = _rechunk(path, tmp_path / "sized.mcap",
                     lambda inner: _chunk_record(b"\0" * (50 << 20), 1000))
    with pytest.raises(InputError, match="a chunk declares 1000 bytes but its lz4 frame "
                                         "52428800: refused before decompressing"):
        read_columns(sized)
    odd = _rechunk(path, tmp_path / "odd.mcap",
                   lambda inner: _chunk_record(inner, len(inner), "brotli", data=inner))
    with pytest.raises(InputError, match="a chunk uses the unknown compression 'brotli'"):
        read_columns(odd)


@pytest.mark.parametrize("good,bad,message", [
    (b'"EgoVehicle":126.0', b'"EgoVehicle":127.0', "episode 1: its messages do not match the "
                                                   "checksum its columns carry"),
    (b'"source":"recorded"', b'"source":"recorde\\u0064"', None),
])
def test_a_changed_byte_in_a_message_is_found(tmp_path, good, bad, message):
    """A digit changed in a state, or the run header edited (here to the same value written
    differently): still valid JSON, but not what was written (in a file without chunks: in
    a compressed chunk its own checksum finds any change, see the test below)."""
    path = write(tmp_path / "run.mcap", episodes(), compress=False)
    data = path.read_bytes()
    assert data.count(good) >= 1
    if len(bad) != len(good):  # the header: keep the record length by shortening elsewhere
        head_at = data.find(good)
        rec = data.rfind(b"\x05", 0, head_at)  # the message record of the run header
        while struct.unpack_from("<Q", data, rec + 1)[0] > 4096:
            rec = data.rfind(b"\x05", 0, rec)
        length = struct.unpack_from("<Q", data, rec + 1)[0]
        data = (data[:rec + 1] + struct.pack("<Q", length + len(bad) - len(good))
                + data[rec + 9:head_at] + bad + data[head_at + len(good):])
        message = "episode 0: the run header does not match the checksum the episode's columns"
    else:
        data = data.replace(good, bad, 1)
    path.write_bytes(data)
    for read in (read_columns, read_run):
        with pytest.raises(InputError, match=re.escape(message)):
            read(path)


@pytest.mark.parametrize("field,value", [(16, 0xFFFFFFF0), (1, 2 ** 62)],
                         ids=["name length", "record length"])
def test_a_damaged_attachment_record_ends_the_file_there(tmp_path, field, value):
    """Lengths inside a record that point past its end: the episodes before it are read,
    with a warning; no struct.error."""
    path = write(tmp_path / "run.mcap", episodes())
    data = bytearray(path.read_bytes())
    at, seen = 8, 0
    while True:  # the second attachment record (episode 1's columns)
        op, length = struct.unpack_from("<BQ", data, at)
        if op == 9:
            seen += 1
            if seen == 2:
                break
        at += 9 + length
    if field == 1:
        struct.pack_into("<Q", data, at + 1, value)
    else:
        struct.pack_into("<I", data, at + 9 + field, value)
    path.write_bytes(bytes(data))
    cols = read_columns(path)
    assert list(cols.episode_ids) == [0]
    assert "the file is damaged or ends early" in cols.warnings[0]
    assert "read 1 complete episode(s)" in cols.warnings[0]
