"""Reading tracecheck MCAP files: :func:`read_run` reads a whole file, :func:`read_episodes`
iterates its episodes, :func:`read_header` gives its run header, and :func:`read_pieces` the
checked pieces both of them and :func:`tracecheck.episodes.read_columns` are built from.

Nothing in a file is trusted before it is checked. An episode counts only once its header,
step messages, end record and columns attachment are all in the file and agree with each
other (episode id, number of steps, crash flag, last action, seed; every step when the steps
are decoded): so ``info``, ``replay``, ``render`` and ``export`` see the same episodes. An
episode that does not agree is an error naming the file and episode — or, when salvaging
(``salvage=True``, the ``--salvage`` option), a :class:`SalvagedEpisodeWarning` and the episode left
out. A damaged tail yields the complete episodes and a :class:`DamagedEpisode` that says
what was lost.
"""

from __future__ import annotations

import math
import warnings
import zlib
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Iterator, Optional

import numpy as np
import orjson
from pydantic import ValidationError

from ..errors import DamagedEpisode, InputError, SalvagedEpisodeWarning, TracecheckError
from . import schema
from .codec import COLUMNS_MEDIA_TYPE, decode_columns, decode_state
from .model import Episode, EpisodeEnd, SearchPoint, StepRecord
from .column_checks import check_columns
from .listing import CUT_HINT, Holdings
from .records import (Attachment, BadChunk, Channel, Damage, DataEnd, MessageRef, Schema,
                      mapped, walk)

__all__ = ["read_run", "find_episode", "read_episodes", "read_header", "Run", "read_pieces", "Piece",
           "search_point", "search_points", "why_unreadable"]


@dataclass
class Run:
    """A whole file: its header and complete episodes (and what could not be read)."""

    path: str
    header: Optional[schema.RunHeaderMessage]
    episodes: list[Episode] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


@dataclass
class Piece:
    """One complete, checked episode of a file: its messages and its decoded columns
    (``steps`` holds ``None`` for steps that were not decoded)."""

    head: schema.EpisodeHeaderMessage
    steps: list
    count: int = 0
    crc: int = 0  # CRC-32 of its messages so far
    last: Optional[tuple] = None  # (buffer, start, end) of the last step message's data
    end: Optional[schema.EpisodeEndMessage] = None
    columns: Optional[tuple[dict, dict[str, np.ndarray]]] = None

    @property
    def episode(self) -> Episode:
        end, head = self.end, self.head
        search = search_point(head)
        return Episode(id=head.episode, seed=head.seed, origin=head.origin,
                       steps=tuple(self.steps),
                       end=EpisodeEnd(end.steps, end.crashed, end.total_reward, end.reason),
                       config=head.environment_config, search=search,
                       reset_options=head.reset_options)


def search_point(head: schema.EpisodeHeaderMessage) -> Optional[SearchPoint]:
    """The search point an episode header holds (a ``falsify`` run's), if any."""
    point = head.search
    return None if point is None else SearchPoint(
        point.repetition, point.evaluation, dict(point.parameters), point.objective,
        point.violated, point.optimizer, point.attribution, point.attribution_step,
        point.attribution_detail)


def search_points(path: str | Path, *, salvage: bool = False
                  ) -> list[tuple[int, Optional[SearchPoint]]]:
    """(episode id, its search point or None) of each complete episode of ``path``, in
    order, read from the episode headers alone (no step is decoded)."""
    with warnings.catch_warnings(record=True):  # a damaged tail: the complete ones
        warnings.simplefilter("always", DamagedEpisode)
        return [(int(p.head.episode), search_point(p.head))
                for p in read_pieces(path, decode=False, salvage=salvage)]


class _BadEpisode(Exception):
    """One episode is damaged (the message says how)."""


def _where(path: Path, episode=None, step=None) -> str:
    parts = [str(path)]
    if episode is not None:
        parts.append(f"episode {episode}")
    if step is not None:
        parts.append(f"step {step}")
    return ", ".join(parts) + ": "


