"""Where episodes are recorded: in local worker processes, or as tasks on a Ray cluster.

Both executors yield the episodes of a recording in order (episode i has seed S + i), so the
same agent, shield and seeds give the same file whichever runs them. On Ray each task is a
batch of consecutive episodes (:func:`batch_size`: one episode for a short recording, up to 64
for a campaign of 10^5 short ones, where a task per episode would cost more than the episode);
a worker killed mid-task makes Ray run the task again from its seeds (up to three times), and
episodes are written once each, in order, as they come back.
"""

from __future__ import annotations

from typing import Iterator, Optional

from ..checking.executors import start_ray
from ..episodes.model import Episode
from ..processes import in_order

__all__ = ["ray_episodes", "batch_size", "batches", "in_order", "IN_FLIGHT"]

_SESSION = None

#: tasks (of either executor) started and not yet written, per CPU: enough to keep the workers
#: busy, few enough that episodes waiting to be written do not fill the memory
IN_FLIGHT = 2


def batches(episodes: int, size: int) -> Iterator[tuple[int, int]]:
    """(first episode, count) of each task of ``size`` episodes (the last one the rest)."""
    return ((first, min(size, episodes - first)) for first in range(0, episodes, size))


def batch_size(episodes: int, workers: int) -> int:
    """Episodes per Ray task: about 32 tasks per worker at least (so the workers stay busy to
    the end), at most 64 episodes in one."""
    return max(1, min(64, episodes // (32 * max(workers, 1))))


def _ray_episodes(settings, first: int, count: int, shield_ref: list, sha256: str
                  ) -> list[Episode]:
    """Runs on a Ray worker: episodes ``first`` to ``first + count - 1``."""
    return [_ray_episode(settings, i, shield_ref, sha256) for i in range(first, first + count)]


def _ray_episode(settings, index: int, shield_ref: list, sha256: str) -> Episode:
    """Runs on a Ray worker: one episode, with the worker's cached agent, shield and env.
    The shield comes as itself (``[ref]`` of the object :func:`ray_episodes` put: pickled as
    its machine's text, its sha256 checked), fetched only when this worker has no session
    for these settings and this shield yet."""
    global _SESSION
    import ray

    from .rollout import Session

    if _SESSION is None or _SESSION.settings != settings or _SESSION.shield.sha256 != sha256:
        _SESSION = Session(settings, shield=ray.get(shield_ref[0]))
    return _SESSION.episode(index)


def ray_episodes(settings, address: Optional[str] = None, *, shield) -> Iterator[Episode]:
    """The episodes of ``settings`` under ``shield`` (sent to the workers itself, never
    ``settings.shield`` to load again) from Ray tasks, in order, as they finish."""
    ray, started = start_ray(address, settings.workers)
    try:
        remote = ray.remote(max_retries=3)(_ray_episodes)
        ref = [ray.put(shield)]  # in a list: a worker fetches it only when it needs it
        size = batch_size(settings.episodes, settings.workers)
        cpus = max(settings.workers, int(ray.cluster_resources().get("CPU", 0)))
        for batch in in_order(lambda job: remote.remote(settings, *job, ref, shield.sha256),
                              batches(settings.episodes, size), IN_FLIGHT * cpus, ray.get):
            yield from batch
    finally:
        if started:
            ray.shutdown()
