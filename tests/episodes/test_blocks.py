"""Blocks of episodes (issue 28): a writer leaves a run blob every BLOCK_ROWS states, readers
take a file a block at a time from them, and every command answers as if the file were read
whole, walked episode by episode."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from tests.helpers import episode, from_blobs, run, walking
from tracecheck.episodes import EpisodeWriter, new_header, read_columns
from tracecheck.episodes import columns as C
from tracecheck.episodes import writer as W
from tracecheck.episodes.columns import BlockUnchecked, block_refs, blocks_of, read_blocks
from tracecheck.episodes.records import walk, Attachment
from tracecheck.episodes.codec import RUN_COLUMNS_MEDIA_TYPE
from tracecheck.errors import InputError


def write(path, episodes, block_rows=10, **kw):
    with EpisodeWriter(path, new_header("recorded", model_name="HighwayEnvironment"),
                       block_rows=block_rows, **kw) as out:
        for ep in episodes:
            out.write(ep)
    return path


def many(n=9):
    """Episodes of 3 to 7 steps, one that crashes; a LANE_LEFT only from episode 6 on (an
    action a later block has and an earlier one does not)."""
    out = []
    for i in range(n):
        ep = episode(i, 3 + i % 5, crash_at_end=i == 4, live=i % 2 == 0)
        if i >= 6:
            steps = list(ep.steps)
            steps[2] = dataclasses.replace(steps[2], action="LANE_LEFT")
            ep = dataclasses.replace(ep, steps=tuple(steps))
        out.append(ep)
    return out


def same(a, b) -> None:
    for key in ("episode_ids", "starts", "episode", "step", "time", "action", "reward",
                "crashed", "values"):
        assert np.array_equal(getattr(a, key), getattr(b, key), equal_nan=True), key
    assert a.action_names == b.action_names and a.seeds == b.seeds and a.reasons == b.reasons
    assert [a.states.row(i) for i in range(a.n)] == [b.states.row(i) for i in range(b.n)]
    assert a.states.label(a.n - 1) == b.states.label(b.n - 1)


def blob_count(path) -> int:
    return sum(isinstance(r, Attachment) and r.media_type == RUN_COLUMNS_MEDIA_TYPE
               for r in walk(path, path.read_bytes()))


def test_a_blob_per_block_and_the_blocks_read_as_the_walk(tmp_path, monkeypatch):
    path = write(tmp_path / "run.mcap", many())
    assert blob_count(path) == blocks_of(path) == 4  # 10 states or more each, the rest last
    assert from_blobs(path)
    blocks = list(read_blocks(path))
    assert [len(b.episode_ids) for b in blocks] == [3, 2, 3, 1]
    assert all(b.n >= 10 for b in blocks[:-1])
    assert "LANE_LEFT" not in blocks[0].action_names and "LANE_LEFT" in blocks[-1].action_names
    for ref, b in zip(block_refs(path), blocks):  # a block alone (a Ray task's): the same
        same(next(read_blocks(path, block=ref)), b)
    whole = read_columns(path)
    assert whole.action_names == ("IDLE", "FASTER", "LANE_LEFT")
    walking(monkeypatch)
    same(whole, read_columns(path))


def test_the_walk_groups_episodes_into_blocks_too(tmp_path, monkeypatch):
    path = write(tmp_path / "run.mcap", many(), block_rows=10 ** 9)
    assert blocks_of(path) == 1
    walking(monkeypatch)
    monkeypatch.setattr(C, "BLOCK_ROWS", 16)
    blocks = list(read_blocks(path))
    assert [len(b.episode_ids) for b in blocks] == [4, 3, 2]
    monkeypatch.setattr(C, "BLOCK_ROWS", 10 ** 9)
    same(C.join(str(path), blocks), read_columns(path))


def test_a_damaged_block_is_walked_and_named(tmp_path, monkeypatch):
    path = write(tmp_path / "run.mcap", many(), compress=False)
    data = bytearray(path.read_bytes())
    data[data.find(b'"episode":5,"step":2') + 30] ^= 1  # one bit of episode 5 (block 2)
    path.write_bytes(bytes(data))
    assert not from_blobs(path)
    refs = block_refs(path)
    assert next(read_blocks(path, block=refs[1])).episode_ids.tolist() == [3, 4]
    with pytest.raises(BlockUnchecked, match="block 2 of its episodes does not check"):
        next(read_blocks(path, block=refs[2]))
    seen = []
    with pytest.raises(InputError, match=r"run.mcap, episode 5: "):
        for b in read_blocks(path):
            seen += b.episode_ids.tolist()
    assert seen == [0, 1, 2, 3, 4]  # blocks 0 and 1 came from their blobs
    salvaged = read_columns(path, salvage=True)
    assert salvaged.episode_ids.tolist() == [0, 1, 2, 3, 4, 6, 7, 8]
    assert len(salvaged.warnings) == 1 and "episode 5" in salvaged.warnings[0]


def test_an_id_used_twice_ends_the_blobs(tmp_path):
    eps = many()
    eps[7] = dataclasses.replace(eps[7], id=1)
    path = write(tmp_path / "run.mcap", eps)
    assert blob_count(path) == 2 and blocks_of(path) == 0  # none from its block on: walked
    with pytest.raises(InputError, match="the episode id 1 is used twice"):
        read_columns(path)


def test_a_killed_writer_leaves_its_blocks_and_episodes(tmp_path):
    path = tmp_path / "run.mcap"
    out = EpisodeWriter(path, new_header("recorded"), block_rows=10)
    out.open()
    for ep in many(5):
        out.write(ep)
    out._stream.flush()  # killed here: no summary, no last blob
    data = path.read_bytes()
    out.close()
    killed = tmp_path / "killed.mcap"
    killed.write_bytes(data)
    assert blocks_of(killed) == 0
    cols = read_columns(killed)
    assert cols.episode_ids.tolist() == [0, 1, 2, 3, 4] and not cols.warnings


@pytest.mark.parametrize("command", [
    ["replay", "--shield", "paper", "--json", "--ltl", "G not({Crash = TRUE})"],
    ["diff", "--shield", "paper", "--against", "none", "--json"],
    ["stats", "--json"],
    ["info", "--json"],
])
def test_commands_answer_the_same_block_by_block(paper_traces, tmp_path, capsys,
                                                 monkeypatch, command):
    """The paper's traces in one block and in blocks of 200 states: every answer the same."""
    one = tmp_path / "qqsingle.mcap"
    run(capsys, "import", "simb", str(paper_traces / "simb" / "base"), "-o", str(one))
    monkeypatch.setattr(W, "BLOCK_ROWS", 200)
    blocked = tmp_path / "qqblocked.mcap"
    run(capsys, "import", "simb", str(paper_traces / "simb" / "base"), "-o", str(blocked))
    assert blocks_of(one) == 1 and blocks_of(blocked) > 3

    def answer(path):
        code, text, err = run(capsys, *command, str(path))
        assert code in (0, 1), err
        out = json.loads(text)
        for entry in out.get("files", ()):  # info's are tables, replay's names
            if isinstance(entry, dict):
                entry.pop("created", None)  # the second each was written in
        text = json.dumps(out).replace(str(path), "FILE").replace(path.stem, "NAME")
        return {k: v for k, v in json.loads(text).items()
                if k not in ("elapsed_s", "statistics_s", "steps_per_s")}

    assert answer(one) == answer(blocked)


