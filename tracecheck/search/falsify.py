"""Falsification: search the parameters of episodes (``--param``) for ones where the agent
under its shield violates a property, every evaluation a recorded episode.

Each repetition of the search is one optimiser (:mod:`.optimizers`, seeded with the search's
seed plus the repetition) asked for ``budget`` points one after the other — or, with ``W``
workers, ``W`` at a time before it is told their values (which changes the points a guided
optimiser chooses: a search reproduces with the same number of workers); each point is an
episode run as ``record`` runs one (:func:`tracecheck.live.rollout.run_episode`: the same
agent, shield and modes), in the environment made with the point's settings on top of the
run's, from the point's seed (or the run's ``--seed`` where the seed is not searched). The
property's value for the episode (:mod:`.objective`) is told to the optimiser, and the
episode is written with its settings and its search point, so every one of them replays,
re-simulates and renders like any recorded episode. Beside the optimiser, uniform random
sampling runs on the same budget and repetitions (the baseline), in the same file.

What a search reports, per optimiser, as ARCH-COMP's falsification track does: the
falsification rate (the repetitions that found a violation) and the episodes to the first
violation (mean, median, min, max over those); with ``stop_at_first`` a repetition ends at
its first violation, as ARCH-COMP's protocol does. No violation found within the budget is no
proof that there is none: the search covered ``budget`` points of the space, no more.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterator, Optional

from ..episodes.model import Episode, SearchPoint
from ..errors import InputError
from .evaluations import Task, evaluations
from .objective import search_objective
from .space import SEED, Space

__all__ = ["FalsifySettings", "Repetition", "Summary", "Violation", "FalsifyResult", "falsify",
           "summarise", "recorded_repetitions", "OBJECTIVE_LIMIT"]

#: objective values are stored within ±this (an STL robustness can be infinite)
OBJECTIVE_LIMIT = 1e300


@dataclass(frozen=True)
class FalsifySettings:
    """A search: ``record`` the episodes' settings (agent, shield, environment, base
    ``--seed``, duration…), ``params`` the ``--param`` texts, ``prop`` the property (None:
    no crash), ``budget`` episodes per repetition, the ``optimizer``, ``repeat``
    repetitions, the search's own ``seed``, and whether uniform random runs beside it."""

    record: object
    params: tuple[str, ...]
    prop: Optional[str] = None
    budget: int = 100
    optimizer: str = "tpe"
    repeat: int = 1
    seed: int = 0
    baseline: bool = True
    #: the steps before each violation that attribution branches at (0: not attributed)
    attribute: int = 5
    #: ``margin``: an episode that keeps a true/false property is valued by the shield's
    #: guard margins (:mod:`.margins`); ``none``: +1
    guide: str = "margin"
    #: end each repetition at its first violation (ARCH-COMP's protocol: the figures are
    #: the same, the episodes after the first are not run)
    stop_at_first: bool = False

    def optimizers(self) -> tuple[str, ...]:
        """The optimisers that run: the one asked for, and uniform random beside it."""
        if self.baseline and self.optimizer != "random":
            return (self.optimizer, "random")
        return (self.optimizer,)


@dataclass(frozen=True)
class Repetition:
    """One repetition of one optimiser: its violations and the number of episodes to the
    first (1-based; None: none within the budget), and the lowest objective value."""

    optimizer: str
    repetition: int
    evaluations: int
    violations: int
    first_violation: Optional[int]
    best: float
    #: how many of its violations were attributed to each kind
    attributions: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Summary:
    """ARCH-COMP's figures of one optimiser over its repetitions."""

    optimizer: str
    repetitions: int
    falsified: int
    rate: float
    first_mean: Optional[float]
    first_median: Optional[float]
    first_min: Optional[int]
    first_max: Optional[int]
    violations: int
    evaluations: int
    attributions: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Violation:
    """A violating episode: its id in the run file, and its search point (with its
    attribution)."""

    episode: int
    point: SearchPoint


