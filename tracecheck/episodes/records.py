"""The records of an MCAP file, read without trusting the file.

:func:`walk` steps through the data section record by record (opcode, length, content) and
checks every length against what is left before reading it, so a truncated or damaged file
ends in a :class:`Damage` that says where, never in an exception from deep inside a parser.
Only the few record kinds tracecheck reads are parsed (schemas, channels, messages,
attachments, chunks); message bodies are handed on as offsets, so a reader that skips most
messages pays for none of them. Chunks (tracecheck writes one per episode; other MCAP tools may
chunk a file otherwise) are decompressed with a limit on the decompression ratio and size,
checked — with the size the chunk's frame itself declares — before anything is decompressed
(:mod:`tracecheck.episodes.frames`).
"""

from __future__ import annotations

import mmap
import struct
from array import array
from contextlib import contextmanager
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Container, Iterator, NamedTuple, Optional, Union

from ..errors import InputError
from .frames import unlz4, unzstd

__all__ = ["forget", "walk", "Damage", "BadChunk", "Schema", "Channel", "Attachment",
           "MessageRef", "DataEnd", "MESSAGE", "MAGIC", "MAX_CHUNK_RATIO", "MAX_CHUNK_BYTES",
           "mapped", "indexed_attachments", "summary_listing", "attachment_at",
           "attachment_name"]

MAGIC = b"\x89MCAP0\r\n"
HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, ATTACHMENT, DATA_END = 1, 2, 3, 4, 5, 6, 9, 15

#: A chunk may decompress to at most this many times its compressed size (plus 1 MiB) …
MAX_CHUNK_RATIO = 1000
#: … and to at most this many bytes.
MAX_CHUNK_BYTES = 1 << 30

_REC = struct.Struct("<BQ")
_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")
_CHUNK = struct.Struct("<QQQI")
#: the package that decompresses each compression of chunks
_PACKAGES = {"zstd": "zstandard", "lz4": "lz4"}


@dataclass(frozen=True)
class Damage:
    """Where and why the walk stopped early."""

    why: str


@dataclass(frozen=True)
class BadChunk:
    """A chunk of the file's top level whose contents are damaged (it does not decompress or
    its checksum does not match) while its record is whole: the walk goes on after it."""

    why: str
    at: int


@dataclass(frozen=True)
class Schema:
    id: int
    name: str


@dataclass(frozen=True)
class Channel:
    id: int
    schema_id: int
    topic: str


@dataclass(frozen=True)
class Attachment:
    name: str
    media_type: str
    data: bytes
    at: int = -1  # where its record starts in the file (-1: inside a chunk)


@dataclass(frozen=True)
class DataEnd:
    """The end of the data section: the summary, where the file has one, starts ``at``."""

    at: int


class MessageRef(NamedTuple):
    """A message record, not copied: its channel id is the first two bytes of
    ``buffer[start:end]`` and its data starts 22 bytes in."""

    buffer: Any
    start: int
    end: int


Record = Union[Schema, Channel, Attachment, MessageRef, Damage, BadChunk, DataEnd]
_new_ref = tuple.__new__  # a MessageRef without its Python-level __new__ (the hot loop)


class _BadRecord(Exception):
    """A record whose fields do not fit it (the message says how)."""


class _Fields:
    """Reads the fields of one record's content, each checked against the record's end."""

    __slots__ = ("buf", "at", "end")

    def __init__(self, buf, start: int, end: int) -> None:
        self.buf, self.at, self.end = buf, start, end

    def take(self, n: int) -> int:
        at = self.at
        if n < 0 or at + n > self.end:
            raise _BadRecord("a field runs past the end of its record")
        self.at = at + n
        return at

    def u16(self) -> int:
        return _U16.unpack_from(self.buf, self.take(2))[0]

    def u32(self) -> int:
        return _U32.unpack_from(self.buf, self.take(4))[0]

    def u64(self) -> int:
        return _U64.unpack_from(self.buf, self.take(8))[0]

    def string(self) -> str:
        n = self.u32()
        at = self.take(n)
        try:
            return bytes(self.buf[at:at + n]).decode("utf-8")
        except UnicodeDecodeError:
            raise _BadRecord("a name is not UTF-8") from None

    def blob(self, n: int) -> bytes:
        at = self.take(n)
        return self.buf[at:at + n]


@contextmanager
def mapped(path: Path) -> Iterator:
    """The bytes of ``path``, memory-mapped for the block (an empty file gives ``b""``)."""
    buf = _open(path)
    try:
        yield buf
    finally:
        if hasattr(buf, "close"):
            buf.close()


def _open(path: Path):
    try:
        with open(path, "rb") as stream:
            try:
                return mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ)
            except ValueError:  # an empty file cannot be mapped
                return b""
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except IsADirectoryError:
        raise InputError(f"{path} is a folder, not an MCAP file") from None
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None


