"""Recording: run an agent under a shield for many episodes and write them to MCAP.

Any environment with an adapter (:mod:`tracecheck.live.adapter`).
Episode i uses seed ``seed + i``, so runs with different shields face the same scenarios.
Episodes run in worker processes and come back in order, so the same seed gives the same
file whatever the number of workers (a few tasks per worker run ahead of the writer, not
more: memory stays flat however many are recorded). A task is one episode, or up to
:data:`LOCAL_BATCH` in a campaign of over 64 episodes per worker; each episode that comes
back is written (and flushed) at once, so an interrupted run keeps every episode that came
back.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, Optional, Sequence

from ..episodes.files import AHEAD, check_run_output, record_episodes
from ..outputs import input_paths
from ..processes import Worker, carried, quiet_worker
from ..episodes.writer import ChannelsFactory, encode_episode, new_header
from ..episodes.model import Episode, EpisodeDigest
from ..errors import InputError
from .executors import batch_size, batches, in_order
from .rollout import RecordSettings, Session, resolve

__all__ = ["RecordSettings", "record", "episodes", "encoded_episodes", "check_settings",
           "recording_header"]


_SESSION: Optional[Session] = None
#: the most episodes a worker runs in one task: fewer tasks cost less (a grid-world campaign
#: ran 1.5x faster in tasks of 64 episodes than one by one), few enough that a finished
#: episode is soon written
LOCAL_BATCH = 8
#: batches of episodes given to each local worker at once: enough that none waits for the
#: writer's next (as the writer writes each episode once encoded and waits for an encoding
#: only far behind, see :func:`~tracecheck.episodes.files.prepared_episodes`), few enough
#: that a simulation stopped early has not run many more (4 left a worker idle no less)
LOCAL_IN_FLIGHT = 2
_FAILED: Optional[BaseException] = None


#: a worker's plug-in channels: how to make them (factory, header), and once made, them
_MAKE_CHANNELS: Optional[tuple] = None
_CHANNELS = None


#: in a worker that also encodes: the episodes it ran, by number, until it encodes them
#: (None: it does not keep them)
_KEPT: Optional[dict[int, Episode]] = None


def _init_worker(settings: RecordSettings, shield, channels=None, header=None,
                 keep: bool = False) -> None:
    global _SESSION, _FAILED, _MAKE_CHANNELS, _KEPT
    quiet_worker()
    _MAKE_CHANNELS = None if channels is None else (channels, header)
    _KEPT = {} if keep else None
    try:
        _SESSION = Session(settings, shield=shield)
    except Exception as error:  # raised from an initializer, the pool starts workers for ever
        _FAILED = error  # raised by the first episode instead, so it reaches the parent


def _work(first: int, count: int, digests: bool = False):
    """Episodes ``first`` to ``first + count - 1`` (``digests``: their digests, the
    episodes kept), and what stopped them: (those made, None) or, where episode k failed,
    (episodes ``first`` … k - 1, its exception, carried with its traceback) — the episodes
    before it in the task are written before its error is said."""
    if _FAILED is not None:
        raise _FAILED
    assert _SESSION is not None
    made: list[Episode] = []
    failed = None
    for i in range(first, first + count):
        try:
            made.append(_SESSION.episode(i))
        except BaseException as exc:  # noqa: BLE001 - raised by the writer after those
            failed = carried(exc)          # before (a SystemExit as a RuntimeError)
            break
    if _KEPT is not None:
        _KEPT.update(zip(range(first, first + count), made))
        if digests:
            return [episode.digest() for episode in made], failed
    return made, failed


def _encode_kept(number: int, context):
    """In the worker that ran episode ``number``: that episode, which it kept, encoded in
    ``context`` (see :func:`_encode`)."""
    assert _KEPT is not None
    return _encode(_KEPT.pop(number), context)


def _encode(episode: Episode, context):
    """In a worker: ``episode`` encoded for the file (its messages with the plug-in's, its
    chunk compressed, its columns) in ``context``."""
    global _CHANNELS
    if _CHANNELS is None and _MAKE_CHANNELS is not None:  # made at the first episode
        make, header = _MAKE_CHANNELS
        _CHANNELS = make(header)
    return encode_episode(episode, context, _CHANNELS)


class _Pooled:
    """The episodes of a recording from worker processes (a context: the workers live while
    it is open), one :class:`~tracecheck.processes.Worker` each. With ``keep`` each worker
    also encodes the episodes it ran for the file (:meth:`encode`: its messages, the
    plug-in's, its compressed chunk and columns), so that the one writer only appends them:
    the episode it kept is encoded where it was made — it does not cross back, and what the
    worker remembers for its values (a grid world's map drawn, encoded and written out)
    holds for it. With ``digests`` too, the workers send only each episode's digest (what
    writing it needs, :class:`~tracecheck.episodes.model.EpisodeDigest`): its steps never
    cross to the writer."""

    def __init__(self, settings: RecordSettings, shield, channels=None, header=None, *,
                 keep: bool = False, digests: bool = False) -> None:
        self.settings, self.shield, self.channels, self.header = settings, shield, channels, \
            header
        self.keep, self.digests = keep, keep and digests
        self._workers: list[Worker] = []
        #: the episodes given and not yet encoded: (the episode, its worker, its number)
        self._given: dict[int, tuple[Episode, Worker, int]] = {}

    def __enter__(self) -> "_Pooled":
        args = (self.settings, self.shield, self.channels, self.header, self.keep)
        try:
            for _ in range(self.settings.workers):
                self._workers.append(Worker(_init_worker, args))
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the workers at once (a simulation that stopped early: what they run ahead is
        not needed)."""
        workers, self._workers = self._workers, []
        for worker in workers:  # all asked first, then each waited for
            worker.stop()
        for worker in workers:
            worker.close()
        self._given.clear()

    def encode(self, episode: Episode, context):
        given = self._given.pop(id(episode), None)
        if given is not None and given[0] is episode:
            return given[1].call(_encode_kept, given[2], context)
        return self._workers[0].call(_encode, episode, context)

    def __iter__(self) -> Iterator[Episode]:
        settings, workers = self.settings, self._workers
        size = min(LOCAL_BATCH, batch_size(settings.episodes, settings.workers))

        def submit(job: tuple[int, int]):
            worker = min(workers, key=lambda w: w.busy)  # the least busy
            return job[0], worker, worker.call(_work, *job, self.digests)

        episode: Episode | EpisodeDigest
        for first, worker, (batch, failed) in in_order(
                submit, batches(settings.episodes, size), LOCAL_IN_FLIGHT * settings.workers,
                lambda h: (h[0], h[1], h[2].get())):
            for number, episode in enumerate(batch, first):
                if self.keep:
                    self._given[id(episode)] = (episode, worker, number)
                yield episode
            if failed is not None:
                raise failed  # rebuilt here with the worker's traceback as its cause


@contextmanager
def encoded_episodes(settings: RecordSettings, shield, channels=None, header=None, *,
                     digests: bool = False):
    """(episodes, encode) of a recording: with local workers, they also encode each episode
    for the file (``encode(episode, context)``, see
    :func:`~tracecheck.episodes.files.prepared_episodes`), else ``encode`` is None (the
    writer encodes them). ``channels`` and ``header``: the writer's plug-in and run header;
    ``digests``: with local workers, the episodes come as their digests (enough to write
    them, see :class:`_Pooled`)."""
    if settings.executor == "local" and settings.workers > 1:
        with _Pooled(settings, shield, channels, header, keep=True,
                     digests=digests) as pooled:
            yield pooled, pooled.encode
    else:
        yield episodes(settings, shield), None


def episodes(settings: RecordSettings, shield) -> Iterator[Episode]:
    """The episodes of a recording, in order, from ``settings.workers`` processes (or from
    Ray tasks with ``executor="ray"``), under ``shield`` (the shield itself, as
    :func:`check_settings` loaded it: workers get it, not a name to load again)."""
    if settings.executor == "ray":
        from .executors import ray_episodes

        yield from ray_episodes(settings, settings.ray_address, shield=shield)
        return
    if settings.workers <= 1:
        session = Session(settings, shield=shield)
        for i in range(settings.episodes):
            yield session.episode(i)
        return
    with _Pooled(settings, shield) as pooled:
        yield from pooled


def run_inputs(settings: RecordSettings, *more) -> list[Path]:
    """The files a recording reads (agent, shield file, …): its output must be none of them."""
    return input_paths(settings.agent, settings.shield, *more)


def check_settings(settings: RecordSettings, out: Path, *, force: bool = False,
                   inputs: Sequence[Path] = ()):
    """Everything that can be checked before an episode runs: output (the output rule, see
    :mod:`tracecheck.outputs`), environment, agent (its spaces against the environment's),
    shield (its operations and variables against the environment's actions and states)."""
    from .agents import load_agent
    from ..checking.shield import check_vocabulary, load_shield

    if settings.episodes < 1:
        raise InputError("--episodes must be at least 1")
    if settings.seed < 0 or settings.seed + settings.episodes - 1 > 2**63 - 1:
        raise InputError(f"--seed {settings.seed}: episode i uses seed SEED + i, and a seed is "
                         "0 … 2^63 - 1 (what Gymnasium takes and a run file stores)")
    if settings.executor not in ("local", "ray"):
        raise InputError(f"unknown executor {settings.executor!r}; the executors are local, ray")
    check_run_output(out, [*run_inputs(settings), *inputs], force=force)
    adapter, config, _ = resolve(settings)
    actions = adapter.actions
    if settings.fallback is not None and settings.fallback not in actions:
        raise InputError(f"unknown fallback action {settings.fallback!r}; the actions are "
                         f"{', '.join(actions)}")
    env = adapter.make_env(config)
    try:
        agent = load_agent(settings.agent, adapter=adapter, env=env)
        shield = load_shield(settings.shield, actions=actions, parameters=adapter.parameters)
        check_vocabulary(shield, adapter, env)
        check_continuous(settings, adapter, shield, env)
    finally:
        env.close()
    return agent, shield


def check_continuous(settings: RecordSettings, adapter, shield, env) -> None:
    """Before any episode: continuous actions fit the shield and the action space (see
    :class:`~tracecheck.live.continuous.ContinuousShield`); a continuous setting is refused
    for discrete actions."""
    if not adapter.parameters:
        if settings.shield_mode is not None or settings.scale is not None:
            raise InputError(f"--shield-mode and --scale are for continuous actions; "
                             f"{adapter.name} has discrete ones ({', '.join(adapter.actions)})")
        return
    from .continuous import ContinuousShield

    ContinuousShield(shield.machine, adapter, env.action_space, mode=settings.shield_mode,
                     scale=settings.scale)


def continuous_fields(settings: RecordSettings, adapter) -> dict:
    """The run header's fields of continuous actions (none for discrete ones)."""
    if not adapter.parameters:
        return {}
    env = adapter.make_env(resolve(settings)[1])
    try:
        space = env.action_space
    finally:
        env.close()
    from .continuous import space_parts

    hybrid, parts = space_parts(adapter, space)
    low = [float(x) if math.isfinite(x) else None for p in parts for x in p.low]
    high = [float(x) if math.isfinite(x) else None for p in parts for x in p.high]
    return {"action_parameters": {p.op: list(p.params) for p in parts},
            "action_low": low, "action_high": high,
            "action_floats": [p.dtype.name for p in parts for _ in p.params],
            "shield_mode": settings.shield_mode or ("mask" if hybrid else "project"),
            "projection_scale": [float(x) for x in (settings.scale or (1.0,) * len(low))]}


def recording_header(settings: RecordSettings, agent, shield):
    """The run header of a recording: environment (adapter, configuration, horizon), agent
    and shield with their hashes."""
    adapter, config, horizon = resolve(settings)
    return new_header(
        "recorded", **continuous_fields(settings, adapter), environment=adapter.name, environment_id=adapter.env_id,
        environment_config=config, horizon=horizon,
        agent_id=agent.id, agent_sha256=agent.sha256,
        agent_file=str(Path(agent.path).resolve()), shield_name=shield.name,
        shield_sha256=shield.sha256, base_seed=settings.seed, model_name=adapter.model_name,
        variables=list(adapter.variables), actions=list(adapter.actions))


def record(settings: RecordSettings, out: str | Path,
           progress: Optional[Callable[[EpisodeDigest], None]] = None, *,
           force: bool = False, channels: Optional[ChannelsFactory] = None
           ) -> tuple[int, int, int]:
    """Record ``settings.episodes`` episodes into ``out``; (episodes, steps, crashes);
    ``progress`` is told of each episode written, by its
    :class:`~tracecheck.episodes.model.EpisodeDigest` (with workers its steps stay in the
    worker that ran it); ``channels`` adds a plug-in's channels: without it the file has
    tracecheck's own channels only; the CLI gives Foxglove's drawn by the adapter it runs
    (``channels=FoxgloveChannels.drawn_by(adapter)`` from ``tracecheck.interop.foxglove``,
    which a caller in Python passes for the same file).

    Bad settings raise before any episode runs; an existing ``out`` is refused unless
    ``force`` (see :func:`~tracecheck.episodes.files.recording_into`). Interrupted, the file
    keeps every finished episode (the exception is re-raised after the file is closed).
    """
    out = Path(out)
    agent, shield = check_settings(settings, out, force=force)
    header = recording_header(settings, agent, shield)
    told = None if progress is None else (lambda episode: progress(episode.digest()))
    with encoded_episodes(settings, shield, channels, header, digests=True) as (made, encode):
        return record_episodes(out, header, made, told, force=force, channels=channels,
                               inputs=run_inputs(settings), encode=encode,
                               ahead=AHEAD * settings.workers)
