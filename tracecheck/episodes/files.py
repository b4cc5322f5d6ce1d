"""Writing runs safely: into ``NAME.part``, renamed into place only when there is something to
keep, so that an existing file is never lost to a run that failed or was interrupted early."""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

from ..errors import InputError
from .writer import EpisodeWriter
from .model import Episode
from .schema import RunHeader

__all__ = ["write_run", "recording_into", "refuse_existing"]


def write_run(path: str | Path, header: RunHeader, episodes: Iterable[Episode], *,
              foxglove: bool = False) -> tuple[int, int, int]:
    """Write ``episodes`` to ``path``; (episodes, steps, crashes) written; ``foxglove`` adds
    Foxglove's channels (``interop/foxglove.py``).

    An error while producing the episodes (a bad input file, say) leaves any existing
    ``path`` untouched and no partial file behind.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"the output {path} is a folder; give a file name such as run.mcap")
    part = path.with_name(path.name + ".part")
    counts = [0, 0, 0]
    try:
        with EpisodeWriter(part, header, foxglove=foxglove) as out:
            for episode in episodes:
                out.write(episode)
                counts[0] += 1
                counts[1] += episode.end.steps
                counts[2] += episode.end.crashed
        os.replace(part, path)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    return counts[0], counts[1], counts[2]


def refuse_existing(path: Path, force: bool) -> None:
    """An existing recording is replaced only when the user says so (``--force``)."""
    if path.exists() and not force:
        raise InputError(f"{path} exists; give another name, or --force to replace it (it is "
                         "replaced only once a new episode is complete)")


@contextmanager
def recording_into(path: str | Path, header: RunHeader, *, force: bool = False,
                   foxglove: bool = True) -> Iterator[EpisodeWriter]:
    """An :class:`EpisodeWriter` for a recording into ``path`` (with Foxglove's channels
    unless ``foxglove`` is false).

    An existing ``path`` is refused unless ``force``; a lock file (``NAME.lock``) makes a
    second writer of the same path fail at once. A new file is written in place (each
    finished episode can be read while the recording goes on); one that replaces a file goes
    to ``NAME.part`` first, which replaces ``path`` once at least one episode is complete —
    also when the recording is interrupted — and is removed otherwise, so the old file stays.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"the output {path} is a folder; give a file name such as run.mcap")
    lock = path.with_name(path.name + ".lock")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        raise InputError(f"another tracecheck is writing {path} (its lock file {lock} exists); "
                         "remove the lock file if no other run is going on") from None
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None
    try:
        refuse_existing(path, force)
    except InputError:
        lock.unlink(missing_ok=True)
        raise
    replacing = path.exists()
    part = path.with_name(path.name + ".part") if replacing else path
    writer = EpisodeWriter(part, header, foxglove=foxglove)
    try:
        with writer:
            yield writer
    finally:
        try:
            if replacing and writer.episodes > 0:
                os.replace(part, path)
            elif replacing:
                part.unlink(missing_ok=True)
        finally:
            lock.unlink(missing_ok=True)