def walk(path: Path, buf, regions: Optional[list[tuple[int, int]]] = None,
         wanted: Optional[Container[int]] = None) -> Iterator[Record]:
    """The records of the MCAP file ``buf`` (read from ``path``), in order, up to the end
    of its data section; a :class:`Damage` last where the file is damaged or ends early.
    ``regions``: only the records in these byte ranges of the file, one after the other
    (each must start at a record). ``wanted``: the channel ids whose messages are given (read
    as each message is met: a reader adds a channel when its record comes); a message on
    another channel (Foxglove's, most of a recording's) is checked for its length and
    passed over."""
    if bytes(buf[:8]) != MAGIC:
        raise InputError(f"{path} is not an MCAP file (it does not start with the MCAP magic "
                         "bytes)")
    for start, end in regions or [(8, len(buf))]:
        for record in _records(buf, start, end, True, wanted):
            yield record
            if isinstance(record, Damage):
                return


def _records(buf, at: int, end: int, top: bool,
             wanted: Optional[Container[int]] = None) -> Iterator[Record]:
    unpack = _REC.unpack_from
    while at < end:
        if at + 9 > end:
            yield Damage(f"a record header is cut off at byte {at}")
            return
        op, length = unpack(buf, at)
        start = at + 9
        stop = start + length
        if stop > end:
            yield Damage(f"the record at byte {at} runs past the end of the "
                         f"{'file' if top else 'chunk'}")
            return
        at = stop
        if op == MESSAGE:
            if length < 22:
                yield Damage(f"the message record at byte {start - 9} is too short")
                return
            if wanted is not None and buf[start] | buf[start + 1] << 8 not in wanted:
                continue
            yield _new_ref(MessageRef, (buf, start, stop))  # MessageRef(…), faster
            continue
        try:
            if op == CHANNEL:
                f = _Fields(buf, start, stop)
                yield Channel(f.u16(), f.u16(), f.string())
            elif op == SCHEMA:
                f = _Fields(buf, start, stop)
                yield Schema(f.u16(), f.string())
            elif op == ATTACHMENT:
                f = _Fields(buf, start, stop)
                f.take(16)
                name, media = f.string(), f.string()
                data = f.blob(f.u64())
                yield Attachment(name, media, data, start - 9 if top else -1)
            elif op == CHUNK:
                try:
                    inner = _chunk(_Fields(buf, start, stop))
                except _BadRecord as exc:
                    if not top:
                        raise
                    yield BadChunk(f"the chunk at byte {start - 9}: {exc}", start - 9)
                    continue
                for record in _records(inner, 0, len(inner), False, wanted):
                    yield record
                    if isinstance(record, Damage):
                        return
            elif op in (DATA_END, FOOTER) and top:
                if op == DATA_END:
                    yield DataEnd(stop)
                return
        except _BadRecord as exc:
            yield Damage(f"the record at byte {start - 9}: {exc}")
            return


def _chunk(f: _Fields) -> bytes:
    f.take(16)
    size, crc = f.u64(), f.u32()
    compression = f.string()
    data = f.blob(f.u64())
    limit = min(MAX_CHUNK_BYTES, MAX_CHUNK_RATIO * len(data) + (1 << 20))
    if size > limit:
        raise _BadRecord(f"a chunk would decompress to {size} bytes from {len(data)} (more than "
                         f"tracecheck's limit of {limit} bytes for it)")
    try:
        if compression == "":
            out = bytes(data)
        elif compression == "zstd":
            out = unzstd(bytes(data), size, "a chunk")
        elif compression == "lz4":
            out = unlz4(bytes(data), size, "a chunk")
        else:
            raise _BadRecord(f"a chunk uses the unknown compression {compression!r}")
    except ImportError:
        raise _BadRecord(f"a chunk is {compression}-compressed and the {_PACKAGES[compression]} "
                         f"package is not installed (pip install {_PACKAGES[compression]})"
                         ) from None
    except ValueError as exc:
        raise _BadRecord(str(exc)) from None
    if len(out) != size:
        raise _BadRecord(f"a chunk decompresses to {len(out)} bytes, not the {size} it declares")
    if crc and zlib.crc32(out) != crc:
        raise _BadRecord("a chunk's checksum does not match its contents")
    return out


_FOOTER = struct.Struct("<BQQQI")
ATTACHMENT_INDEX = 10


