"""tracecheck's own MCAP writer, over mcap's public record classes: one chunk per episode,
ended when the episode is (:meth:`McapOut.end_chunk`), and the summary's indexes kept as the
bytes they are written as (a campaign of 10^5 episodes held about 90 MB of index objects).

It writes what ``mcap.writer.Writer`` writes with tracecheck's settings — chunks compressed
with zstd (or no chunks), chunk, attachment and metadata indexes, no message index,
statistics, repeated schemas and channels, summary offsets, a summary CRC — byte for byte (a
test compares them), without reaching into that class's private state.
"""

from __future__ import annotations

import struct
import zlib
from collections import defaultdict
from dataclasses import dataclass
from typing import BinaryIO, Optional

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (Attachment, AttachmentIndex, Channel, Chunk, ChunkIndex, DataEnd,
                          Footer, Header, Schema, Statistics, SummaryOffset)

from .frames import zstd

__all__ = ["McapOut", "MAGIC", "MessageBuffer", "Messages"]

#: the 8 bytes an MCAP file starts and ends with
MAGIC = struct.pack("<8B", 137, 77, 67, 65, 80, 48, 13, 10)
#: a message record's opcode, length, channel, sequence, log and publish times (then data)
_MESSAGE = struct.Struct("<BQHIQQ")
_pack_message = _MESSAGE.pack
_MESSAGE_OP = int(Opcode.MESSAGE)


class _Packed:
    """Index records kept as their bytes until the summary is written."""

    __slots__ = ("data",)

    def __init__(self) -> None:
        self.data = bytearray()

    def add(self, record) -> None:
        builder = RecordBuilder()
        record.write(builder)
        self.data += builder.end()


@dataclass(frozen=True)
class Messages:
    """One chunk's messages made ready away from the file (:class:`MessageBuffer`): their
    records, or compressed as a chunk's data, and what the file's statistics and index need."""

    records: bytes  # the message records (empty when ``compressed`` holds them)
    compressed: Optional[bytes]  # zstd of the records (a chunked file), else None
    size: int  # the records' length
    crc: int  # CRC-32 of the records
    start: int  # the least and greatest log time
    end: int
    counts: tuple[tuple[int, int], ...]  # (channel id, messages) in the order first seen
    count: int


class MessageBuffer:
    """Message records gathered as :meth:`McapOut.add_message` writes them, anywhere (a
    recording's workers), then made :class:`Messages` by :meth:`finish`, which
    :meth:`McapOut.add_messages` writes: the same bytes as message by message."""

    def __init__(self) -> None:
        self._parts: list[bytes] = []  # each record's head and data, joined when finished
        self._counts: dict[int, int] = {}
        self._start = self._end = 0
        self._count = 0

    def add(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
            sequence: int = 0) -> None:
        if type(data) is not bytes:  # kept until finish: a buffer changed later is not
            data = bytes(memoryview(data))  # what was added (and a number is no buffer)
        parts = self._parts  # (a few messages per step of a recording: kept lean)
        parts.append(_pack_message(_MESSAGE_OP, 22 + len(data), channel_id, sequence,
                                   log_time, publish_time))
        parts.append(data)
        counts = self._counts
        counts[channel_id] = counts.get(channel_id, 0) + 1
        if self._count == 0 or log_time < self._start:
            self._start = log_time
        if log_time > self._end:
            self._end = log_time
        self._count += 1

    def finish(self, compress: bool) -> Messages:
        """The messages so far (compressed with zstd for a chunked file)."""
        raw = b"".join(self._parts)
        return Messages(b"" if compress else raw, zstd(raw) if compress else None,
                        len(raw), zlib.crc32(raw), self._start, self._end,
                        tuple(self._counts.items()), self._count)


