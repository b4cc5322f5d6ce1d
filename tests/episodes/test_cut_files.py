"""Files with episodes cut out (or their summary edited): what the summary lists and the run
blobs' names are checked against what the data section holds, by every reader — a file with
a block missing from the middle is exit 2 naming what is listed and what is there, never
fewer episodes with exit 0; with --salvage the episodes it holds, and a warning."""

from __future__ import annotations

import re
import struct

import pytest

from tests.helpers import episode, from_blobs, run
from tracecheck.episodes import EpisodeWriter, new_header, read_columns, read_run
from tracecheck.episodes.blobs import blob_records, verified_block
from tracecheck.episodes.records import mapped
from tracecheck.errors import InputError

HINT = ("hint: read a copy of the file as it was written; --salvage reads the episodes it "
        "holds, with a warning")
ATTACHMENT_INDEX, FOOTER = 10, 2


def write(path, n=20):
    """``n`` episodes of 3 to 7 steps in blocks of 20 states or more: episodes 0–3, 4–7,
    8–11, 12–14, 15–18, 19 (run blobs run-4 … run-20)."""
    with EpisodeWriter(path, new_header("recorded", model_name="HighwayEnvironment"),
                       block_rows=20) as out:
        for i in range(n):
            out.write(episode(i, 3 + i % 5, crash_at_end=i % 3 == 0))
    return path


def blocks(path) -> list[tuple[int, int, list[int]]]:
    """(first byte, end of the run blob's record, episode ids) of each block."""
    with mapped(path) as buf:
        view = memoryview(buf)
        index = blob_records(buf)
        out = []
        for k, (offset, size) in enumerate(index.runs):
            arrays = verified_block(buf, view, index, k)[1]
            out.append((int(arrays["run:spans"][0, 0]), offset + size,
                        arrays["run:episodes"].tolist()))
        view.release()
    return out


def cut(path, out, k: int, summary: bool = True):
    """``path`` without block ``k`` (its episodes and run blob); ``summary=False``: and
    without its summary (a footer that names none)."""
    data = path.read_bytes()
    start, end, _ = blocks(path)[k]
    data = data[:start] + data[end:]
    if not summary:
        data_end = data.rindex(b"\x0f" + struct.pack("<Q", 4))  # the data end record
        data = (data[:data_end + 13] + struct.pack("<BQQQI", FOOTER, 20, 0, 0, 0)
                + data[-8:])
    out.write_bytes(data)
    return out


def test_the_blocks_of_the_file(tmp_path):
    assert [ids for _, _, ids in blocks(write(tmp_path / "run.mcap"))] == [
        [0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11], [12, 13, 14], [15, 16, 17, 18], [19]]


@pytest.mark.parametrize("k,held,missing", [
    (2, "16 episode(s) (0–7, 12–19) in 5 block(s)", "episode(s) 8–11 (block 2) are missing"),
    (5, "19 episode(s) (0–18) in 5 block(s)", "episode(s) 19 (block 5) are missing"),
])
def test_a_block_cut_out_is_an_error_naming_what_is_listed_and_held(tmp_path, capsys, k, held,
                                                                    missing):
    path = cut(write(tmp_path / "whole.mcap"), tmp_path / "run.mcap", k)
    message = (f"{path}: the file's summary lists 20 episode(s) (0–19) in 6 block(s), but its "
               f"data section holds {held}: {missing} — the file was cut or edited after it "
               "was written")
    with pytest.raises(InputError, match=re.escape(message)):
        read_columns(path)
    with pytest.raises(InputError, match=re.escape(message)):
        read_run(path)
    for args in (["info"], ["stats"], ["replay", "--shield", "paper"],
                 ["export", "simb", "-o", tmp_path / "simb"]):
        code, out, err = run(capsys, *args[:2], path, *args[2:]) if args[0] == "export" \
            else run(capsys, args[0], path, *args[1:])
        assert code == 2, (args, out, err)
        assert f"error: {message}\n  {HINT}" in err, err
        assert "Traceback" not in err
    cols = read_columns(path, salvage=True)
    assert len(cols.episode_ids) == (16 if k == 2 else 19)
    assert cols.warnings == [f"{message}; only the episodes it holds are read"]
    salvaged = read_run(path, salvage=True)
    assert len(salvaged.episodes) == len(cols.episode_ids)
    assert salvaged.warnings == cols.warnings
    code, out, err = run(capsys, "info", path, "--salvage", "--json")
    assert code == 0 and f'"episodes": {len(cols.episode_ids)}' in out
    assert missing in err


def test_without_a_summary_the_run_blobs_names_tell(tmp_path, capsys):
    path = cut(write(tmp_path / "whole.mcap"), tmp_path / "run.mcap", 2, summary=False)
    message = (f"{path}: the run blob run-15.columns closes a block after the file's first 15 "
               "episodes, but 11 come before it: 4 episode(s) are missing before it — the "
               "file was cut or edited after it was written")
    with pytest.raises(InputError, match=re.escape(message)):
        read_columns(path)
    code, _, err = run(capsys, "replay", path, "--shield", "paper")
    assert code == 2 and f"error: {message}" in err and "Traceback" not in err


def test_a_killed_recording_and_a_file_without_summary_read_as_before(tmp_path):
    """No summary and run blobs that fit: nothing is missing, nothing is said."""
    path = write(tmp_path / "whole.mcap")
    data = path.read_bytes()
    data_end = data.rindex(b"\x0f" + struct.pack("<Q", 4))
    bare = tmp_path / "bare.mcap"
    bare.write_bytes(data[:data_end + 13] + struct.pack("<BQQQI", FOOTER, 20, 0, 0, 0)
                     + data[-8:])
    killed = tmp_path / "killed.mcap"
    killed.write_bytes(data[:blocks(path)[3][1]])  # after block 3's blob
    assert read_columns(bare).episode_ids.tolist() == list(range(20))
    cols = read_columns(killed)
    assert cols.episode_ids.tolist() == list(range(15)) and not cols.warnings


def test_a_summary_that_puts_an_episode_elsewhere_is_not_trusted(tmp_path, capsys):
    """The data section intact, the summary's index of episode 5's columns off by a byte:
    the blocks are not taken from their blobs (whose episodes are not those the summary
    lists there), and the walk names the difference."""
    path = write(tmp_path / "run.mcap")
    assert from_blobs(path)
    data = bytearray(path.read_bytes())
    name = b"episode-5.columns"
    at = data.rindex(struct.pack("<I", len(name)) + name) - 40  # its index record's offset
    assert data[at - 9] == ATTACHMENT_INDEX
    offset = struct.unpack_from("<Q", data, at)[0]
    struct.pack_into("<Q", data, at, offset + 1)
    path.write_bytes(bytes(data))
    assert not from_blobs(path)
    message = (f"{path}: the file's summary lists 20 episode(s) (0–19) in 6 block(s), but its "
               "data section holds 20 episode(s) (0–19) in 6 block(s): its summary puts "
               f"episode-5.columns at byte {offset + 1}, the file holds it at byte {offset}")
    code, _, err = run(capsys, "info", path)
    assert code == 2 and f"error: {message} — the file was cut or edited" in err