def test_files_from_before_blocks_read_as_before(monkeypatch):
    """A file with one run blob for the whole file (before blocks) is one block from it; a
    file with none (before run blobs) is walked; both give the walk's answer."""
    from tests.helpers import ROOT

    old_blob = ROOT / "tests" / "episodes" / "data" / "discrete_before_parameters.mcap"
    no_blob = ROOT / "sample_traces" / "base_none.mcap"
    assert blocks_of(old_blob) == 1 and from_blobs(old_blob) and blocks_of(no_blob) == 0
    fast = [read_columns(old_blob), read_columns(no_blob)]
    assert len(list(read_blocks(no_blob))) == 1 and fast[1].n > 1000
    walking(monkeypatch)
    for cols, path in zip(fast, (old_blob, no_blob)):
        same(cols, read_columns(path))


def test_a_block_of_another_file_is_refused(tmp_path):
    """A Ray task gets block k of the file as it was counted; the file written again (other
    blocks) in between: the task's block does not check, it is not read from the new file."""
    path = write(tmp_path / "run.mcap", many())
    refs = block_refs(path)
    write(path, many()[:5])
    assert len(block_refs(path)) == 2
    with pytest.raises(BlockUnchecked):
        next(read_blocks(path, block=refs[1]))


def test_the_data_section_ends_at_the_last_blob(tmp_path, monkeypatch):
    """Nothing may follow the last blob but the data section's end: a file where something
    does is walked (and reads the same)."""
    from tracecheck.episodes.blobs import blob_records
    from tracecheck.episodes.records import mapped

    path = write(tmp_path / "run.mcap", many(), compress=False)
    with mapped(path) as buf:
        end = sum(blob_records(buf).runs[-1])
    before = read_columns(path)
    assert blocks_of(path) == 4
    data = bytearray(path.read_bytes())
    assert data[end] == 15  # MCAP's DataEnd
    data[end] = 0x80  # a record of a kind MCAP readers skip
    path.write_bytes(bytes(data))
    assert blocks_of(path) == 0
    same(read_columns(path), before)


