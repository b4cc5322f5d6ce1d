"""Write and read tracecheck MCAP files.

:class:`EpisodeWriter` writes each episode completely (header, steps, columns, end record)
and flushes it to the operating system before the next one starts, so a run that is killed
leaves a file whose finished episodes all read back. The file is MCAP without chunking:
readable by any MCAP tool, and readable by tracecheck even when its tail is missing.

:func:`read_run` reads a whole file, :func:`read_episodes` iterates its episodes, and
:func:`read_columns` gives the numpy columns of every state in a file (for replay and
statistics) without decoding a single step message.
"""

from __future__ import annotations

import datetime as _dt
import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Iterator, Optional

import numpy as np
from mcap.reader import SeekingReader
from mcap.records import Attachment, Channel, Footer, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from pydantic import ValidationError

from .. import __version__
from ..b.vector import Columns
from ..b.values import Elem
from ..errors import InputError, TracecheckError
from . import schema as S
from .codec import (COLUMNS_MEDIA_TYPE, columns_from_arrays, decode_columns, decode_state,
                    encode_columns, encode_state)
from .model import Episode, EpisodeEnd, StepRecord

__all__ = ["EpisodeWriter", "read_run", "read_episodes", "read_columns", "Run", "RunColumns",
           "DamagedFileWarning", "new_header"]

_NS = 1_000_000_000
_GAP_S = 1.0  # seconds of file time between two episodes


class DamagedFileWarning(UserWarning):
    """A file whose tail is damaged: the complete episodes were read, the rest was lost."""


def new_header(source: str, **fields: Any) -> S.RunHeader:
    """A run header stamped with this tracecheck version and the current time."""
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    return S.RunHeader(tracecheck_version=__version__, created=now, source=source, **fields)


class EpisodeWriter:
    """Writes a run to an MCAP file, one complete episode at a time.

    >>> with EpisodeWriter("run.mcap", new_header("recorded")) as out:  # doctest: +SKIP
    ...     out.write(episode)
    """

    def __init__(self, path: str | Path, header: S.RunHeader) -> None:
        self.path = Path(path)
        self.header = header
        self.episodes = 0
        self._stream: Optional[IO[bytes]] = None
        self._writer: Optional[Writer] = None
        self._channels: dict[str, int] = {}
        self._clock_ns = 0
        self._actions = list(header.actions)

    # -- context
    def __enter__(self) -> "EpisodeWriter":
        self.open()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()

    def open(self) -> None:
        try:
            self._stream = open(self.path, "wb")
        except OSError as exc:
            raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        self._writer = Writer(self._stream, use_chunking=False,
                              compression=CompressionType.NONE)
        self._writer.start(profile="tracecheck", library=f"tracecheck {__version__}")
        for name in S.MESSAGES:
            sid = self._writer.register_schema(name=name, encoding="jsonschema",
                                               data=S.schema_json(name).encode())
            self._channels[name] = self._writer.register_channel(
                topic=S.TOPICS[name], message_encoding="json", schema_id=sid)
        self._clock_ns = _time.time_ns()
        self._emit("tracecheck.RunHeader", self.header.model_dump_json().encode(), 0.0)
        self._flush()

    def close(self) -> None:
        """Write the summary (index and statistics) and close the file."""
        if self._writer is None:
            return
        try:
            self._writer.finish()
        except OSError:
            pass  # disk full or gone: the episodes flushed so far stay readable
        finally:
            self._writer = None
            if self._stream is not None:
                self._stream.close()
                self._stream = None

    # -- writing
    def _emit(self, name: str, data: bytes, at_s: float) -> None:
        t = self._clock_ns + int(round(at_s * _NS))
        self._writer.add_message(channel_id=self._channels[name], log_time=t, publish_time=t,
                                 data=data)

    def _flush(self) -> None:
        self._stream.flush()

    def write(self, episode: Episode) -> None:
        """Write ``episode`` completely, then flush it to disk."""
        if self._writer is None:
            raise TracecheckError("the EpisodeWriter is closed")
        for s in episode.steps:
            if s.action is not None and s.action not in self._actions:
                self._actions.append(s.action)
        try:
            self._write(episode)
            self._flush()
        except OSError as exc:
            raise InputError(f"cannot write episode {episode.id} to {self.path}: "
                             f"{exc.strerror or exc}") from None
        self.episodes += 1

    def _write(self, ep: Episode) -> None:
        header = S.EpisodeHeader(episode=ep.id, seed=ep.seed, origin=ep.origin)
        self._emit("tracecheck.EpisodeHeader", header.model_dump_json(exclude_none=True).encode(),
                   0.0)
        for s in ep.steps:
            msg = {"episode": ep.id, "step": s.step, "time": s.time, "action": s.action,
                   "state": encode_state(s.state), "reward": s.reward, "crashed": s.crashed}
            for key in ("observation", "action_values", "preferred_action", "allowed_actions",
                        "shield_time_us", "deadlock"):
                value = getattr(s, key)
                if value is not None:
                    msg[key] = value
            data = S.Step.model_validate(msg).model_dump_json(exclude_none=True).encode()
            self._emit("tracecheck.Step", data, s.time)
        last = ep.steps[-1].time
        end = S.EpisodeEnd(episode=ep.id, steps=ep.end.steps, crashed=ep.end.crashed,
                           total_reward=ep.end.total_reward, reason=ep.end.reason)
        self._emit("tracecheck.EpisodeEnd", end.model_dump_json().encode(), last)
        # the columns come last: an attachment in the file means its episode is complete
        cols = Columns.from_states([s.state for s in ep.steps])
        for s in ep.steps:
            for name in s.action_values or ():
                if name not in self._actions:
                    self._actions.append(name)
        blob = encode_columns(ep.id, [s.time for s in ep.steps], [s.action for s in ep.steps],
                              [s.reward for s in ep.steps], [s.crashed for s in ep.steps],
                              cols, self._actions, [s.action_values for s in ep.steps],
                              seed=ep.seed)
        t = self._clock_ns + int(round(last * _NS))
        self._writer.add_attachment(create_time=t, log_time=t,
                                    name=f"episode-{ep.id}.columns",
                                    media_type=COLUMNS_MEDIA_TYPE, data=blob)
        self._clock_ns += int(round((last + _GAP_S) * _NS))