def _parse(name: str, data: bytes):
    try:
        return schema.MESSAGES[name].model_validate_json(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        loc = ".".join(str(p) for p in first["loc"])
        raise _BadEpisode(f"bad {name} message: {loc}: {first['msg']}") from None


#: the bytes of an MCAP Message record before its data: channel id (2), sequence (4), log
#: time (8), publish time (8) — the MCAP specification's layout
MESSAGE_FIELDS = 2 + 4 + 8 + 8


class EpisodeDamage(Enum):
    """Why the episode being assembled is damaged (its remaining messages are skipped)."""

    STRAY = "a message outside any episode"
    REUSED_ID = "an episode id used twice"
    BAD_MESSAGE = "a message that does not check"
    LOST_CHUNK = "the chunk of its messages is damaged"


class _Assembler:
    """Builds checked pieces from records; raises (or, salvaging, warns) per bad episode."""

    def __init__(self, path: Path, only: Optional[set[int]], decode: bool,
                 salvage: bool) -> None:
        self.path = path
        self.only = only
        self.decode = decode
        self.salvage = salvage
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, str] = {}
        self.header: Optional[schema.RunHeaderMessage] = None
        self.current: Optional[Piece] = None
        #: why the current episode is damaged (salvaging: the rest of it is skipped)
        self.broken: Optional[EpisodeDamage] = None
        self.count = 0
        self.seen: set[int] = set()
        self.run_crc = 0
        self.bad_chunk: Optional[str] = None  # why the chunk of the current episode is lost

    # -- errors
    def bad(self, why: str, episode=None, step=None) -> None:
        if episode is None and self.current is not None:
            episode = self.current.head.episode
        if not self.salvage:
            raise InputError(f"{_where(self.path, episode, step)}{why}",
                             hint="--salvage leaves damaged episodes out with a warning")
        warnings.warn(f"{_where(self.path, episode, step)}{why}; the episode is left out",
                      SalvagedEpisodeWarning, stacklevel=4)

    # -- records
    def feed(self, record) -> Optional[Piece]:
        if type(record) is MessageRef:
            buf, start, stop = record
            name = self.channels.get(buf[start] | buf[start + 1] << 8)
            if name is not None:
                return self.message(name, buf, start + MESSAGE_FIELDS, stop)
        elif isinstance(record, Attachment):
            if record.media_type == COLUMNS_MEDIA_TYPE:
                return self.attachment(record.data)
        elif isinstance(record, Channel):
            name = self.schemas.get(record.schema_id, "")
            if name in schema.MESSAGES and schema.TOPICS[name] == record.topic:
                self.channels[record.id] = name
        elif isinstance(record, Schema):
            self.schemas[record.id] = record.name
        return None

    def message(self, name: str, buf, start: int, stop: int) -> Optional[Piece]:
        data = buf[start:stop]
        if self.current is not None:
            self.current.crc = zlib.crc32(data, self.current.crc)
        if name == "tracecheck.RunHeader":
            if self.header is not None:
                raise InputError(f"{self.path}: the file has a second run header")
            try:
                self.header = _parse(name, data)
            except _BadEpisode as exc:
                raise InputError(f"{self.path}: {exc}") from None
            self.run_crc = zlib.crc32(data)
            return None
        if self.header is None:
            raise InputError(f"{self.path} is not a tracecheck run (its first message is not "
                             "a /tracecheck/run header)")
        if name == "tracecheck.EpisodeHeader":
            self.start(data)
        elif self.current is None:  # a stray message: one warning, the rest of it ignored
            self.current = Piece(schema.EpisodeHeaderMessage(episode=-1), [])
            self.broken = EpisodeDamage.STRAY
            self.bad(f"a {name} message comes outside any episode", episode="?")
        elif self.broken is None:
            try:
                if name == "tracecheck.Step":
                    self.step(data)
                elif name == "tracecheck.EpisodeEnd":
                    self.finish(data)
            except _BadEpisode as exc:
                self.broken = EpisodeDamage.BAD_MESSAGE
                self.bad(str(exc))
        return None

    def start(self, data: bytes) -> None:
        self.chunk_lost()
        if self.current is not None and self.broken is None:
            self.bad("the episode ends without its " +
                     ("columns attachment" if self.current.end else "end record"))
        self.current, self.broken = None, None
        try:
            head = _parse("tracecheck.EpisodeHeader", data)
        except _BadEpisode as exc:
            self.broken = EpisodeDamage.BAD_MESSAGE
            self.current = Piece(schema.EpisodeHeaderMessage(episode=-1), [])
            self.bad(str(exc), episode="?")
            return
        self.current = Piece(head, [], crc=zlib.crc32(data))
        if head.episode in self.seen:
            self.broken = EpisodeDamage.REUSED_ID
            self.bad(f"the episode id {head.episode} is used twice",
                     )
        self.seen.add(head.episode)

    def wanted(self, piece: Optional[Piece] = None) -> bool:
        piece = piece or self.current
        return self.only is None or piece.head.episode in self.only

    def step(self, data: bytes) -> None:
        piece = self.current
        if piece.end is not None:
            raise _BadEpisode("a step message comes after the episode's end record")
        piece.count += 1
        piece.steps.append(self.step_record(data))

    def step_record(self, data: bytes) -> StepRecord:
        k = self.current.count - 1
        msg = _parse("tracecheck.Step", data)
        if msg.episode != self.current.head.episode or msg.step != k:
            raise _BadEpisode(f"step message {k} is step {msg.step} of episode {msg.episode}")
        try:
            state = decode_state(msg.state)
        except TracecheckError as exc:
            raise _BadEpisode(f"step {k}: {exc.message}") from None
        return StepRecord(
            step=msg.step, time=msg.time, action=msg.action, state=state, reward=msg.reward,
            crashed=msg.crashed,
            observation=tuple(tuple(r) for r in msg.observation) if msg.observation else None,
            action_values=msg.action_values, preferred_action=msg.preferred_action,
            allowed_actions=tuple(msg.allowed_actions) if msg.allowed_actions is not None
            else None, shield_time_us=msg.shield_time_us, deadlock=msg.deadlock,
            shield_problem=msg.shield_problem,
            parameters=msg.parameters, proposal=msg.proposal,
            projection_distance=msg.projection_distance,
            allowed_intervals=None if msg.allowed_intervals is None else {
                name: tuple(tuple(i) for i in intervals)
                for name, intervals in msg.allowed_intervals.items()})

    def finish(self, data: bytes) -> None:
        piece = self.current
        if piece.end is not None:
            raise _BadEpisode("the episode has two end records")
        end = _parse("tracecheck.EpisodeEnd", data)
        if end.episode != piece.head.episode:
            raise _BadEpisode(f"the end record belongs to episode {end.episode}")
        if not piece.count:
            raise _BadEpisode("the episode has no steps")
        piece.end = end

    def damaged_chunk(self, why: str) -> None:
        """A chunk (the messages of one episode) does not decompress or check: the episode
        it held is named by the columns attachment after it."""
        if self.header is None:
            raise InputError(f"{self.path}: the run header's chunk is damaged ({why})")
        self.chunk_lost()
        if self.current is not None and self.broken is None:
            self.bad("the episode ends without its "
                     + ("columns attachment" if self.current.end else "end record"))
        self.current = Piece(schema.EpisodeHeaderMessage(episode=-1), [])
        self.broken, self.bad_chunk = EpisodeDamage.LOST_CHUNK, why

    def chunk_lost(self, blob: Optional[bytes] = None) -> None:
        """Report the damaged chunk before this point, naming its episode where ``blob`` (its
        columns attachment) says which."""
        if self.bad_chunk is None:
            return
        why, self.bad_chunk = self.bad_chunk, None
        episode = "?"
        if blob is not None:
            try:
                episode = decode_columns(blob)[0]["episode"]
            except (InputError, KeyError, TypeError):
                pass
        self.bad(f"the chunk of the episode's messages is damaged ({why})", episode=episode)

    def attachment(self, blob: bytes) -> Optional[Piece]:
        self.chunk_lost(blob)
        piece, broken = self.current, self.broken
        if piece is None or piece.end is None:
            if broken is None:
                self.bad("a columns attachment comes before the episode's end record")
            return None
        self.current, self.broken = None, None
        self.count += 1
        if broken is not None or not self.wanted(piece):
            return None
        try:
            piece.columns = decode_columns(blob)
            _checksums(piece, self.run_crc)
            _agree(piece, self.decode)
        except (_BadEpisode, InputError) as exc:
            self.bad(exc.message if isinstance(exc, InputError) else str(exc),
                     episode=piece.head.episode)
            return None
        return piece

    def cut(self, why: Optional[str]) -> None:
        """The file's summary or run blobs say episodes are missing (see :mod:`.listing`)."""
        if why is not None and not self.salvage:
            raise InputError(f"{self.path}: {why}", hint=CUT_HINT)
        if why is not None:
            warnings.warn(f"{self.path}: {why}; only the episodes it holds are read",
                          SalvagedEpisodeWarning, stacklevel=4)

    def lost(self, why: str) -> str:
        partial = ""
        if self.current is not None and self.broken is None:
            partial = (f"; lost the unfinished episode {self.current.head.episode} "
                       f"({self.current.count} step message(s))")
        return (f"{self.path}: the file is damaged or ends early ({why}); read {self.count} "
                f"complete episode(s){partial}")


