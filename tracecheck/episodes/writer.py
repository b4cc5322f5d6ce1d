"""Writing tracecheck MCAP files.

:class:`EpisodeWriter` writes each episode completely (header, steps, columns, end record)
and flushes it to the operating system before the next one starts, so a run that is killed
leaves a file whose finished episodes all read back. The messages of each episode are one
MCAP chunk compressed with zstd (MCAP's own chunk compression, which every MCAP reader
decompresses), closed before the episode's columns attachment: readable by any MCAP tool, and
readable by tracecheck even when its tail is missing.

More channels beside tracecheck's own come from a plug-in (:class:`StepChannels`), made for
the run's header by whoever records: the CLI hands the writer Foxglove's
(:class:`tracecheck.interop.foxglove.FoxgloveChannels`).
"""

from __future__ import annotations

import datetime as _dt
import time as _time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Callable, Iterable, Optional, Protocol

from pydantic import ValidationError

from .. import __version__
from ..b.columns import Columns
from ..errors import InputError, TracecheckError
from . import schema
from .mcap_out import McapOut, MessageBuffer, Messages
from .blobs import BLOCK_ROWS
from .codec import COLUMNS_MEDIA_TYPE, encode_columns, encode_state
from .model import Episode, EpisodeDigest
from .reader import why_unreadable
from .step_json import step_json

__all__ = ["EpisodeWriter", "new_header", "StepChannels", "ChannelsFactory", "EncodeContext",
           "EncodedEpisode", "encode_episode", "actions_after", "clock_after"]

_NS = 1_000_000_000
#: what a step message carries when its StepRecord has it (the same names in both)
_OPTIONAL_KEYS = ("observation", "action_values", "preferred_action", "allowed_actions",
                  "shield_time_us", "deadlock", "shield_problem", "parameters", "proposal", "projection_distance",
                  "allowed_intervals")
_GAP_S = 1.0  # seconds of file time between two episodes


class StepChannels(Protocol):
    """Channels a writer adds beside tracecheck's own, one batch of messages per step (not
    in the episode's checksum: tracecheck never reads them; the run blob's checksum of the
    file's bytes covers them)."""

    #: schemas by name, registered in this order: JSON schemas, or serialized protobuf
    #: ``FileDescriptorSet``s for the names in ``schema_encodings``
    schemas: dict[str, bytes]
    #: the schemas that are not JSON schemas: name -> "protobuf" (their messages protobuf)
    schema_encodings: dict[str, str]
    #: topic → the name of its schema, channels registered in this order
    topics: dict[str, str]

    def messages(self, step, *, episode: int, stamp_ns: int,
                 previous_crashed: bool) -> Iterable[tuple[str, bytes]]:
        """(topic, message in its schema's encoding) for one step (a ``StepRecord``) at
        ``stamp_ns``."""
        ...


#: makes the plug-in for a run from its header (e.g. the ``FoxgloveChannels`` class)
ChannelsFactory = Callable[["schema.RunHeaderMessage"], StepChannels]


def clock_after(clock_ns: int, episode: Episode | EpisodeDigest) -> int:
    """The file time the episode after ``episode`` starts at, ``episode`` starting at
    ``clock_ns`` (its last step, then a gap)."""
    return clock_ns + int(round((episode.last_time + _GAP_S) * _NS))


def actions_after(actions: Iterable[str], episode: Episode | EpisodeDigest) -> tuple[str, ...]:
    """The run's action names once ``episode`` is written: ``actions``, then those its steps
    take and score that are new, in the order they first appear (the columns' action axis)."""
    out = list(actions)
    out += [name for name in episode.action_names if name not in out]
    return tuple(out)


@dataclass(frozen=True)
class EncodeContext:
    """What encoding an episode for a file depends on besides the episode: when it starts,
    the file's channels, the action names so far, the run header's CRC, whether messages
    are chunked, and the file's name (for messages)."""

    clock_ns: int
    channels: tuple[tuple[str, int], ...]
    actions: tuple[str, ...]
    run_crc: int
    compress: bool
    name: str


@dataclass(frozen=True)
class EncodedEpisode:
    """An episode made ready for the file (:func:`encode_episode`): its messages (one chunk)
    and its columns attachment, for ``context``."""

    context: EncodeContext
    messages: Messages
    blob: bytes
    actions: tuple[str, ...]  # the run's action names after it
    #: why the episode would read back damaged (the writer's own check; None: it would not)
    damage: Optional[str] = None


