"""Decompression bombs: a zstd frame whose header declares more than the record around it (a
chunk, an episode's columns attachment, a run blob) may hold is refused before a byte is
decompressed — python-zstandard allocates what a frame declares, whatever limit it is given —
and said so; an lz4 frame likewise. Memory is measured with tracemalloc, which sees the
buffers the decompressors allocate."""

from __future__ import annotations

import re
import struct
import tracemalloc
import zlib

import lz4.frame
import pytest
import zstandard

from tests.helpers import episode, run
from tracecheck.episodes import EpisodeWriter, new_header, read_columns
from tracecheck.episodes import codec
from tracecheck.episodes import writer as W
from tracecheck.episodes.codec import decode_columns
from tracecheck.episodes.frames import unlz4, unzstd
from tracecheck.errors import InputError

GiB = 1 << 30
CHUNK = 6


def declaring(frame: bytes, size: int) -> bytes:
    """The zstd ``frame`` with its header declaring ``size`` bytes of content (8 bytes for
    the size; the blocks unchanged)."""
    d = frame[4]
    single, dict_bytes = (d >> 5) & 1, [0, 1, 2, 4][d & 3]
    head = 5 + (1 - single) + dict_bytes + [single, 2, 4, 8][d >> 6]
    return (frame[:4] + bytes([0xC0 | single << 5 | (d & 0x04)])
            + frame[5:5 + (1 - single) + dict_bytes] + struct.pack("<Q", size) + frame[head:])


def refused(fn, error, match: str) -> int:
    """The most memory ``fn()`` held at once before it raised ``error`` matching ``match``."""
    tracemalloc.start()
    try:
        with pytest.raises(error, match=match):
            fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def write(path, **kw):
    with EpisodeWriter(path, new_header("recorded"), **kw) as out:
        for i in range(3):
            out.write(episode(i, 4, crash_at_end=i == 1))
    return path


def test_a_frame_that_declares_another_size_is_not_decompressed():
    frame = zstandard.ZstdCompressor().compress(b"x" * 1000)
    assert unzstd(frame, 1000, "a chunk") == b"x" * 1000
    bomb = declaring(frame, 4 * GiB)
    assert zstandard.frame_content_size(bomb) == 4 * GiB
    assert refused(lambda: unzstd(bomb, 1000, "a chunk"), ValueError,
                   "a chunk declares 1000 bytes but its zstd frame 4294967296: refused before "
                   "decompressing") < 1 << 20
    silent = zstandard.ZstdCompressor(write_content_size=False).compress(b"x" * 5000)
    with pytest.raises(ValueError, match="a chunk does not decompress"):  # bounded output
        unzstd(silent, 1000, "a chunk")
    sized = lz4.frame.compress(b"y" * (50 << 20))
    with pytest.raises(ValueError, match="a chunk declares 1000 bytes but its lz4 frame "
                                         "52428800: refused before decompressing"):
        unlz4(sized, 1000, "a chunk")


def _with_chunk(data: bytes, nth: int, change) -> bytes:
    """``data`` with the zstd frame of its ``nth`` chunk record changed by ``change``."""
    at, seen = 8, 0
    while True:
        op, length = struct.unpack_from("<BQ", data, at)
        if op == CHUNK:
            if seen == nth:
                break
            seen += 1
        at += 9 + length
    body = data[at + 9:at + 9 + length]
    name = struct.unpack_from("<I", body, 28)[0]
    fixed = body[:32 + name]
    frame = change(body[32 + name + 8:])
    body = fixed + struct.pack("<Q", len(frame)) + frame
    return data[:at] + struct.pack("<BQ", CHUNK, len(body)) + body + data[at + 9 + length:]