class McapOut:
    """An MCAP writer for run files (see the module docstring).

    Args:
        stream: where the file is written (binary, with ``tell``).
        chunked: put messages in zstd-compressed chunks (else each message is a record).
    """

    def __init__(self, stream: BinaryIO, *, chunked: bool = True) -> None:
        self._stream = stream
        self._chunked = chunked
        self._out = RecordBuilder()
        self._chunk = RecordBuilder()
        self._chunk_messages = 0
        self._chunk_start = self._chunk_end = 0
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._chunk_indexes = _Packed()
        self._attachment_indexes = _Packed()
        self._statistics = Statistics(
            attachment_count=0, channel_count=0, channel_message_counts=defaultdict(int),
            chunk_count=0, message_count=0, metadata_count=0, message_start_time=0,
            message_end_time=0, schema_count=0)

    # -- the data section
    def start(self, profile: str, library: str) -> None:
        """Write the magic and the header record."""
        self._stream.write(MAGIC)
        Header(profile, library).write(self._out)
        self._flush()

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """A new schema (written into the current chunk); its id."""
        schema = Schema(id=len(self._schemas) + 1, data=data, encoding=encoding, name=name)
        self._schemas[schema.id] = schema
        self._statistics.schema_count += 1
        schema.write(self._chunk if self._chunked else self._out)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: Optional[dict[str, str]] = None) -> int:
        """A new channel (written into the current chunk); its id."""
        channel = Channel(id=len(self._channels) + 1, topic=topic,
                          message_encoding=message_encoding, schema_id=schema_id,
                          metadata=dict(metadata or {}))
        self._channels[channel.id] = channel
        self._statistics.channel_count += 1
        channel.write(self._chunk if self._chunked else self._out)
        return channel.id

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        """A message, into the current chunk."""
        stats = self._statistics
        if stats.message_count == 0:
            stats.message_start_time = log_time
        else:
            stats.message_start_time = min(log_time, stats.message_start_time)
        stats.message_end_time = max(log_time, stats.message_end_time)
        stats.channel_message_counts[channel_id] += 1
        stats.message_count += 1
        # the record as mcap's Message.write writes it, packed at once (a recording writes
        # tens of thousands a second)
        record = _MESSAGE.pack(Opcode.MESSAGE, 22 + len(data), channel_id, sequence, log_time,
                               publish_time)
        if not self._chunked:
            self._out.write(record)
            self._out.write(data)
            self._flush()
            return
        if self._chunk_messages == 0:
            self._chunk_start = log_time
        else:
            self._chunk_start = min(self._chunk_start, log_time)
        self._chunk_end = max(self._chunk_end, log_time)
        self._chunk_messages += 1
        self._chunk.write(record)
        self._chunk.write(data)

    def add_messages(self, messages: Messages) -> None:
        """Messages made ready elsewhere (:class:`MessageBuffer`): written as
        :meth:`add_message` would write them one by one, then :meth:`end_chunk`."""
        if not messages.count:
            return
        stats = self._statistics
        stats.message_start_time = messages.start if stats.message_count == 0 else \
            min(stats.message_start_time, messages.start)
        stats.message_end_time = max(stats.message_end_time, messages.end)
        for channel, n in messages.counts:
            stats.channel_message_counts[channel] += n
        stats.message_count += messages.count
        if not self._chunked:
            self._out.write(messages.records)
            self._flush()
            return
        if self._chunk_messages or self._chunk.count or messages.compressed is None:
            raise ValueError("messages made ready for a chunk of their own")
        self._write_chunk(messages.compressed, messages.size, messages.crc, messages.start,
                          messages.end)

    def add_attachment(self, create_time: int, log_time: int, name: str, media_type: str,
                       data: bytes) -> None:
        """An attachment record (after the chunk before it), indexed."""
        self._flush()
        offset = self._stream.tell()
        self._statistics.attachment_count += 1
        Attachment(create_time=create_time, log_time=log_time, name=name,
                   media_type=media_type, data=data).write(self._out)
        self._attachment_indexes.add(AttachmentIndex(
            offset=offset, length=self._out.count, create_time=create_time,
            log_time=log_time, data_size=len(data), name=name, media_type=media_type))
        self._flush()

    def end_chunk(self) -> None:
        """Compress and write the chunk of messages so far (none: nothing), and flush the
        stream: an episode is on disk when it ends."""
        self._finish_chunk()
        self._flush()
        self._stream.flush()

    def _finish_chunk(self) -> None:
        if not self._chunked or self._chunk_messages == 0:
            return
        raw = self._chunk.end()
        self._write_chunk(zstd(raw), len(raw), zlib.crc32(raw), self._chunk_start,
                          self._chunk_end)
        self._chunk_messages = 0
        self._chunk_start = self._chunk_end = 0

    def _write_chunk(self, compressed: bytes, size: int, crc: int, start_time: int,
                     end_time: int) -> None:
        self._statistics.chunk_count += 1
        chunk = Chunk(compression="zstd", data=compressed, message_start_time=start_time,
                      message_end_time=end_time, uncompressed_crc=crc, uncompressed_size=size)
        self._flush()
        start = self._stream.tell()
        chunk.write(self._out)
        length = self._out.count
        self._flush()
        self._chunk_indexes.add(ChunkIndex(
            message_start_time=chunk.message_start_time,
            message_end_time=chunk.message_end_time, chunk_start_offset=start,
            chunk_length=length, message_index_offsets={}, message_index_length=0,
            compression="zstd", compressed_size=len(compressed), uncompressed_size=size))

    def _flush(self) -> None:
        self._stream.write(self._out.end())

    # -- the summary
    def finish(self) -> None:
        """The last chunk, the data end, the summary (schemas, channels, statistics, chunk,
        attachment and metadata indexes, their offsets), the footer and the magic."""
        self._finish_chunk()
        DataEnd(0).write(self._out)
        self._flush()
        start = self._stream.tell()
        summary = RecordBuilder()
        offsets: list[SummaryOffset] = []

        def group(opcode: int, write) -> None:
            begin = summary.count
            write()
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=start + begin,
                                         group_length=summary.count - begin))

        group(Opcode.SCHEMA, lambda: [s.write(summary) for s in self._schemas.values()])
        group(Opcode.CHANNEL, lambda: [c.write(summary) for c in self._channels.values()])
        group(Opcode.STATISTICS, lambda: self._statistics.write(summary))
        group(Opcode.CHUNK_INDEX, lambda: summary.write(self._chunk_indexes.data))
        group(Opcode.ATTACHMENT_INDEX,
              lambda: summary.write(self._attachment_indexes.data))
        group(Opcode.METADATA_INDEX, lambda: None)
        offset_start = start + summary.count
        for offset in offsets:
            offset.write(summary)
        data = summary.end()
        crc = zlib.crc32(data)
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 8 + 8 + 4,
                                     0 if not data else start, offset_start), crc)
        self._stream.write(data)
        Footer(summary_start=0 if not data else start, summary_offset_start=offset_start,
               summary_crc=crc).write(self._out)
        self._flush()
        self._stream.write(MAGIC)