def encode_episode(ep: Episode, context: EncodeContext,
                   extra: Optional[StepChannels] = None) -> EncodedEpisode:
    """Everything :class:`EpisodeWriter` writes for ``ep`` but the file positions: its
    header, step and end messages with the plug-in's after each step, compressed as its
    chunk, and its columns attachment — made anywhere (a recording's workers encode the
    episodes the one writer appends)."""
    channels = dict(context.channels)
    buffer = MessageBuffer()
    crc = 0
    clock = context.clock_ns

    def emit(name: str, data: bytes, at_s: float) -> None:
        nonlocal crc
        crc = zlib.crc32(data, crc)
        t = clock + int(round(at_s * _NS))
        buffer.add(channels[name], t, data, t)

    search = None if ep.search is None else schema.SearchPointMessage(
        repetition=ep.search.repetition, evaluation=ep.search.evaluation,
        parameters=dict(ep.search.parameters), objective=ep.search.objective,
        violated=ep.search.violated, optimizer=ep.search.optimizer,
        attribution=ep.search.attribution, attribution_step=ep.search.attribution_step,
        attribution_detail=ep.search.attribution_detail)
    header = schema.EpisodeHeaderMessage(
        episode=ep.id, seed=ep.seed, origin=ep.origin, search=search,
        environment_config=dict(ep.config) if ep.config is not None else None,
        reset_options=dict(ep.reset_options) if ep.reset_options is not None else None)
    head = header.model_dump_json(exclude_none=True).encode()
    emit("tracecheck.EpisodeHeader", head, 0.0)
    steps = ep.steps
    for k, s in enumerate(steps):
        try:
            state = encode_state(s.state)
        except TracecheckError as exc:
            raise InputError(f"{context.name}, episode {ep.id}, step {s.step}: {exc.message}",
                             hint=exc.hint) from None
        msg = {"episode": ep.id, "step": s.step, "time": s.time}
        if s.action is not None:
            msg["action"] = s.action
        msg["state"], msg["reward"], msg["crashed"] = state, s.reward, s.crashed
        for key in _OPTIONAL_KEYS:
            value = getattr(s, key)
            if value is not None:
                msg[key] = value
        try:
            data = step_json(msg)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(map(str, first["loc"]))
            raise InputError(f"{context.name}, episode {ep.id}, step {s.step}: "
                             f"{where + ': ' if where else ''}{first['msg']}") from None
        emit("tracecheck.Step", data, s.time)
        if extra is not None:  # the plug-in's channels, right after the step message (not
            t = clock + int(round(s.time * _NS))  # in the CRC: tracecheck's messages only)
            for topic, payload in extra.messages(
                    s, episode=ep.id, stamp_ns=t,
                    previous_crashed=k > 0 and steps[k - 1].crashed):
                buffer.add(channels[topic], t, payload, t)
    last = steps[-1].time
    end = schema.EpisodeEndMessage(episode=ep.id, steps=ep.end.steps, crashed=ep.end.crashed,
                                   total_reward=ep.end.total_reward, reason=ep.end.reason)
    tail = end.model_dump_json().encode()
    emit("tracecheck.EpisodeEnd", tail, last)
    actions = actions_after(context.actions, ep)
    cols = Columns.from_states([s.state for s in steps])
    blob = encode_columns(ep.id, [s.time for s in steps], [s.action for s in steps],
                          [s.reward for s in steps], [s.crashed for s in steps],
                          cols, list(actions), [s.action_values for s in steps],
                          seed=ep.seed, checksums={"messages_crc": crc,
                                                   "run_crc": context.run_crc},
                          parameters=[s.parameters for s in steps],
                          proposals=[s.proposal for s in steps],
                          distances=[s.projection_distance for s in steps],
                          reason=ep.end.reason)
    damage = why_unreadable(head, data, tail, len(steps), blob, crc, context.run_crc)
    return EncodedEpisode(context, buffer.finish(context.compress), blob, actions, damage)


def new_header(source: str, **fields: Any) -> schema.RunHeaderMessage:
    """A run header stamped with this tracecheck version and the current time.

    Args:
        source: how the run came to be (``recorded``, ``imported-simb``, …).
        fields: the header's other fields (environment, variables, actions, shield, …).

    Returns:
        The header message (:class:`~tracecheck.episodes.schema.RunHeaderMessage`).

    >>> new_header("recorded", environment="corridor").environment
    'corridor'
    """
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    return schema.RunHeaderMessage(tracecheck_version=__version__, created=now, source=source,
                                   **fields)