def _checksums(piece: Piece, run_crc: int) -> None:
    """The episode's messages and the run header are byte for byte what was written (files
    from before these checksums have none)."""
    header = piece.columns[0]
    if header.get("messages_crc", piece.crc) != piece.crc:
        raise _BadEpisode("its messages do not match the checksum its columns carry (the file was "
                          "damaged or edited)")
    if header.get("run_crc", run_crc) != run_crc:
        raise _BadEpisode("the run header does not match the checksum the episode's columns carry "
                          "(the file was damaged or edited)")


def _agree(piece: Piece, decoded: bool) -> None:
    """The columns of ``piece`` say what its messages say (raises :class:`_BadEpisode`)."""
    header, arrays = piece.columns
    check_columns(header, arrays)
    head, end = piece.head, piece.end
    if header.get("episode") != head.episode:
        raise _BadEpisode(f"its columns belong to episode {header.get('episode')!r}")
    rows = len(arrays["time"])
    if not rows == piece.count == end.steps + 1:
        raise _BadEpisode(f"the step messages ({piece.count}), end record ({end.steps} steps after "
                          f"the initial state) and columns ({rows} rows) disagree on its length")
    if header.get("seed") != head.seed:
        raise _BadEpisode(f"the columns say seed {header.get('seed')!r}, the episode header "
                          f"{head.seed!r}")
    if header.get("reason", end.reason) != end.reason:  # files before it have none
        raise _BadEpisode(f"the columns say it ended by {header.get('reason')!r}, the end "
                          f"record by {end.reason!r}")
    names = header["actions"]
    crashed = bool(arrays["crashed"][-1])
    if decoded:
        last = piece.steps[-1]
    else:
        last = _last_step(piece)
    last_action = names[arrays["action"][-1]] if arrays["action"][-1] >= 0 else None
    if not crashed == end.crashed == last.crashed:
        raise _BadEpisode(f"the columns, end record and last step disagree on whether it crashed "
                          f"({crashed}, {end.crashed}, {last.crashed})")
    if last.action != last_action:
        raise _BadEpisode(f"the last step's action is {last.action!r} in its message and "
                          f"{last_action!r} in the columns")
    continuous = any(name.startswith(_CONTINUOUS) for name in arrays)
    if not decoded and (continuous or last.continuous is not None):
        _same_parameters(arrays, rows - 1, last.continuous)
    if decoded:
        actions = [names[a] if a >= 0 else None for a in arrays["action"].tolist()]
        for k, s in enumerate(piece.steps):
            if (s.action != actions[k] or s.crashed != bool(arrays["crashed"][k])
                    or s.reward != float(arrays["reward"][k])
                    or s.time != float(arrays["time"][k])):
                raise _BadEpisode(f"step {k}: the step message and the columns disagree "
                                  "(action, reward, time or crash flag)")
            if continuous or s.parameters or s.proposal or s.projection_distance is not None:
                _same_parameters(arrays, k, s)