@dataclass(frozen=True)
class FalsifyResult:
    """What a search found: each repetition, the figures per optimiser, and every violating
    episode."""

    property: str
    logic: str
    space: dict
    budget: int
    repetitions: tuple[Repetition, ...]
    summaries: tuple[Summary, ...]
    output: str
    violations: tuple[Violation, ...] = ()
    #: every evaluation: (optimizer, search, evaluation, objective)
    values: tuple[tuple[str, int, int, float], ...] = ()
    #: the dimensions of ``space`` that are lists of choices (the others: [low, high])
    choices: tuple[str, ...] = ()


def summarise(optimizer: str, reps: list[Repetition]) -> Summary:
    """The falsification rate and the episodes to the first violation of ``reps``."""
    firsts = [r.first_violation for r in reps if r.first_violation is not None]
    kinds: dict = {}
    for r in reps:
        for kind, count in r.attributions.items():
            kinds[kind] = kinds.get(kind, 0) + count
    return Summary(
        optimizer, len(reps), len(firsts), len(firsts) / len(reps) if reps else 0.0,
        statistics.fmean(firsts) if firsts else None,
        statistics.median(firsts) if firsts else None,
        min(firsts) if firsts else None, max(firsts) if firsts else None,
        sum(r.violations for r in reps), sum(r.evaluations for r in reps), kinds)


def searched(settings: FalsifySettings, evaluate, space: Space, done: list[Repetition],
             found: list[Violation], values: list, workers: int = 1) -> Iterator[Episode]:
    """The episodes of the search, in order, each with its point; each finished
    repetition appended to ``done``, each violation to ``found``, each objective value to
    ``values``. ``evaluate(tasks)`` runs a batch of evaluations (in order); with ``workers``
    above 1 an optimiser is asked that many points before it is told their values."""
    from .optimizers import make_optimizer

    record = settings.record
    episode_id = 0
    for name in settings.optimizers():
        for r in range(settings.repeat):
            optimizer = make_optimizer(name, len(space.dimensions), settings.seed + r)
            first, violations, best, kinds = None, 0, math.inf, {}
            k = 0
            while k < settings.budget and not (settings.stop_at_first and first is not None):
                units = [optimizer.ask() for _ in range(min(workers, settings.budget - k))]
                points = [space.point(u) for u in units]
                tasks = [Task(episode_id + i,
                               int(p[SEED]) if SEED in p else record.seed,
                               {d.name: p[d.name] for d in space.settings},
                               {d.name: p[d.name] for d in space.resets} or None)
                         for i, p in enumerate(points)]
                for unit, params, task, outcome in zip(units, points, tasks, evaluate(tasks)):
                    episode, value, violated, why = outcome
                    optimizer.tell(unit, value)
                    best = min(best, value)
                    if violated:
                        violations += 1
                        first = k + 1 if first is None else first
                    if why is not None:
                        kinds[why.kind] = kinds.get(why.kind, 0) + 1
                    stored = max(-OBJECTIVE_LIMIT, min(OBJECTIVE_LIMIT, value))
                    point = SearchPoint(r, k, params, stored, violated, name,
                                        why.kind if why else None,
                                        why.step if why else None,
                                        why.detail if why else None)
                    values.append((name, r, k, stored))
                    if violated:
                        found.append(Violation(task.episode, point))
                    yield replace(episode, config=task.overrides or None, search=point)
                    k += 1
                episode_id += len(tasks)
            done.append(Repetition(name, r, k, violations, first, best, kinds))


