"""Trace files read in worker processes (``tracecheck import simb|prob2trace --workers N``):
each file parsed, converted and checked in a worker, the episodes coming back in the files'
order with the ids one process gives them, and each encoded for the run file there too (the
one writer only appends it: :func:`tracecheck.episodes.files.prepared_episodes`). The file
is the same as one process writes, byte for byte apart from the time it was written.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Optional, Sequence

from ..episodes.model import Episode
from ..episodes.writer import encode_episode
from ..processes import in_order, quiet_worker, worker_pool

__all__ = ["read_in_workers"]

#: files a worker reads per task
CHUNK = 8

_READ: Optional[tuple] = None  # a worker's (read, vocabulary, machine)


def _init(read: Callable, vocab, machine) -> None:
    global _READ
    quiet_worker()
    _READ = (read, vocab, machine)


def _some(jobs: list[tuple[str, int]]) -> list[Episode]:
    read, vocab, machine = _READ
    return [read(Path(path), episode_id, vocab, machine) for path, episode_id in jobs]


def _encode(episode: Episode, context):  # sent by this name: the worker's own encoder runs
    return encode_episode(episode, context)


@contextmanager
def read_in_workers(read: Callable, files: Sequence[Path], vocab, machine=None, *,
                    workers: int = 1, first_id: int = 0):
    """(episodes, encode): the episodes of ``files`` (``read(path, episode_id, vocab,
    machine)`` each, ids from ``first_id`` in order) and, with workers, how they encode
    each (None: the writer encodes). With one worker, all in this process."""
    if workers <= 1:
        yield (read(Path(f), first_id + k, vocab, machine) for k, f in enumerate(files)), None
        return
    pool = worker_pool(workers, _init, (read, vocab, machine))
    try:
        jobs = [(str(f), first_id + k) for k, f in enumerate(files)]

        def encode(episode: Episode, context):
            return pool.apply_async(_encode, (episode, context))
        # CHUNK files a task, at most two tasks a worker ahead of the writer: memory stays flat
        chunks = [jobs[k:k + CHUNK] for k in range(0, len(jobs), CHUNK)]
        read_ = in_order(lambda chunk: pool.apply_async(_some, (chunk,)), chunks,
                         2 * workers, lambda handle: handle.get())
        yield (episode for chunk in read_ for episode in chunk), encode
    finally:
        pool.terminate()
        pool.join()
