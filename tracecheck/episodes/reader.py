"""Reading tracecheck MCAP files: :func:`read_run` reads a whole file, :func:`read_episodes`
iterates its episodes, :func:`read_header` gives its run header. A damaged tail yields the
complete episodes and a :class:`DamagedFileWarning` that says what was lost.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Iterator, Optional

from mcap.records import Attachment, Channel, Footer, Message, Schema
from mcap.stream_reader import StreamReader
from pydantic import ValidationError

from ..errors import InputError, TracecheckError
from . import schema as S
from .codec import COLUMNS_MEDIA_TYPE, decode_state
from .model import Episode, EpisodeEnd, StepRecord

__all__ = ["read_run", "read_episodes", "read_header", "Run", "DamagedFileWarning"]


class DamagedFileWarning(UserWarning):
    """A file whose tail is damaged: the complete episodes were read, the rest was lost."""


@dataclass
class Run:
    """A whole file: its header and complete episodes (and what could not be read)."""

    path: str
    header: Optional[S.RunHeader]
    episodes: list[Episode] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def records(path: Path, stream: IO[bytes]) -> Iterator[Any]:
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
        yield Damage(f"{type(exc).__name__}: {exc}")


@dataclass
class Damage:
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


def open_run(path: str | Path) -> tuple[Path, IO[bytes]]:
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
    path, stream = open_run(path)
    with stream:
        asm = _Assembler(path, only)
        count = 0
        for record in records(path, stream):
            if isinstance(record, Damage):
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
    path, stream = open_run(path)
    with stream:
        asm = _Assembler(path)
        for record in records(path, stream):
            if isinstance(record, Damage):
                break
            asm.feed(record)
            if asm.header is not None:
                return asm.header
    raise InputError(f"{path} is an MCAP file but not a tracecheck run (no /tracecheck/run "
                     "header)")