def test_a_chunk_bomb_is_refused_naming_its_episode(tmp_path, capsys):
    path = write(tmp_path / "run.mcap")
    bomb = tmp_path / "bomb.mcap"
    bomb.write_bytes(_with_chunk(path.read_bytes(), 2, lambda f: declaring(f, GiB)))
    message = (re.escape(f"{bomb}, episode 1: the chunk of the episode's messages is damaged "
                         "(the chunk at byte ") + r"\d+: a chunk declares \d+ bytes but its zstd frame 1073741824: "
               r"refused before decompressing \(a decompression bomb, or damage\)\)")
    assert refused(lambda: read_columns(bomb), InputError, message) < 64 << 20
    for command in ("info", "stats", "replay"):
        args = [command, bomb] + (["--shield", "none"] if command == "replay" else [])
        code, _, err = run(capsys, *args)
        assert code == 2 and "refused before decompressing" in err, (command, err)
        assert "Traceback" not in err and "MemoryError" not in err
        assert "hint: --salvage leaves damaged episodes out with a warning" in err


def test_a_columns_attachment_bomb_is_refused_naming_its_episode(tmp_path, capsys,
                                                                 monkeypatch):
    real = W.encode_columns

    def bombed(ep, *args, **kw):
        blob = real(ep, *args, **kw)
        if ep != 1:
            return blob
        body = blob[:12] + declaring(blob[12:-4], 2 * GiB)
        return body + struct.pack("<I", zlib.crc32(body))

    monkeypatch.setattr(W, "encode_columns", bombed)
    path = write(tmp_path / "run.mcap")
    monkeypatch.undo()
    message = (r"episode 1: damaged columns attachment: it declares \d+ bytes but its zstd "
               r"frame 2147483648: refused before decompressing")
    assert refused(lambda: read_columns(path), InputError, message) < 64 << 20
    code, _, err = run(capsys, "info", path)
    assert code == 2 and f"error: {path}, episode 1: damaged columns attachment" in err
    assert "Traceback" not in err
    code, out, err = run(capsys, "info", path, "--salvage", "--json")
    assert code == 0 and '"episodes": 2' in out and "refused before decompressing" in err


def test_a_run_blob_bomb_is_not_read_and_the_file_is_walked(tmp_path, monkeypatch):
    real = codec.encode_run_columns

    def bombed(*args, **kw):
        blob = real(*args, **kw)
        body = blob[:12] + declaring(blob[12:-4], 3 * GiB)
        return body + struct.pack("<I", zlib.crc32(body))

    monkeypatch.setattr(codec, "encode_run_columns", bombed)
    path = write(tmp_path / "run.mcap", block_rows=5)
    monkeypatch.undo()
    from tests.helpers import from_blobs
    from tracecheck.episodes.blobs import blob_records
    from tracecheck.episodes.records import attachment_at, mapped
    from tracecheck.episodes.codec import RUN_COLUMNS_MEDIA_TYPE

    with mapped(path) as buf:
        blobs = [attachment_at(buf, o, s, RUN_COLUMNS_MEDIA_TYPE)
                 for o, s in blob_records(buf).runs]
    assert len(blobs) == 3
    with pytest.raises(InputError, match="it declares .* but its zstd frame 3221225472"):
        decode_columns(blobs[0])
    assert not from_blobs(path)
    tracemalloc.start()
    try:
        cols = read_columns(path)
        assert tracemalloc.get_traced_memory()[1] < 64 << 20
    finally:
        tracemalloc.stop()
    assert cols.episode_ids.tolist() == [0, 1, 2] and not cols.warnings


def test_a_streamed_frame_without_its_size_is_read_within_the_records_size():
    """A streaming writer's frame (Go's mcap CLI, python-zstandard's compressobj) does not
    say its size and uses its own window (2 MiB at level 3): read, bounded by the size the
    record declares — not refused as damage."""
    import zstandard

    from tracecheck.episodes.frames import unzstd

    data = bytes(range(256)) * 2000  # 512 000 bytes
    co = zstandard.ZstdCompressor(level=3).compressobj()
    frame = co.compress(data) + co.flush()
    assert zstandard.frame_content_size(frame) == -1
    assert unzstd(frame, len(data), "a chunk") == data
    with pytest.raises(ValueError):
        unzstd(frame, len(data) - 1, "a chunk")  # more than the record says: refused
