"""Writing runs safely, by the output rule (:mod:`tracecheck.outputs`): never over an input,
an existing file only with ``force``, through an exclusively created temporary file that is
renamed into place only when there is something to keep, so that an existing file is never
lost to a run that failed or was interrupted early."""

from __future__ import annotations

import os
from collections import deque
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Optional, Sequence

from ..errors import InputError
from ..outputs import atomic_temp, check_output, open_new, temp_file
from .writer import (ChannelsFactory, EncodeContext, EncodedEpisode, EpisodeWriter,
                     actions_after, clock_after)
from .model import Episode, EpisodeDigest
from .schema import RunHeaderMessage

__all__ = ["write_run", "recording_into", "record_episodes", "prepared_episodes",
           "check_run_output"]

_NO_FOLLOW = getattr(os, "O_NOFOLLOW", 0)


def check_run_output(path: str | Path, inputs: Sequence[Path] = (), *,
                     force: bool = False) -> Path:
    """The output rule for a run file: not an input, not a folder, an existing file only
    with ``force``."""
    return check_output(Path(path), inputs, force=force, example="run.mcap")


#: episodes being encoded elsewhere at once, per worker that encodes (a recording's and a
#: simulation's; an import's pool, this many in all), before the writer waits for the
#: oldest: waiting for it while 8 in all were, each of two workers sat idle a sixth of a
#: grid-world recording, for the writer's next call
AHEAD = 64


def write_run(path: str | Path, header: RunHeaderMessage, episodes: Iterable[Episode], *,
              channels: Optional[ChannelsFactory] = None, force: bool = False,
              inputs: Sequence[Path] = (),
              encode: Optional[Callable[[Episode, EncodeContext], Any]] = None
              ) -> tuple[int, int, int]:
    """Write ``episodes`` to ``path``; (episodes, steps, crashes) written; ``channels`` adds
    a plug-in's channels (Foxglove's: ``interop/foxglove.py``); ``encode``: the episodes
    are encoded elsewhere (see :func:`prepared_episodes`).

    ``path`` must not be one of ``inputs``, and an existing ``path`` is replaced only with
    ``force``. An error while producing the episodes (a bad input file, say) leaves any
    existing ``path`` untouched and no partial file behind.
    """
    path = check_run_output(path, inputs, force=force)
    counts = [0, 0, 0]
    with atomic_temp(path) as (stream, part):
        with EpisodeWriter(part, header, channels, stream=stream, name=path) as out:
            for episode, prepared in prepared_episodes(out, episodes, encode):
                out.write(episode, prepared)
                counts[0] += 1
                counts[1] += episode.end.steps
                counts[2] += episode.end.crashed
    return counts[0], counts[1], counts[2]


def _lock(path: Path) -> Path:
    """Create ``NAME.lock`` beside ``path`` (never through a link); a second writer fails."""
    lock = path.with_name(path.name + ".lock")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY | _NO_FOLLOW, 0o666))
    except FileExistsError:
        raise InputError(f"another tracecheck is writing {path} (its lock file {lock} exists); "
                         "remove the lock file if no other run is going on") from None
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None
    return lock


@contextmanager
def recording_into(path: str | Path, header: RunHeaderMessage, *, force: bool = False,
                   channels: Optional[ChannelsFactory] = None,
                   inputs: Sequence[Path] = ()) -> Iterator[EpisodeWriter]:
    """An :class:`EpisodeWriter` for a recording into ``path``; ``channels`` adds a plug-in's
    channels (none by default: tracecheck's own channels only; the CLI's ``record`` and
    ``simulate`` give Foxglove's, ``tracecheck.interop.foxglove.FoxgloveChannels``).

    ``path`` follows the output rule (not an input; an existing one only with ``force``); a
    lock file (``NAME.lock``) makes a second writer of the same path fail at once. A new file
    is written in place, created exclusively (each finished episode can be read while the
    recording goes on); one that replaces a file goes to a temporary file beside it, which
    replaces ``path`` once at least one episode is complete — also when the recording is
    interrupted — and is removed otherwise, so the old file stays. A new file that an error
    or an interrupt leaves without a complete episode is removed.
    """
    path = Path(path)
    lock = _lock(path)
    try:
        check_run_output(path, inputs, force=force)
        replacing = os.path.lexists(path)
        stream, part = temp_file(path) if replacing else (open_new(path), path)
    except BaseException:
        lock.unlink(missing_ok=True)
        raise
    writer = EpisodeWriter(part, header, channels, stream=stream, name=path)
    finished = False
    try:
        with stream, writer:
            yield writer
        finished = True
    finally:
        try:
            if replacing and writer.episodes > 0:
                os.replace(part, path)
            elif replacing:
                part.unlink(missing_ok=True)
            elif not finished and writer.episodes == 0:  # an error before any episode: a
                path.unlink(missing_ok=True)  # new file with none would look like a run
        finally:
            lock.unlink(missing_ok=True)


