"""Where episodes run: in local worker processes, or as tasks on a Ray cluster.

Both executors yield the episodes of a recording in order (episode i has seed S + i), so the
same agent, shield and seeds give the same file whichever runs them. On Ray each episode is a
task; a worker killed mid-episode makes Ray run the task again from its seed (up to three
times), and episodes are written once each, in order, as they come back.
"""

from __future__ import annotations

import os
from typing import Iterator, Optional

from ..episodes.model import Episode
from ..errors import InputError

__all__ = ["ray_episodes", "EXECUTORS"]

EXECUTORS = ("local", "ray")
_SESSION = None


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


def _start_ray(address: Optional[str], cpus: int):
    try:
        import ray
    except ImportError:
        raise InputError("the ray executor needs Ray: pip install 'tracecheck[ray]'") from None
    if ray.is_initialized():
        return ray, False
    os.environ.setdefault("RAY_DEDUP_LOGS", "0")
    try:
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(address="local", num_cpus=cpus, include_dashboard=False,
                     log_to_driver=False, _node_ip_address="127.0.0.1")
    except Exception as exc:  # noqa: BLE001 - Ray fails in many ways; say which address
        where = address or "a local instance"
        raise InputError(f"cannot start or reach Ray at {where}: {exc}") from None
    return ray, True


def ray_episodes(settings, address: Optional[str] = None, *, shield) -> Iterator[Episode]:
    """The episodes of ``settings`` under ``shield`` (sent to the workers itself, never
    ``settings.shield`` to load again) from Ray tasks, in order, as they finish."""
    ray, started = _start_ray(address, settings.workers)
    try:
        remote = ray.remote(max_retries=3)(_ray_episode)
        ref = [ray.put(shield)]  # in a list: a worker fetches it only when it needs it
        pending = {remote.remote(settings, i, ref, shield.sha256): i
                   for i in range(settings.episodes)}
        ready: dict[int, Episode] = {}
        following = 0
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                ready[pending.pop(ref)] = ray.get(ref)
            while following in ready:
                yield ready.pop(following)
                following += 1
    finally:
        if started:
            ray.shutdown()


def _in_task(fn, salvage: bool, *job):
    """``fn(*job)`` in a task, reading files the way the caller does (``--salvage``)."""
    from ..episodes.salvage import salvaging

    with salvaging(salvage):
        return fn(*job)


def map_files(fn, jobs: list[tuple], executor: str = "local",
              address: Optional[str] = None, cpus: int = 2) -> list:
    """``fn(*job)`` for each job (one per file), locally or as Ray tasks; results in order."""
    if executor not in EXECUTORS:
        raise InputError(f"unknown executor {executor!r}; the executors are "
                         f"{', '.join(EXECUTORS)}")
    if executor == "local" or len(jobs) <= 1 and address is None:
        return [fn(*job) for job in jobs]
    from ..episodes.salvage import salvage_on

    ray, started = _start_ray(address, cpus)
    try:
        remote = ray.remote(max_retries=3)(_in_task)
        return ray.get([remote.remote(fn, salvage_on(), *job) for job in jobs])
    finally:
        if started:
            ray.shutdown()