def indexed_attachments(buf, media_type: str, also: str = ""
                        ) -> Optional[tuple[list[tuple[int, int]], int, array]]:
    """From the file's summary: (offset, size) of each attachment record of ``media_type``,
    in the order of the file, the greatest offset of any other attachment (-1: none), and
    the offset and size of each attachment of the media type ``also``, one after the other
    (as listed: 16 bytes each, not objects — a campaign has 10^5 of them); or None — where
    the file has no footer or summary, or anything in them does not fit (a reader then walks
    the records instead)."""
    end = len(buf) - 8
    if end < 8 + _FOOTER.size or bytes(buf[end:]) != MAGIC:
        return None
    op, length, summary_start, offsets_start, _ = _FOOTER.unpack_from(buf, end - _FOOTER.size)
    footer = end - _FOOTER.size
    if op != FOOTER or length != 20 or not 8 <= summary_start <= footer:
        return None
    found, other, more = [], -1, array("q")
    wanted, also = media_type.encode(), also.encode()
    unpack = _REC.unpack_from
    try:
        at, stop_at = _group(buf, summary_start, offsets_start, footer, ATTACHMENT_INDEX)
        forgotten = at
        while at + 9 <= stop_at:
            if at - forgotten > _FORGET_EVERY:  # a campaign's index is megabytes: let the
                forget(buf)                     # pages read so far go
                forgotten = at
            op, length = unpack(buf, at)
            start, stop = at + 9, at + 9 + length
            if stop > stop_at:
                return None
            if op == ATTACHMENT_INDEX:
                f = _Fields(buf, start, stop)
                offset, size = f.u64(), f.u64()
                f.take(24)
                f.take(f.u32())  # the name
                n = f.u32()
                if offset < 8 or offset + size > summary_start:
                    return None
                media = buf[f.take(n):f.at]
                if media == wanted:
                    found.append((offset, size))
                else:
                    other = max(other, offset)
                    if media == also:
                        more += array("q", (offset, size))
            at = stop
    except (_BadRecord, struct.error):
        return None
    return sorted(found), other, more


def summary_listing(buf, data_end: int) -> Optional[tuple[int, list[tuple[int, str, str]]]]:
    """Where the file's footer says its summary starts, and (offset, name, media type) of
    each attachment the summary lists, in the order of offsets — the summary read from
    ``data_end``, where the data section ends (a summary always starts there: a footer that
    says otherwise is itself a sign that bytes were cut out or put in). None where there is
    no summary to read: no footer (a killed recording), a footer naming none, or records
    there that do not read."""
    end = len(buf) - 8
    if end < data_end + _FOOTER.size or bytes(buf[end:]) != MAGIC:
        return None
    footer = end - _FOOTER.size
    op, length, summary_start, _, _ = _FOOTER.unpack_from(buf, footer)
    if op != FOOTER or length != 20 or not summary_start:
        return None
    listed, at = [], data_end
    try:
        while at < footer:
            op, length = _REC.unpack_from(buf, at)
            start, at = at + 9, at + 9 + length
            if at > footer:
                return None
            if op == ATTACHMENT_INDEX:
                f = _Fields(buf, start, at)
                offset = f.u64()
                f.take(32)  # its length, log and create time, data size
                listed.append((offset, f.string(), f.string()))
    except (_BadRecord, struct.error):
        return None
    return summary_start, sorted(listed)


#: a scan of the summary lets the pages it read go every this many bytes
_FORGET_EVERY = 1 << 22
SUMMARY_OFFSET = 14


def _group(buf, summary_start: int, offsets_start: int, footer: int, opcode: int
           ) -> tuple[int, int]:
    """Where the summary's records of ``opcode`` lie, as the file's summary offsets say
    (only where they fit the summary); else the whole summary."""
    has_offsets = summary_start < offsets_start <= footer
    end = offsets_start if has_offsets else footer  # the summary's records end here
    at = offsets_start if has_offsets else footer
    while at + 9 + 17 <= footer:
        op, length = _REC.unpack_from(buf, at)
        if op != SUMMARY_OFFSET or length != 17:
            break
        group, start, size = struct.unpack_from("<BQQ", buf, at + 9)
        if group == opcode and summary_start <= start and start + size <= end:
            return start, start + size
        at += 9 + length
    return summary_start, end


def forget(buf) -> None:
    """Let the pages of a mapped file read so far leave this process (they stay in the
    page cache): what a reader of a large file keeps is then what it decoded."""
    if isinstance(buf, mmap.mmap) and hasattr(mmap, "MADV_DONTNEED"):
        buf.madvise(mmap.MADV_DONTNEED)


def attachment_at(buf, offset: int, size: int, media_type: str) -> Optional[bytes]:
    """The data of the attachment record at ``offset`` (``size`` bytes long, as the summary
    lists it), or None where no such record of ``media_type`` lies there."""
    end = offset + size  # each field read only within the record (a reader checks 10^5)
    try:
        op, length = _REC.unpack_from(buf, offset)
        if op != ATTACHMENT or 9 + length != size or end > len(buf):
            return None
        at = offset + 9 + 16  # past its log and create time
        at += 4 + _U32.unpack_from(buf, at)[0]  # its name
        n = _U32.unpack_from(buf, at)[0] if at + 4 <= end else -1
        if not 0 <= n <= end - at - 12 or buf[at + 4:at + 4 + n] != media_type.encode():
            return None
        at += 4 + n
        n = _U64.unpack_from(buf, at)[0]
        return buf[at + 8:at + 8 + n] if n <= end - at - 8 else None
    except struct.error:
        return None


def attachment_name(buf, offset: int) -> str:
    """The name of the attachment record at ``offset`` ("?" where none reads there)."""
    try:
        op, length = _REC.unpack_from(buf, offset)
        if op != ATTACHMENT or offset + 9 + length > len(buf):
            return "?"
        f = _Fields(buf, offset + 9, offset + 9 + length)
        f.take(16)
        return f.string()
    except (_BadRecord, struct.error):
        return "?"