#: the column prefixes of continuous actions (see :func:`.codec.parameter_arrays`)
_CONTINUOUS = ("par:", "prop:", "dist")


def _same_parameters(arrays: dict, row: int, step) -> None:
    """Row ``row`` of the columns holds the parameter values, proposal and projection
    distance of ``step`` (a step message; None: one with none of them)."""
    def from_columns(prefix: str) -> dict:
        return {name[len(prefix):]: float(arr[row]) for name, arr in arrays.items()
                if name.startswith(prefix) and not math.isnan(arr[row])}

    dist = arrays.get("dist")
    dist = None if dist is None or math.isnan(dist[row]) else float(dist[row])
    got = (from_columns("par:"), from_columns("prop:"), dist)
    want = ({}, {}, None) if step is None else (
        dict(step.parameters or {}), dict(step.proposal or {}), step.projection_distance)
    if got != want:
        raise _BadEpisode(f"step {row}: the step message and the columns disagree on its "
                          "action's parameters, proposal or projection distance")


@dataclass(frozen=True)
class _Last:
    action: Optional[str]
    crashed: bool
    continuous: Optional[schema.StepMessage] = None  # the message, where it has parameters


def _last_step(piece: Piece) -> _Last:
    """The action and crash flag of the last step message (the rest is not needed)."""
    buf, a, b = piece.last
    try:
        msg = orjson.loads(buf[a:b])
    except orjson.JSONDecodeError as exc:
        raise _BadEpisode(f"step {piece.count - 1}: the step message is not JSON ({exc})") from None
    if not (isinstance(msg, dict) and msg.get("episode") == piece.head.episode
            and msg.get("step") == piece.count - 1 and type(msg.get("crashed")) is bool
            and (msg.get("action") is None or type(msg.get("action")) is str)):
        full = _parse("tracecheck.Step", buf[a:b])  # says what is wrong …
        raise _BadEpisode(f"step message {piece.count - 1} is step {full.step} of episode "
                          f"{full.episode}")  # … or this is
    if "parameters" in msg or "proposal" in msg or "projection_distance" in msg:
        return _Last(msg.get("action"), msg["crashed"], _parse("tracecheck.Step", buf[a:b]))
    return _Last(msg.get("action"), msg["crashed"])