def test_a_variable_of_two_kinds_is_named(tmp_path):
    """Episodes whose variable changes kind (a number, then a boolean) or goes missing: an
    error naming it, not one kind taken for all (nor a KeyError)."""
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    def ep(i, value, name="Foo"):
        steps = tuple(StepRecord(k, float(k), None if k == 0 else "GO", {name: value, "x": 1.0},
                                 0.0, False) for k in range(3))
        return Episode(i, steps, make_end(steps))

    for second, message in ((True, "the variable Foo is a number in episode 0 and a boolean "
                                   "in episode 1"),
                            (2.0, "the variable Bar is in episode 1 but not in episode 0")):
        for rows in (3, 1000):  # in two blocks; in one (the walk of the writer's read-back)
            path = write(tmp_path / f"run{rows}.mcap",
                         [ep(0, 1.0), ep(1, second, "Foo" if second is True else "Bar")],
                         block_rows=rows)
            with pytest.raises(InputError, match=message.replace("(", r"\(")):
                read_columns(path)


class _ThroughMcap:
    """mcap's own Writer behind McapOut's interface, with tracecheck's settings (its public
    API only): the oracle for tracecheck's writer."""

    def __init__(self, stream, *, chunked=True):
        from mcap.writer import CompressionType, IndexType, Writer

        self.writer = Writer(stream, chunk_size=1 << 62, use_chunking=chunked,
                             compression=CompressionType.ZSTD,
                             index_types=IndexType.ATTACHMENT | IndexType.CHUNK
                             | IndexType.METADATA)

    def end_chunk(self):
        self.writer.flush()

    def add_messages(self, messages):
        """tracecheck's messages made ready for a chunk, given to mcap's Writer one by one
        (its records read back: opcode, length, channel, sequence, log and publish time)."""
        import struct

        import zstandard

        raw = messages.records if messages.compressed is None else \
            zstandard.ZstdDecompressor().decompress(messages.compressed,
                                                    max_output_size=messages.size)
        at = 0
        while at < len(raw):
            _, length, channel, sequence, log, publish = struct.unpack_from("<BQHIQQ", raw, at)
            data = raw[at + 31:at + 9 + length]
            self.writer.add_message(channel_id=channel, log_time=log, data=data,
                                    publish_time=publish, sequence=sequence)
            at += 9 + length

    def __getattr__(self, name):
        return getattr(self.writer, name)


@pytest.mark.parametrize("compress", [True, False])
def test_the_file_is_byte_for_byte_what_mcaps_writer_writes(tmp_path, monkeypatch, compress):
    """tracecheck's own writer (indexes kept as bytes: ~90 MB of objects for 10^5 episodes,
    and no private attribute of mcap's Writer touched) writes the very file mcap's Writer
    writes with the same settings, and mcap's reader reads its summary."""
    from mcap.reader import make_reader

    header = new_header("recorded", model_name="HighwayEnvironment")

    def written(path):
        with EpisodeWriter(path, header, block_rows=10, compress=compress) as out:
            for ep in many():
                out.write(ep)
        return path.read_bytes()

    monkeypatch.setattr(W._time, "time_ns", lambda: 1_700_000_000_000_000_000)  # one clock
    ours = written(tmp_path / "ours.mcap")
    monkeypatch.setattr(W, "McapOut", _ThroughMcap)
    assert ours == written(tmp_path / "mcap.mcap")
    with open(tmp_path / "ours.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert len(summary.chunk_indexes) == ((1 + 9) if compress else 0)  # head's, one an episode
    assert len(summary.attachment_indexes) == 9 + blob_count(tmp_path / "ours.mcap")


def test_an_integer_function_stays_integer_across_episodes_of_other_elements(tmp_path):
    """Episodes with different elements are widened to one element axis: that made an
    integer function a float column again (F(a) / 2 divided reals on replay)."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.episodes import new_header, read_columns
    from tracecheck.episodes.files import write_run
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    def episode(eid, f):
        steps = tuple(StepRecord(k, float(k), None if k == 0 else "GO", {"F": f}, 0.0, False)
                      for k in range(3))
        return Episode(eid, steps, make_end(steps))
    a, b = Elem("a"), Elem("b")
    path = tmp_path / "ints.mcap"
    write_run(path, new_header("recorded", actions=["GO"]),
              [episode(0, FuncValue({a: 3})), episode(1, FuncValue({a: 3, b: -3}))])
    vals, defined = read_columns(path).states.functions["F"]
    assert vals.dtype == np.int64 and vals[defined].tolist() == [3, 3, 3, 3, -3, 3, -3, 3, -3]