# ------------------------------------------------------------------ reading


@dataclass
class Run:
    """A whole file: its header and complete episodes (and what could not be read)."""

    path: str
    header: Optional[S.RunHeader]
    episodes: list[Episode] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _records(path: Path, stream: IO[bytes]) -> Iterator[Any]:
    """The records of an MCAP file in order; stops with a warning where the tail is damaged."""
    magic = stream.read(8)
    if magic != b"\x89MCAP0\r\n":
        raise InputError(f"{path} is not an MCAP file (it does not start with the MCAP magic "
                         "bytes)")
    stream.seek(0)
    reader = StreamReader(stream, skip_magic=False, emit_chunks=False)
    try:
        for record in reader.records:
            yield record
            if isinstance(record, Footer):
                return
    except Exception as exc:  # noqa: BLE001 - a damaged tail breaks the reader in many ways
        yield _Damage(f"{type(exc).__name__}: {exc}")


@dataclass
class _Damage:
    why: str


class _Assembler:
    """Builds episodes from records, checking each message against its schema."""

    def __init__(self, path: Path, only: Optional[set[int]] = None) -> None:
        self.path = path
        self.only = only
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, str] = {}
        self.header: Optional[S.RunHeader] = None
        self.current: Optional[dict] = None
        self.columns: dict[int, bytes] = {}

    def where(self, episode: Optional[int] = None, step: Optional[int] = None) -> str:
        parts = [str(self.path)]
        if episode is not None:
            parts.append(f"episode {episode}")
        if step is not None:
            parts.append(f"step {step}")
        return ", ".join(parts) + ": "

    def parse(self, name: str, data: bytes, episode=None, step=None):
        try:
            return S.MESSAGES[name].model_validate_json(data)
        except ValidationError as exc:
            first = exc.errors()[0]
            loc = ".".join(str(p) for p in first["loc"])
            raise InputError(f"{self.where(episode, step)}bad {name} message: {loc}: "
                             f"{first['msg']}") from None

    def feed(self, record) -> Optional[Episode]:
        if isinstance(record, Schema):
            self.schemas[record.id] = record.name
        elif isinstance(record, Channel):
            self.channels[record.id] = self.schemas.get(record.schema_id, "")
        elif isinstance(record, Attachment) and record.media_type == COLUMNS_MEDIA_TYPE:
            if self.current is not None:
                self.current["columns"] = record.data
        elif isinstance(record, Message):
            return self.message(self.channels.get(record.channel_id), record.data)
        return None

    def message(self, name: Optional[str], data: bytes) -> Optional[Episode]:
        if name == "tracecheck.RunHeader":
            self.header = self.parse(name, data)
        elif name == "tracecheck.EpisodeHeader":
            head = self.parse(name, data)
            self.current = {"head": head, "steps": [], "columns": None}
        elif name == "tracecheck.Step":
            if self.current is None:
                raise InputError(f"{self.where()}a step message comes before any episode header")
            ep = self.current["head"].episode
            if self.only is not None and ep not in self.only:
                self.current["steps"].append(None)
                return None
            msg = self.parse(name, data, ep)
            if msg.episode != ep:
                raise InputError(f"{self.where(ep, msg.step)}step message of episode "
                                 f"{msg.episode} inside episode {ep}")
            self.current["steps"].append(self.step(msg, ep))
        elif name == "tracecheck.EpisodeEnd":
            if self.current is None:
                raise InputError(f"{self.where()}an episode end comes before its header")
            head = self.current["head"]
            end = self.parse(name, data, head.episode)
            steps = tuple(self.current["steps"])
            if not steps:
                raise InputError(f"{self.where(head.episode)}the episode has no steps")
            if self.only is not None and head.episode not in self.only:
                self.current = None
                return None
            episode = Episode(id=head.episode, seed=head.seed, origin=head.origin, steps=steps,
                              end=EpisodeEnd(end.steps, end.crashed, end.total_reward,
                                             end.reason))
            self.current = None
            return episode
        return None

    def step(self, msg: S.Step, ep: int) -> StepRecord:
        try:
            state = decode_state(msg.state)
        except TracecheckError as exc:
            raise InputError(f"{self.where(ep, msg.step)}{exc.message}") from None
        return StepRecord(
            step=msg.step, time=msg.time, action=msg.action, state=state, reward=msg.reward,
            crashed=msg.crashed,
            observation=tuple(tuple(r) for r in msg.observation) if msg.observation else None,
            action_values=msg.action_values, preferred_action=msg.preferred_action,
            allowed_actions=tuple(msg.allowed_actions) if msg.allowed_actions is not None
            else None, shield_time_us=msg.shield_time_us, deadlock=msg.deadlock)