def why_unreadable(header: bytes, last_step: bytes, end: bytes, steps: int, blob: bytes,
                   messages_crc: int, run_crc: int) -> Optional[str]:
    """Why an episode as a writer encodes it would read back damaged, or None: its episode
    header, last step and end messages, its number of steps, its columns attachment and the
    CRC-32 of its messages, checked as reading its file checks them (columns against
    messages, without decoding the steps) — the writer's check of what it writes."""
    try:
        head = _parse("tracecheck.EpisodeHeader", header)
        piece = Piece(head=head, steps=[], count=steps, crc=messages_crc,
                      last=(last_step, 0, len(last_step)),
                      end=_parse("tracecheck.EpisodeEnd", end), columns=decode_columns(blob))
        if piece.end.episode != head.episode:
            raise _BadEpisode(f"the end record belongs to episode {piece.end.episode}")
        _checksums(piece, run_crc)
        _agree(piece, decoded=False)
    except (_BadEpisode, TracecheckError) as exc:
        return str(exc)
    return None


def read_pieces(path: str | Path, only: Optional[set[int]] = None, *, decode: bool = True,
                salvage: bool = False, regions: Optional[list[tuple[int, int]]] = None
                ) -> Iterator[Piece]:
    """The complete, checked episodes of a file in order (those in ``only`` when given;
    ``decode=False``: step messages are counted, not decoded; ``regions``: only the records
    in these byte ranges, see :func:`~tracecheck.episodes.records.walk`).

    A damaged tail ends the iteration with a :class:`DamagedEpisode`; a file that is not
    a tracecheck run raises :class:`~tracecheck.errors.InputError`, and so does an episode
    whose parts disagree unless salvaging.
    """
    path = Path(path)
    with mapped(path) as buf:
        view = memoryview(buf)  # checksums over parts of the file without copying them
        try:
            yield from _pieces(path, buf, view, _Assembler(path, only, decode, salvage),
                               regions)
        finally:
            view.release()


