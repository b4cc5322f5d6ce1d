"""Where a search's episodes run: in this process, in local worker processes, or as Ray
tasks — each evaluation the episode of a point in the environment made with its settings,
the property's value, and its attribution where it violates.

A batch of evaluations (the points an optimiser was asked for at once: ``--workers W`` of
them) runs in parallel and comes back in order, whichever executor runs it, so a search
gives the same episodes on each. On Ray a task is one evaluation; a worker keeps its
environment, agent and shield for the next (the shield sent once, as ``record`` sends it),
and a worker killed mid-task makes Ray run the evaluation again (up to three times).
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from typing import Optional

from .objective import Objective, search_objective

__all__ = ["Task", "Evaluator", "evaluations"]


@dataclass(frozen=True)
class Task:
    """One evaluation: the episode's id in the file, its seed, settings and what it starts
    from (the adapter's ``reset`` options)."""

    episode: int
    seed: int
    overrides: dict
    options: Optional[dict] = None


class Evaluator:
    """Runs evaluations in one process: the episode in the environment made with its
    settings, the property's value, and its attribution where it violates."""

    def __init__(self, settings, session, objective: Objective) -> None:
        self.settings, self.session, self.objective = settings, session, objective

    def __call__(self, task: Task) -> tuple:
        from ..live.rollout import run_episode
        from .attribution import attribute

        record, session = self.settings.record, self.session
        session.reconfigure(session.adapter.config(
            {**dict(record.env_config or {}), **task.overrides}, profile=record.profile,
            horizon=session.horizon))
        episode = run_episode(session, task.episode, seed=task.seed, options=task.options)
        value, violated = self.objective.value(episode)
        why = None
        if violated and self.settings.attribute > 0:
            why = attribute(session, episode, self.objective, self.settings.attribute)
        return episode, value, violated, why


_WORKER: Optional[Evaluator] = None


def _init_worker(settings, shield) -> None:
    """A worker process's own environment, agent and objective (built there)."""
    global _WORKER
    from ..live.rollout import Session
    from ..processes import quiet_worker

    quiet_worker()
    session = Session(settings.record, shield=shield)
    _WORKER = Evaluator(settings, session, search_objective(settings.prop, settings.guide,
                                                          shield, session))


def _work(task: Task) -> tuple:
    assert _WORKER is not None
    return _WORKER(task)


@contextmanager
def evaluations(settings, session, objective: Objective, shield):
    """``evaluate(tasks)``: in this process, in ``settings.record.workers`` processes (each
    with its own environment and agent, as ``record``'s workers), or as Ray tasks
    (``--executor ray``)."""
    workers = settings.record.workers
    if settings.record.executor == "ray":
        with _on_ray(settings, shield) as evaluate:
            yield evaluate
        return
    if workers <= 1:
        local = Evaluator(settings, session, objective)
        yield lambda tasks: [local(t) for t in tasks]
        return
    from ..processes import worker_pool

    with worker_pool(workers, _init_worker, (settings, shield)) as pool:
        try:
            yield lambda tasks: pool.map(_work, tasks, chunksize=1)
        finally:
            pool.terminate()


_RAY: Optional[tuple] = None  # ((settings, shield's sha256), the worker's Evaluator)


def _ray_evaluate(settings, task: Task, shield_ref: list, sha256: str) -> tuple:
    """Runs on a Ray worker: one evaluation, with the worker's environment, agent and
    objective for these settings and this shield (fetched only when it has none yet)."""
    global _RAY
    import ray

    from ..live.rollout import Session

    if _RAY is None or _RAY[0] != (settings, sha256):
        shield = ray.get(shield_ref[0])
        session = Session(settings.record, shield=shield)
        objective = search_objective(settings.prop, settings.guide, shield, session)
        _RAY = ((settings, sha256), Evaluator(settings, session, objective))
    return _RAY[1](task)


@contextmanager
def _on_ray(settings, shield):
    """``evaluate(tasks)`` as Ray tasks, on the cluster at ``--ray-address`` or a local Ray
    of ``--workers`` CPUs (started here, and stopped at the end)."""
    from ..checking.executors import start_ray

    record = settings.record
    ray, started = start_ray(record.ray_address, max(1, record.workers))
    try:
        remote = ray.remote(max_retries=3)(_ray_evaluate)
        ref = [ray.put(shield)]  # in a list: a worker fetches it only when it needs it
        yield lambda tasks: ray.get([remote.remote(settings, t, ref, shield.sha256)
                                     for t in tasks])
    finally:
        if started:
            ray.shutdown()