@contextmanager
def whole_episode() -> Iterator[None]:
    """Ctrl-C (SIGINT) and SIGTERM while an episode is written take effect once it is: the
    file then ends with that episode complete, never with a part of one (which every later
    read would report as damaged). Only in the main thread, where signals are handled."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list = []
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    for s in saved:
        signal.signal(s, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)
    if caught:
        raise KeyboardInterrupt


def record_episodes(path: str | Path, header: RunHeaderMessage, episodes: Iterable[Episode],
                    progress: Optional[Callable[[Episode | EpisodeDigest], None]] = None, *,
                    force: bool = False, channels: Optional[ChannelsFactory] = None,
                    inputs: Sequence[Path] = (),
                    encode: Optional[Callable[[Episode, EncodeContext], Any]] = None,
                    ahead: int = AHEAD) -> tuple[int, int, int]:
    """Write ``episodes`` into ``path`` as they come (:func:`recording_into`: an interrupted
    or failed recording keeps every finished episode); (episodes, steps, crashes).

    ``encode(episode, context)``: where episodes are encoded elsewhere (a recording's
    workers), a handle whose ``get()`` gives the
    :func:`~tracecheck.episodes.writer.encode_episode` of the episode for the context it
    will be written in; the writer then only appends it — the same file as when it encodes
    the episodes itself; ``ahead``: how many are being encoded at once (see
    :func:`prepared_episodes`)."""
    counts = [0, 0, 0]
    with recording_into(path, header, force=force, channels=channels,
                        inputs=inputs) as writer:
        stream = prepared_episodes(writer, episodes, encode, ahead)
        for episode, prepared in stream:
            with whole_episode():
                writer.write(episode, prepared)
            counts[0] += 1
            counts[1] += episode.end.steps
            counts[2] += episode.end.crashed
            if progress is not None:
                progress(episode)
    return counts[0], counts[1], counts[2]


def _ready(handle) -> bool:
    ready = getattr(handle, "ready", None)
    return ready is not None and ready()


def prepared_episodes(writer: EpisodeWriter, episodes: Iterable[Episode], encode=None,
                      ahead: int = AHEAD
                      ) -> Iterator[tuple[Episode, Optional[EncodedEpisode]]]:
    """Each episode, in order, with what to give ``writer.write``: encoded by ``encode``
    (``encode(episode, context)``: a handle whose ``get()`` gives it, made elsewhere) for
    the context it will be written in — each episode's from the one before: its start time
    (:func:`clock_after`) and the action names (:func:`actions_after`); None without
    ``encode`` (the writer encodes it). Each is given as soon as its encoding has come (a
    handle's ``ready()``, where it has one), and at most ``ahead`` are being encoded at
    once (:data:`AHEAD` times the workers that encode): beyond that the oldest is waited
    for."""
    if encode is None:
        yield from ((episode, None) for episode in episodes)
        return
    context = writer.context()
    waiting: deque = deque()
    source = iter(episodes)
    while True:
        try:
            episode = next(source)
        except StopIteration:
            break
        except Exception:  # an episode failed (its environment raised): those before it,
            while waiting:  # which came back and are being encoded, are written first
                done, handle = waiting.popleft()
                try:
                    encoded = handle.get()
                except Exception:  # noqa: BLE001 - the first error is the one to say
                    break
                yield done, encoded
            raise
        waiting.append((episode, encode(episode, context)))
        context = replace(context, clock_ns=clock_after(context.clock_ns, episode),
                          actions=actions_after(context.actions, episode))
        while waiting and (len(waiting) > ahead or _ready(waiting[0][1])):
            done, handle = waiting.popleft()
            yield done, handle.get()
    while waiting:
        done, handle = waiting.popleft()
        yield done, handle.get()