def _pieces(path: Path, buf, view, asm: "_Assembler", regions=None) -> Iterator[Piece]:
    steps = -1  # the channel of step messages, once known
    held, data_end = Holdings(), None  # what the walk met, for the summary (whole files)
    # only tracecheck's own channels' messages: the others are nobody's here (feed passes
    # them over), and a recording's are mostly Foxglove's
    for record in walk(path, buf, regions, asm.channels):
        if type(record) is MessageRef:
            piece = asm.current
            data, start, end = record
            if (data[start] | data[start + 1] << 8 == steps
                    and piece is not None and piece.end is None and asm.broken is None
                    and not (asm.decode and asm.wanted())):
                # a step that is not decoded: counted, checksummed, the last one kept for
                # the cross-check (the hot loop of reading a file's columns)
                piece.count += 1
                piece.last = (data, start + MESSAGE_FIELDS, end)
                rec = view if data is buf else memoryview(data)
                piece.crc = zlib.crc32(rec[start + MESSAGE_FIELDS:end], piece.crc)
                continue
        elif isinstance(record, Damage):
            asm.chunk_lost()
            warnings.warn(asm.lost(record.why), DamagedEpisode, stacklevel=4)
            break
        elif isinstance(record, BadChunk):
            asm.damaged_chunk(record.why)
            continue
        elif isinstance(record, Attachment):
            held.met(record)
        elif type(record) is DataEnd:
            data_end = record.at
        piece = asm.feed(record)
        if steps < 0 and isinstance(record, Channel):
            steps = next((k for k, v in asm.channels.items() if v == "tracecheck.Step"), -1)
        if piece is not None:
            yield piece
    else:
        asm.chunk_lost()
        if asm.current is not None and asm.broken is None:
            warnings.warn(asm.lost("the last episode is not complete"), DamagedEpisode,
                          stacklevel=4)
    if asm.header is None:
        raise InputError(f"{path} is an MCAP file but not a tracecheck run (no "
                         "/tracecheck/run header)")
    if regions is None:
        asm.cut(held.problem(buf, data_end))


def read_episodes(path: str | Path, only: Optional[set[int]] = None, *,
                  salvage: bool = False) -> Iterator[Episode]:
    """The complete episodes of a file, in order (see :func:`read_pieces`).

    Args:
        path: a run file.
        only: the episode ids to decode (the step messages of the others are not decoded).
        salvage: leave out episodes whose parts disagree, with a warning.

    Returns:
        An iterator of :class:`~tracecheck.episodes.model.Episode`.

    >>> next(read_episodes("sample_traces/base_none.mcap")).id  # repo root
    0
    """
    for piece in read_pieces(path, only, salvage=salvage):
        yield piece.episode


def read_run(path: str | Path, only: Optional[set[int]] = None, *,
             salvage: bool = False) -> Run:
    """The header and all complete episodes of a file.

    Args:
        path: a run file.
        only: the episode ids to decode (None: all).
        salvage: leave out episodes whose parts disagree, with a warning, instead of
            refusing the file.

    Returns:
        A :class:`Run`: header, episodes, and the warnings (collected, not raised).

    >>> len(read_run("sample_traces/base_none.mcap", {0}).episodes)  # repo root
    1
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DamagedEpisode)
        episodes = list(read_episodes(path, only, salvage=salvage))
    header = read_header(path)
    return Run(str(path), header, episodes,
               [str(w.message) for w in caught if issubclass(w.category, DamagedEpisode)])


def find_episode(run: str | Path, result: Run, episode: int, salvage: bool = False
                 ) -> Episode:
    """Episode ``episode`` among those ``result`` decoded from ``run``, else the located
    error naming the episodes the file has (``salvage``: as :func:`read_run`, for reading
    their numbers)."""
    found = next((ep for ep in result.episodes if ep.id == episode), None)
    if found is not None:
        return found
    with warnings.catch_warnings(record=True):  # read_run gave them
        warnings.simplefilter("always", DamagedEpisode)
        ids = [int(p.head.episode) for p in read_pieces(run, decode=False, salvage=salvage)]
    if not ids:
        raise InputError(f"{run} holds no complete episode")
    raise InputError(f"{run} has no episode {episode}; it has {_ids_text(ids)}",
                     hint=result.warnings[0] if result.warnings else None)


def _ids_text(ids: list[int]) -> str:
    ids = sorted(ids)
    if len(ids) > 12:
        return f"{', '.join(map(str, ids[:12]))}, … ({len(ids)} episodes)"
    return ", ".join(map(str, ids))


def read_header(path: str | Path) -> schema.RunHeaderMessage:
    """The run header of a file (its first message).

    Args:
        path: a run file.

    Returns:
        The header: source, environment, variables, actions, shield, agent, …

    >>> read_header("sample_traces/base_none.mcap").source  # repo root
    'recorded'
    """
    path = Path(path)
    with mapped(path) as buf:
        asm = _Assembler(path, set(), False, True)
        for record in walk(path, buf):
            if isinstance(record, Damage):
                break
            asm.feed(record)
            if asm.header is not None:
                return asm.header
    raise InputError(f"{path} is an MCAP file but not a tracecheck run (no /tracecheck/run "
                     "header)")