def _open(path: str | Path) -> tuple[Path, IO[bytes]]:
    path = Path(path)
    try:
        return path, open(path, "rb")
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except IsADirectoryError:
        raise InputError(f"{path} is a folder, not an MCAP file") from None
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None


def _lost(path: Path, asm: _Assembler, count: int, why: str) -> str:
    partial = ""
    if asm.current is not None:
        head = asm.current["head"]
        partial = (f"; lost the unfinished episode {head.episode} "
                   f"({len(asm.current['steps'])} step message(s))")
    return (f"{path}: the file is damaged or ends early ({why}); read {count} complete "
            f"episode(s){partial}")


def read_episodes(path: str | Path, only: Optional[set[int]] = None) -> Iterator[Episode]:
    """The complete episodes of a file, in order (only those in ``only`` when given: the
    step messages of the others are not decoded).

    A damaged tail ends the iteration with a :class:`DamagedFileWarning` saying what was
    lost; a file that is not MCAP, or whose messages do not fit the schema, raises
    :class:`~tracecheck.errors.InputError` naming the file, episode and step.
    """
    path, stream = _open(path)
    with stream:
        asm = _Assembler(path, only)
        count = 0
        for record in _records(path, stream):
            if isinstance(record, _Damage):
                warnings.warn(_lost(path, asm, count, record.why), DamagedFileWarning,
                              stacklevel=2)
                return
            before = asm.current
            episode = asm.feed(record)
            if before is not None and asm.current is None:
                count += 1
            if episode is not None:
                yield episode
        if asm.header is None:
            raise InputError(f"{path} is an MCAP file but not a tracecheck run (no "
                             "/tracecheck/run header)")
        if asm.current is not None:
            warnings.warn(_lost(path, asm, count, "no end record for the last episode"),
                          DamagedFileWarning, stacklevel=2)


