"""Falsification: search the parameters of episodes (``--param``) for ones where the agent
under its shield violates a property, every evaluation a recorded episode.

Each repetition of the search is one optimiser (:mod:`.optimizers`, seeded with the search's
seed plus the repetition) asked for ``budget`` points one after the other; each point is an
episode run as ``record`` runs one (:func:`tracecheck.live.rollout.run_episode`: the same
agent, shield and modes), in the environment made with the point's settings on top of the
run's, from the point's seed (or the run's ``--seed`` where the seed is not searched). The
property's value for the episode (:mod:`.objective`) is told to the optimiser, and the
episode is written with its settings and its search point, so every one of them replays,
re-simulates and renders like any recorded episode. Beside the optimiser, uniform random
sampling runs on the same budget and repetitions (the baseline), in the same file.

What a search reports, per optimiser, as ARCH-COMP's falsification track does: the
falsification rate (the repetitions that found a violation) and the episodes to the first
violation (mean, median, min, max over those). No violation found within the budget is no
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
from .objective import Objective
from .space import SEED, Space

__all__ = ["FalsifySettings", "Repetition", "Summary", "Violation", "FalsifyResult", "falsify",
           "summarise", "OBJECTIVE_LIMIT"]

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
    """A violating episode: its id in the run file, its search point and attribution."""

    episode: int
    optimizer: str
    repetition: int
    evaluation: int
    parameters: dict
    objective: float
    attribution: Optional[str]
    attribution_step: Optional[int]
    attribution_detail: Optional[str]


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


def searched(settings: FalsifySettings, session, space: Space, objective: Objective,
             done: list[Repetition], found: list[Violation], values: list
             ) -> Iterator[Episode]:
    """The episodes of the search, in order, each with its point; each finished
    repetition appended to ``done``, each violation to ``found``, each objective value to
    ``values``."""
    from ..live.rollout import run_episode
    from .attribution import attribute
    from .optimizers import make_optimizer

    record = settings.record
    base = dict(record.env_config or {})
    episode_id = 0
    for name in settings.optimizers():
        for r in range(settings.repeat):
            optimizer = make_optimizer(name, len(space.dimensions), settings.seed + r)
            first, violations, best, kinds = None, 0, math.inf, {}
            for k in range(settings.budget):
                unit = optimizer.ask()
                params = space.point(unit)
                overrides = {d.name: params[d.name] for d in space.settings}
                session.reconfigure(session.adapter.config(
                    {**base, **overrides}, profile=record.profile, horizon=session.horizon))
                seed = int(params[SEED]) if SEED in params else record.seed
                episode = run_episode(session, episode_id, seed=seed)
                value, violated = objective.value(episode)
                optimizer.tell(unit, value)
                best = min(best, value)
                if violated:
                    violations += 1
                    first = k + 1 if first is None else first
                why = None
                if violated and settings.attribute > 0:
                    why = attribute(session, episode, objective, settings.attribute)
                    kinds[why.kind] = kinds.get(why.kind, 0) + 1
                stored = max(-OBJECTIVE_LIMIT, min(OBJECTIVE_LIMIT, value))
                point = SearchPoint(r, k, params, stored, violated, name,
                                    why.kind if why else None, why.step if why else None,
                                    why.detail if why else None)
                values.append((name, r, k, stored))
                if violated:
                    found.append(Violation(episode_id, name, r, k, dict(params), stored,
                                           point.attribution, point.attribution_step,
                                           point.attribution_detail))
                yield replace(episode, config=overrides or None, search=point)
                episode_id += 1
            done.append(Repetition(name, r, settings.budget, violations, first, best, kinds))


def check_search(settings: FalsifySettings) -> None:
    """What can be refused before anything runs."""
    from .optimizers import make_optimizer

    if settings.budget < 1:
        raise InputError("--budget must be at least 1")
    if settings.repeat < 1:
        raise InputError("--repeat must be at least 1")
    if settings.seed < 0:
        raise InputError("--search-seed must be at least 0")
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
    from .objective import load_objective
    from .space import check_space

    out = Path(out)
    check_search(settings)
    record = settings.record
    agent, shield = check_settings(record, out, force=force)
    session = Session(record, shield=shield)
    try:
        space = check_space(settings.params, session.adapter, record.env_config,
                            check=_fits(record, shield, session.adapter))
        objective = load_objective(
            settings.prop, _property_machine(shield, session.adapter, settings.prop),
            tuple(session.adapter.actions))
        header = recording_header(record, agent, shield).model_copy(update={
            "search": SearchRunMessage(
                optimizer=settings.optimizer, budget=settings.budget, repeat=settings.repeat,
                seed=settings.seed, property=objective.text, space=space.describe(),
                baseline="random" if "random" in settings.optimizers()[1:] else None)})
        done: list[Repetition] = []
        found: list[Violation] = []
        values: list = []
        record_episodes(out, header, searched(settings, session, space, objective, done,
                                              found, values),
                        progress, force=force, channels=channels, inputs=run_inputs(record))
    finally:
        session.env.close()
    summaries = tuple(summarise(name, [r for r in done if r.optimizer == name])
                      for name in settings.optimizers())
    return FalsifyResult(objective.text, objective.logic, space.describe(), settings.budget,
                         tuple(done), summaries, str(out), tuple(found), tuple(values))


def _property_machine(shield, adapter, prop: Optional[str]):
    """The machine a property is read in: the shield's, or where it has no state (``--shield
    none``) the environment's own shield's, as ``stats`` reads properties — with the
    recorded crash flag ``crashed`` in scope (unless the machine has its own)."""
    from ..checking.crashflag import flagged

    machine = getattr(shield, "machine", None)
    if (machine is None or not machine.variables) and adapter.default_shield is not None:
        from ..stats.formulas import own_shield

        machine = own_shield(adapter).machine
    if prop is not None and (machine is None or not machine.variables):
        raise InputError(f"--property {prop!r}: a property reads the states' variables, "
                         f"which a B machine declares; the shield has none, and the "
                         f"environment {adapter.name} names no default_shield",
                         hint="give --shield a machine with the variables, or the adapter "
                              f"{type(adapter).__name__} a default_shield")
    return flagged(machine) if machine is not None else None


def _fits(record, shield, adapter):
    """The check of an environment a search will run in: the agent and the shield fit it
    (as ``record`` checks its one environment)."""
    from ..checking.shield import check_vocabulary
    from ..live.agents import load_agent

    def check(env) -> None:
        load_agent(record.agent, adapter=adapter, env=env)
        check_vocabulary(shield, adapter, env)
    return check