def recorded_repetitions(points) -> list[Repetition]:
    """The repetitions of a recorded search, from its episodes' search points (``(episode,
    point)`` pairs, :func:`~tracecheck.episodes.reader.search_points`; episodes without
    one are not the search's): what :func:`falsify` returned, read back from its file (a
    search cut short: the episodes it finished)."""
    groups: dict = {}
    for _, point in points:
        if point is not None:
            groups.setdefault((point.optimizer, point.repetition), []).append(point)
    reps = []
    for (name, r), group in groups.items():
        violating = [p.evaluation + 1 for p in group if p.violated]
        kinds: dict = {}
        for p in group:
            if p.attribution:
                kinds[p.attribution] = kinds.get(p.attribution, 0) + 1
        reps.append(Repetition(name, r, len(group), len(violating),
                               min(violating) if violating else None,
                               min(p.objective for p in group), kinds))
    return reps


def check_search(settings: FalsifySettings) -> None:
    """What can be refused before anything runs."""
    from .optimizers import make_optimizer

    if settings.budget < 1:
        raise InputError("--budget must be at least 1")
    if settings.repeat < 1:
        raise InputError("--repeat must be at least 1")
    if settings.seed < 0:
        raise InputError("--search-seed must be at least 0")
    if settings.guide not in ("margin", "none"):
        raise InputError(f"unknown guide {settings.guide!r}; the guides are margin, none")
    if settings.attribute < 0:
        raise InputError("--attribute must be at least 0 (0: violations not attributed)")
    for name in settings.optimizers():
        make_optimizer(name, 1, 0)  # an unknown or uninstalled one: exit 2 now


def falsify(settings: FalsifySettings, out: str | Path,
            progress: Optional[Callable[[Episode], None]] = None, *, force: bool = False,
            channels=None) -> FalsifyResult:
    """Run the search of ``settings`` and write every episode to ``out`` (the output rule;
    interrupted, the file keeps every finished episode). Bad settings raise before any
    episode runs."""
    from ..episodes.files import record_episodes
    from ..episodes.schema import SearchRunMessage
    from ..live.record import check_settings, recording_header, run_inputs
    from ..live.rollout import Session
    from .space import check_space

    out = Path(out)
    check_search(settings)
    record = settings.record
    agent, shield = check_settings(record, out, force=force)
    session = Session(record, shield=shield)
    try:
        space = check_space(settings.params, session.adapter, record.env_config,
                            check=_fits(record, shield, session.adapter))
        objective = search_objective(settings.prop, settings.guide, shield, session)
        header = recording_header(record, agent, shield).model_copy(update={
            "search": SearchRunMessage(
                optimizer=settings.optimizer, budget=settings.budget, repeat=settings.repeat,
                stop_at_first=settings.stop_at_first or None,
                seed=settings.seed, property=objective.text, space=space.describe(),
                choices=[d.name for d in space.dimensions if d.choices is not None] or None,
                reset=[d.name for d in space.resets] or None,
                baseline="random" if "random" in settings.optimizers()[1:] else None,
                guide="margin" if objective.guide is not None else None)})
        done: list[Repetition] = []
        found: list[Violation] = []
        values: list = []
        with evaluations(settings, session, objective, shield) as evaluate:
            record_episodes(out, header, searched(settings, evaluate, space, done, found,
                                                  values, max(1, record.workers)),
                            progress, force=force, channels=channels,
                            inputs=run_inputs(record))
    finally:
        session.env.close()
    summaries = tuple(summarise(name, [r for r in done if r.optimizer == name])
                      for name in settings.optimizers())
    return FalsifyResult(objective.text, objective.logic, space.describe(), settings.budget,
                         tuple(done), summaries, str(out), tuple(found), tuple(values),
                         tuple(d.name for d in space.dimensions if d.choices is not None))


def _fits(record, shield, adapter):
    """The check of an environment a search will run in: the agent and the shield fit it
    (as ``record`` checks its one environment)."""
    from ..checking.shield import check_vocabulary
    from ..live.agents import load_agent

    def check(env) -> None:
        load_agent(record.agent, adapter=adapter, env=env)
        check_vocabulary(shield, adapter, env)
    return check
