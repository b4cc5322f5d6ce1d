"""Compressed run files: the messages of each episode in one zstd chunk (MCAP's own chunk
compression), closed before the episode's columns attachment, which is compressed too. A
damaged chunk is an error naming the file and episode (salvaging: the episode is left out);
a cut file keeps every finished episode; any MCAP reader reads the file."""

from __future__ import annotations

import re
import struct

import pytest
from mcap.reader import make_reader

from tests.helpers import episode
from tracecheck.episodes import (EpisodeWriter, new_header, read_columns, read_episodes,
                                 read_run)
from tracecheck.episodes.codec import decode_columns
from tracecheck.errors import DamagedEpisode, InputError, SalvagedEpisodeWarning

ACTIONS = ["IDLE", "FASTER", "SLOWER"]
CHUNK, ATTACHMENT = 6, 9


def write(path, compress=True):
    with EpisodeWriter(path, new_header("recorded", actions=ACTIONS), compress=compress) as w:
        for e in [episode(0), episode(1, 4, crash_at_end=True), episode(2, 2)]:
            w.write(e)
    return path


def top_records(data: bytes) -> list[tuple[int, int, int]]:
    """(opcode, start of the record, end) of the file's top-level records up to the footer."""
    at, out = 8, []
    while at < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, at)
        out.append((op, at, at + 9 + length))
        if op == 2:
            break
        at += 9 + length
    return out


def test_each_episode_is_one_zstd_chunk_before_its_compressed_columns(tmp_path):
    path = write(tmp_path / "run.mcap")
    data = path.read_bytes()
    ops = [op for op, _, _ in top_records(data)]
    data_section = ops[:ops.index(15)]  # up to the data end record
    # the run header's chunk, then per episode: its chunk, its columns; the run blob last
    assert [op for op in data_section if op in (CHUNK, ATTACHMENT)] == \
        [CHUNK] + [CHUNK, ATTACHMENT] * 3 + [ATTACHMENT]
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
        assert len(summary.chunk_indexes) == 4
        assert sum(1 for _ in reader.iter_messages()) == summary.statistics.message_count
        blobs = [a.data for a in reader.iter_attachments()]
    assert {b[:4] for b in blobs} == {b"TCC3"}
    assert [decode_columns(b)[0]["episode"] for b in blobs] == [0, 1, 2, -1]


def test_a_compressed_file_reads_as_the_same_file_uncompressed(tmp_path):
    small = write(tmp_path / "run.mcap")
    plain = write(tmp_path / "plain.mcap", compress=False)
    assert small.stat().st_size < plain.stat().st_size
    a, b = read_run(small), read_run(plain)
    assert [e.steps for e in a.episodes] == [e.steps for e in b.episodes]
    ca, cb = read_columns(small), read_columns(plain)
    assert ca.n == cb.n and list(ca.episode_ids) == list(cb.episode_ids) == [0, 1, 2]
    assert [ca.states.row(i) for i in range(ca.n)] == [cb.states.row(i) for i in range(cb.n)]


def _flip_in_chunk(path, nth: int) -> None:
    """Flip one byte in the middle of the compressed data of the ``nth`` chunk."""
    data = bytearray(path.read_bytes())
    chunks = [(a, b) for op, a, b in top_records(bytes(data)) if op == CHUNK]
    a, b = chunks[nth]
    data[(a + b) // 2 + 20] ^= 0x40
    path.write_bytes(bytes(data))


def test_a_damaged_chunk_names_its_episode(tmp_path):
    path = write(tmp_path / "run.mcap")
    _flip_in_chunk(path, 2)  # the run header's chunk, episode 0's, episode 1's
    for read in (read_columns, lambda p: list(read_episodes(p))):
        with pytest.raises(InputError, match=r"run\.mcap, episode 1: the chunk of the "
                                             r"episode's messages is damaged \(the chunk at "
                                             r"byte \d+: .*\)") as info:
            read(path)
        assert "--salvage" in info.value.hint
    cols = read_columns(path, salvage=True)
    assert list(cols.episode_ids) == [0, 2]
    assert len(cols.warnings) == 1 and re.match(r".*run\.mcap, episode 1: the chunk of the "
                                                r"episode's messages is damaged .*; the "
                                                r"episode is left out", cols.warnings[0])
    with pytest.warns(SalvagedEpisodeWarning, match="episode 1: the chunk"):
        assert [e.id for e in read_episodes(path, salvage=True)] == [0, 2]


def test_a_damaged_run_header_chunk_is_an_error(tmp_path):
    path = write(tmp_path / "run.mcap")
    _flip_in_chunk(path, 0)
    with pytest.raises(InputError, match=r"run\.mcap: the run header's chunk is damaged"):
        read_columns(path)


def test_a_cut_compressed_file_keeps_every_finished_episode(tmp_path):
    path = write(tmp_path / "run.mcap")
    data = path.read_bytes()
    chunks = [(a, b) for op, a, b in top_records(data) if op == CHUNK]
    a, b = chunks[3]  # episode 2's chunk, cut in the middle
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:(a + b) // 2])
    with pytest.warns(DamagedEpisode, match=r"read 2 complete episode\(s\)"):
        assert [e.id for e in read_episodes(cut)] == [0, 1]
    cols = read_columns(cut)
    assert list(cols.episode_ids) == [0, 1] and "read 2 complete episode(s)" in cols.warnings[0]


def test_a_columns_blob_that_lies_about_its_size_is_refused(tmp_path):
    from tracecheck.episodes.codec import encode_columns  # noqa: F401  (the writer's encoder)

    path = write(tmp_path / "run.mcap")
    with open(path, "rb") as f:
        blob = next(make_reader(f).iter_attachments()).data
    import zlib

    body = bytearray(blob[:-4])
    struct.pack_into("<Q", body, 4, 10 ** 12)  # declares a terabyte
    liar = bytes(body) + struct.pack("<I", zlib.crc32(bytes(body)))
    with pytest.raises(InputError, match=r"would decompress to 1000000000000 bytes from \d+ "
                                         r"\(more than tracecheck's limit"):
        decode_columns(liar, where="x: ")
    body = bytearray(blob[:-4])
    struct.pack_into("<Q", body, 4, struct.unpack_from("<Q", blob, 4)[0] - 1)
    short = bytes(body) + struct.pack("<I", zlib.crc32(bytes(body)))
    with pytest.raises(InputError, match=r"x: damaged columns attachment: it declares \d+ "
                                         r"bytes but its zstd frame \d+: refused before"):
        decode_columns(short, where="x: ")