class EpisodeWriter:
    """Writes a run to an MCAP file, one complete episode at a time.

    >>> with EpisodeWriter("run.mcap", new_header("recorded")) as out:  # doctest: +SKIP
    ...     out.write(episode)
    """

    def __init__(self, path: str | Path, header: schema.RunHeaderMessage,
                 channels: Optional[ChannelsFactory] = None, *,
                 stream: Optional[IO[bytes]] = None, name: Optional[str | Path] = None,
                 compress: bool = True, block_rows: Optional[int] = None) -> None:
        self.path = Path(path)  # the file on disk (read back for the CRCs of its blocks)
        self.name = str(name or path)  # … and how messages call it (the output's own name)
        self._given = stream  # a stream opened by the caller, which also closes it
        self._compress = compress  # False: no chunks, the layout of earlier files
        self.header = header
        self._make_channels = channels  # more channels (Foxglove's: interop/foxglove.py)
        self._extra: Optional[StepChannels] = None
        self.episodes = 0
        self._stream: Optional[IO[bytes]] = None
        self._writer: Optional[McapOut] = None
        self._channels: dict[str, int] = {}
        self._clock_ns = 0
        self._actions = list(header.actions)
        self._crc = 0  # CRC-32 of the messages of the episode being written
        #: per episode of the open block: its records' bytes in the file
        self._spans: list[tuple[int, int]] = []
        self._blocked: list[bytes] = []  # … and its columns attachment
        self._head_end: Optional[int] = None  # where the first episode starts
        self._spanned = 0  # the episodes in blocks so far, the open one's too
        self._run_crc = 0  # … and of the run header
        self._block_rows = block_rows or BLOCK_ROWS  # a run blob per block of this many states
        self._rows = 0  # the states of the open block's episodes so far
        self._blobs = True  # False once a block did not read back: no more blobs
        self._ids: set[int] = set()  # the episode ids so far (blobs only for unique ones)
        self._head_crc: Optional[int] = None

    # -- context
    def __enter__(self) -> "EpisodeWriter":
        self.open()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()

    def open(self) -> None:
        try:
            self._stream = self._given or open(self.path, "wb")
        except OSError as exc:
            raise InputError(f"cannot write {self.name}: {exc.strerror or exc}") from None
        # one chunk per episode, ended by _end_chunk; chunks and attachments indexed, not
        # each message (readers find an episode by its chunk)
        self._writer = McapOut(self._stream, chunked=self._compress)
        self._writer.start(profile="tracecheck", library=f"tracecheck {__version__}")
        for name in schema.MESSAGES:
            sid = self._writer.register_schema(name=name, encoding="jsonschema",
                                               data=schema.schema_json(name).encode())
            self._channels[name] = self._writer.register_channel(
                topic=schema.TOPICS[name], message_encoding="json", schema_id=sid)
        if self._make_channels is not None:
            self._register_extra(self._make_channels(self.header))
        self._clock_ns = _time.time_ns()
        self._crc = 0
        self._emit("tracecheck.RunHeader", self.header.model_dump_json().encode(), 0.0)
        self._run_crc = self._crc
        self._end_chunk()
        self._flush()

    def _register_extra(self, extra: StepChannels) -> None:
        encodings = {name: getattr(extra, "schema_encodings", {}).get(name, "jsonschema")
                     for name in extra.schemas}
        if set(encodings.values()) - {"jsonschema", "protobuf"}:
            raise TracecheckError(f"unknown schema encodings: {sorted(encodings.values())}")
        ids = {name: self._writer.register_schema(name=name, encoding=encodings[name],
                                                  data=data)
               for name, data in extra.schemas.items()}
        for topic, name in extra.topics.items():
            self._channels[topic] = self._writer.register_channel(
                topic=topic, schema_id=ids[name],
                message_encoding="protobuf" if encodings[name] == "protobuf" else "json")
        self._extra = extra

    def close(self) -> None:
        """Write the summary (index and statistics) and close the file."""
        if self._writer is None:
            return
        try:
            self._close_block()
            self._writer.finish()
        except OSError:
            pass  # disk full or gone: the episodes flushed so far stay readable
        finally:
            self._writer = None
            if self._stream is not None and self._stream is not self._given:
                self._stream.close()
            self._stream = None

    def _close_block(self) -> None:
        """The episodes since the last blob in one columns blob — their columns attachments
        joined as a reader walking them joins them — with the CRC-32 of each episode's
        records and of the file's head: a reader takes the block from it at once (see
        :mod:`tracecheck.episodes.blobs`)."""
        spans, self._spans, self._rows = self._spans, [], 0
        blocked, self._blocked = self._blocked, []
        if not spans or not self._blobs:
            return
        import warnings

        from .codec import RUN_COLUMNS_MEDIA_TYPE, encode_run_columns
        from .columns import written_columns
        from .records import mapped

        self._stream.flush()
        head_end = self._head_end
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                run = written_columns(self.path, blocked)
        except TracecheckError:
            run = None
        if run is None or len(run.episode_ids) != len(spans) or run.warnings:
            self._blobs = False  # the file reads as it is, walked from here on
            return
        with mapped(self.path) as buf:
            view = memoryview(buf)
            try:
                crcs = [zlib.crc32(view[a:b]) for a, b in spans]
                if self._head_crc is None:
                    self._head_crc = zlib.crc32(view[:head_end])
            finally:
                view.release()
        blob = encode_run_columns(run, spans, crcs, self._head_crc, head_end)
        self._writer.add_attachment(create_time=self._clock_ns, log_time=self._clock_ns,
                                    name=f"run-{self._spanned}.columns",
                                    media_type=RUN_COLUMNS_MEDIA_TYPE, data=blob)

    # -- writing
    def _emit(self, name: str, data: bytes, at_s: float) -> None:
        self._crc = zlib.crc32(data, self._crc)
        t = self._clock_ns + int(round(at_s * _NS))
        self._writer.add_message(channel_id=self._channels[name], log_time=t, publish_time=t,
                                 data=data)

    def _flush(self) -> None:
        self._stream.flush()

    def _end_chunk(self) -> None:
        """Compress and write the chunk of messages so far, and flush it: an episode is on
        disk when it ends."""
        if self._compress:
            self._writer.end_chunk()

    def context(self) -> EncodeContext:
        """What the next episode is encoded for (:func:`encode_episode`)."""
        return EncodeContext(self._clock_ns, tuple(self._channels.items()), tuple(self._actions),
                             self._run_crc, self._compress, self.name)

    def write(self, episode: Episode | EpisodeDigest,
              prepared: Optional[EncodedEpisode] = None) -> None:
        """Write ``episode`` completely, then flush it to disk (``prepared``: the episode
        encoded ahead, elsewhere: used where it was made for this writer's next episode, as
        :meth:`context` says, else made again here — the same bytes either way; an
        :class:`~tracecheck.episodes.model.EpisodeDigest` only with what was made for it)."""
        if self._writer is None:
            raise TracecheckError("the EpisodeWriter is closed")
        context = self.context()
        if prepared is None or prepared.context != context:
            if not isinstance(episode, Episode):
                raise TracecheckError(f"episode {episode.id} came without its steps and was "
                                      "not encoded for this point of the file")
            prepared = encode_episode(episode, context, self._extra)
        try:
            self._write(episode, prepared)
            self._flush()
        except OSError as exc:
            raise InputError(f"cannot write episode {episode.id} to {self.name}: "
                             f"{exc.strerror or exc}") from None
        self.episodes += 1

    def _write(self, ep: Episode | EpisodeDigest, encoded: EncodedEpisode) -> None:
        start = self._stream.tell()
        self._writer.add_messages(encoded.messages)
        self._end_chunk()  # before the attachment, which the writer puts straight in the file
        # the columns come last: an attachment in the file means its episode is complete
        self._actions = list(encoded.actions)
        t = self._clock_ns + int(round(ep.last_time * _NS))
        self._writer.add_attachment(create_time=t, log_time=t,
                                    name=f"episode-{ep.id}.columns",
                                    media_type=COLUMNS_MEDIA_TYPE, data=encoded.blob)
        self._clock_ns = clock_after(self._clock_ns, ep)
        self._spans.append((start, self._stream.tell()))  # header … columns attachment
        self._blocked.append(encoded.blob)
        if encoded.damage is not None:
            self._blobs = False  # it reads back damaged: the reader walks the file, and says so
        self._spanned += 1
        if self._head_end is None:
            self._head_end = start
        if ep.id in self._ids:
            self._blobs = False  # the reader walks the file, and names the id used twice
        self._ids.add(ep.id)
        self._rows += ep.end.steps + 1
        if self._rows >= self._block_rows:
            self._close_block()
