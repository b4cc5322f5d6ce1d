"""Where files are checked: in this process, or one Ray task per file.

Replay, diff and statistics map a function over their run files with :func:`map_files`;
recording starts Ray the same way (:func:`start_ray`) for its episode tasks.
"""

from __future__ import annotations

import os
import pickle
from typing import Optional

from ..errors import InputError
from ..limits import deep_recursion

__all__ = ["map_files", "file_blocks", "start_ray", "EXECUTORS"]

EXECUTORS = ("local", "ray")


def start_ray(address: Optional[str], cpus: int):
    """(the ray module, whether this call started it): Ray at ``address``, or a local
    instance of ``cpus`` CPUs, unless one is running already."""
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


def _in_task(fn, job: bytes):
    """``fn(*job)`` in a Ray task: the job (its shields, formulas and property sets) is
    unpickled here, with the recursion limit a deeply nested formula needs."""
    with deep_recursion():
        return fn(*pickle.loads(job))


def file_blocks(paths, executor: str = "local") -> list[tuple[int, str, Optional[int]]]:
    """The units of work over run files: (index of the file, its path, block or None for
    the whole file). Locally a whole file each (read block by block all the same); on Ray
    each block of a file that has them (:func:`~tracecheck.episodes.columns.blocks_of`)."""
    from ..episodes.columns import blocks_of

    out = []
    for i, p in enumerate(paths):
        count = blocks_of(p) if executor != "local" else 0
        out += [(i, str(p), k) for k in range(count)] or [(i, str(p), None)]
    return out


def map_files(fn, jobs: list[tuple], executor: str = "local",
              address: Optional[str] = None, cpus: int = 2) -> list:
    """``fn(*job)`` for each job (one per file), locally or as Ray tasks; results in order."""
    if executor not in EXECUTORS:
        raise InputError(f"unknown executor {executor!r}; the executors are "
                         f"{', '.join(EXECUTORS)}")
    if executor == "local" or len(jobs) <= 1 and address is None:
        return [fn(*job) for job in jobs]
    ray, started = start_ray(address, cpus)
    try:
        remote = ray.remote(max_retries=3)(_in_task)
        with deep_recursion():  # a job's formulas may nest as deeply as the parser reads
            return ray.get([remote.remote(fn, pickle.dumps(job)) for job in jobs])
    finally:
        if started:
            ray.shutdown()