def read_run(path: str | Path, only: Optional[set[int]] = None) -> Run:
    """The header and all complete episodes of a file (or those in ``only``); warnings are
    collected, not raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DamagedFileWarning)
        episodes = list(read_episodes(path, only))
    header = read_header(path)
    return Run(str(path), header, episodes,
               [str(w.message) for w in caught if issubclass(w.category, DamagedFileWarning)])


def read_header(path: str | Path) -> Optional[S.RunHeader]:
    """The run header of a file (the first message)."""
    path, stream = _open(path)
    with stream:
        asm = _Assembler(path)
        for record in _records(path, stream):
            if isinstance(record, _Damage):
                break
            asm.feed(record)
            if asm.header is not None:
                return asm.header
    raise InputError(f"{path} is an MCAP file but not a tracecheck run (no /tracecheck/run "
                     "header)")


# ------------------------------------------------------------------ columns


@dataclass
class RunColumns:
    """Every state of a file as numpy columns, one row per state (step 0 included).

    ``episode[r]`` and ``step[r]`` say which state row ``r`` is; ``starts[i]`` is the first
    row of the i-th episode (``starts[-1]`` the number of rows). ``action[r]`` indexes
    ``action_names`` (-1 at step 0); ``states`` holds the B variables for
    :meth:`tracecheck.b.Machine.enabled_batch`.
    """

    path: str
    episode_ids: np.ndarray
    starts: np.ndarray
    episode: np.ndarray
    step: np.ndarray
    time: np.ndarray
    action: np.ndarray
    action_names: tuple[str, ...]
    reward: np.ndarray
    crashed: np.ndarray
    states: Columns
    warnings: list[str] = field(default_factory=list)
    values: Optional[np.ndarray] = None  # (rows, actions): the agent's values, NaN if none
    seeds: list[Optional[int]] = field(default_factory=list)  # per episode

    @property
    def n(self) -> int:
        return int(self.starts[-1])


def _column_blobs(path: Path) -> tuple[list[tuple[int, bytes]], list[str]]:
    """(episode id, columns blob) for each complete episode, using the index if there is one."""
    _, stream = _open(path)
    with stream:
        try:
            reader = SeekingReader(stream)
            summary = reader.get_summary()
        except Exception:  # noqa: BLE001 - no usable summary: read the records in order
            summary = None
        if summary is not None and summary.attachment_indexes is not None:
            return [(None, att.data) for att in reader.iter_attachments()
                    if att.media_type == COLUMNS_MEDIA_TYPE], []
    # linear scan: keep only episodes whose end record was read
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DamagedFileWarning)
        blobs = _scan_blobs(path)
    return blobs, [str(w.message) for w in caught]


def _scan_blobs(path: Path) -> list[tuple[Optional[int], bytes]]:
    """Column attachments in file order (each follows its episode's end record)."""
    path, stream = _open(path)
    blobs: list[tuple[Optional[int], bytes]] = []
    with stream:
        for record in _records(path, stream):
            if isinstance(record, _Damage):
                warnings.warn(f"{path}: the file is damaged or ends early ({record.why}); "
                              f"read {len(blobs)} complete episode(s)", DamagedFileWarning)
                break
            if isinstance(record, Attachment) and record.media_type == COLUMNS_MEDIA_TYPE:
                blobs.append((None, record.data))
    return blobs


def read_columns(path: str | Path) -> RunColumns:
    """All states of a file as numpy columns (see :class:`RunColumns`).

    Reads only the per-episode column attachments; a file with a damaged tail gives its
    complete episodes, with the loss described in ``warnings``.
    """
    path = Path(path)
    blobs, notes = _column_blobs(path)
    decoded = []
    for i, (_, blob) in enumerate(blobs):
        header, arrays = decode_columns(blob, where=f"{path}, columns attachment {i + 1}: ")
        decoded.append((header.get("episode", i), header, arrays))
    actions: list[str] = []
    elements: list[str] = []
    for _, header, _ in decoded:
        actions += [a for a in header["actions"] if a not in actions]
        elements += [e for e in header["elements"] if e not in elements]
    parts = []
    values = []
    literals: dict = {}
    for ep, header, arrays in decoded:
        order = [actions.index(a) for a in header["actions"]]
        remap = np.array(order + [-1], dtype=np.int16)
        cols = columns_from_arrays(header, arrays, literals)
        parts.append((ep, arrays, remap[arrays["action"]], _widen(cols, elements)))
        table = np.full((len(arrays["time"]), len(actions)), np.nan)
        if "values" in arrays:
            table[:, order] = arrays["values"]
        values.append(table)
    result = _concatenate(str(path), parts, tuple(actions), tuple(Elem(e) for e in elements),
                          notes)
    if any("values" in arrays for _, _, arrays in decoded):
        result.values = np.concatenate(values)
    result.seeds = [header.get("seed") for _, header, _ in decoded]
    return result


def _widen(cols: Columns, elements: list[str]) -> Columns:
    """``cols`` with its element axis in the order of ``elements`` (missing: undefined)."""
    if [str(e) for e in cols.elements] == elements:
        return cols
    where = [elements.index(str(e)) for e in cols.elements]
    k = len(elements)
    out = Columns(n=cols.n, elements=tuple(Elem(e) for e in elements),
                  numbers=cols.numbers, booleans=cols.booleans, others=cols.others)
    for name, (vals, defined) in cols.functions.items():
        v, d = np.zeros((cols.n, k)), np.zeros((cols.n, k), dtype=bool)
        v[:, where], d[:, where] = vals, defined
        out.functions[name] = (v, d)
    for name, mask in cols.masks.items():
        m = np.zeros((cols.n, k), dtype=bool)
        m[:, where] = mask
        out.masks[name] = m
    return out


def _concatenate(path: str, parts, actions, elements, notes) -> RunColumns:
    lengths = [len(arrays["time"]) for _, arrays, _, _ in parts]
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    n = int(starts[-1])
    ids = np.array([ep for ep, _, _, _ in parts], dtype=np.int64)

    def cat(key):
        return (np.concatenate([arrays[key] for _, arrays, _, _ in parts]) if parts
                else np.zeros(0))

    states = Columns(n=n, elements=elements)
    if parts:
        first = parts[0][3]
        for name in first.numbers:
            states.numbers[name] = np.concatenate([c.numbers[name] for *_, c in parts])
        for name in first.booleans:
            states.booleans[name] = np.concatenate([c.booleans[name] for *_, c in parts])
        for name in first.functions:
            states.functions[name] = (
                np.concatenate([c.functions[name][0] for *_, c in parts]),
                np.concatenate([c.functions[name][1] for *_, c in parts]))
        for name in first.masks:
            states.masks[name] = np.concatenate([c.masks[name] for *_, c in parts])
        for name in first.others:
            states.others[name] = [v for *_, c in parts for v in c.others[name]]
    episode = np.repeat(ids, lengths)
    step = np.concatenate([np.arange(m) for m in lengths]) if parts else np.zeros(0, np.int64)
    states.label = lambda i: f"{path}, episode {int(episode[i])}, step {int(step[i])}"
    return RunColumns(
        path=path, episode_ids=ids, starts=starts,
        episode=episode, step=step,
        time=cat("time"), action=np.concatenate([a for _, _, a, _ in parts]) if parts
        else np.zeros(0, dtype=np.int16), action_names=actions, reward=cat("reward"),
        crashed=cat("crashed").astype(bool), states=states, warnings=notes)
