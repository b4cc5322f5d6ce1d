"""Where files are checked: in this process, in worker processes of it (``workers``), or in
Ray tasks.

Replay, diff and statistics map a function over their run files with :func:`map_file_blocks`:
one unit per file in this process, one per block of episodes for workers or Ray (memory per
worker is one block's), the results put back in file and block order — the same report
whatever runs them. Recording starts Ray the same way (:func:`start_ray`).
"""

from __future__ import annotations

import os
import pickle
from typing import Optional

from ..errors import InputError
from ..limits import deep_recursion

__all__ = ["map_files", "map_file_blocks", "file_blocks", "start_ray", "EXECUTORS", "UNCHECKED"]

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


def file_blocks(paths, executor: str = "local", workers: int = 1
                ) -> list[tuple[int, str, object]]:
    """The units of work over run files: (index of the file, its path, a
    :class:`~tracecheck.episodes.columns.BlockRef` or None for the whole file). In this
    process a whole file each (read block by block all the same); for workers or on Ray each
    block of a file that has them (:func:`~tracecheck.episodes.columns.block_refs`), but a
    run with continuous actions whole (its statistics decode every step of it)."""
    from ..episodes.columns import block_refs
    from ..episodes.reader import read_header

    whole = executor == "local" and workers <= 1
    out = []
    for i, p in enumerate(paths):
        refs = [] if whole or read_header(p).action_parameters else block_refs(p)
        out += [(i, str(p), ref) for ref in refs] or [(i, str(p), None)]
    return out


#: what a task over a block returns when the block does not check (then its whole file is
#: read again, walked: the walk names the damage, or salvages)
UNCHECKED = "tracecheck: block unchecked"


def _unit(fn, *job):
    from ..episodes.columns import BlockUnchecked

    try:
        return fn(*job)
    except BlockUnchecked:
        return UNCHECKED


def map_file_blocks(fn, make_job, paths, executor: str = "local",
                    address: Optional[str] = None, workers: int = 1
                    ) -> list[tuple[int, object]]:
    """``fn(*make_job(i, path, block))`` for each unit of :func:`file_blocks` (file ``i`` of
    ``paths``), in this process, in ``workers`` processes or as Ray tasks: (index of the
    file, result) in file order. A file one of whose blocks does not check when its task
    reads it (damaged, or changed since it was counted) is done again whole, as one process
    does it."""
    units = file_blocks(paths, executor, workers)
    results = map_files(_unit, [(fn, *make_job(i, p, ref)) for i, p, ref in units], executor,
                        address, workers=workers)
    redo = sorted({i for (i, _, _), r in zip(units, results) if r == UNCHECKED})
    again = dict(zip(redo, map_files(fn, [make_job(i, str(paths[i]), None) for i in redo],
                                     executor, address, workers=workers)))
    out, given = [], set()
    for (i, _, _), r in zip(units, results):
        if i not in again:
            out.append((i, r))
        elif i not in given:  # the whole file once, in place of its blocks
            out.append((i, again[i]))
            given.add(i)
    return out


def map_files(fn, jobs: list[tuple], executor: str = "local",
              address: Optional[str] = None, cpus: int = 2, workers: int = 1) -> list:
    """``fn(*job)`` for each job (one per file or block), in this process, in ``workers``
    processes (``local``) or as Ray tasks; results in order."""
    if executor not in EXECUTORS:
        raise InputError(f"unknown executor {executor!r}; the executors are "
                         f"{', '.join(EXECUTORS)}")
    if executor == "local" and workers > 1 and len(jobs) > 1:
        return _in_workers(fn, jobs, workers)
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


def _in_workers(fn, jobs: list[tuple], workers: int) -> list:
    """``fn(*job)`` for each job in a pool of ``workers`` processes, results in order (a
    job's error raised here, as in one process; Ctrl-C stops the pool)."""
    from ..processes import quiet_worker, worker_pool

    with worker_pool(min(workers, len(jobs)), quiet_worker) as pool:
        try:
            handles = [pool.apply_async(_in_worker, (fn, [pickle.dumps(a) for a in job]))
                       for job in jobs]
            return [h.get() for h in handles]
        finally:
            pool.terminate()


#: in a worker: each argument it was sent, by its bytes — a shield (or a property set) that
#: every job carries is unpickled once, and its compiled guards serve every later job
_LOADED: dict[bytes, object] = {}


def _in_worker(fn, args: list[bytes]):
    """``fn(*args)`` in a worker process, each argument unpickled once per process."""
    loaded = []
    for data in args:
        if data not in _LOADED:
            _LOADED[data] = pickle.loads(data)
        loaded.append(_LOADED[data])
    with deep_recursion():
        return fn(*loaded)
