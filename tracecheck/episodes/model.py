"""Episodes inside tracecheck: frozen dataclasses, whatever file they came from."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Optional

__all__ = ["StepRecord", "EpisodeEnd", "Episode", "EpisodeDigest", "SearchPoint", "END_REASONS"]

#: the end reasons, in a fixed order (the run columns blob stores their index)
END_REASONS: tuple[str, ...] = ("crashed", "time-limit", "end-of-trace", "deadlock", "interrupted")


@dataclass(frozen=True)
class StepRecord:
    """One state and the action that led to it (``action`` is None at step 0)."""

    step: int
    time: float
    action: Optional[str]
    state: Mapping[str, Any]
    reward: float
    crashed: bool
    observation: Optional[tuple[tuple[float, ...], ...]] = None
    action_values: Optional[Mapping[str, float]] = None
    preferred_action: Optional[str] = None
    allowed_actions: Optional[tuple[str, ...]] = None
    shield_time_us: Optional[float] = None
    deadlock: Optional[bool] = None
    #: why the live shield could not evaluate some guard in the state before (those actions
    #: were not allowed: it failed closed)
    shield_problem: Optional[str] = None
    #: continuous actions (an operation with REAL parameters): the values of the executed
    #: action's parameters, by parameter name
    parameters: Optional[Mapping[str, float]] = None
    #: what the agent proposed for them, before the shield
    proposal: Optional[Mapping[str, float]] = None
    #: how far the shield moved the proposal (Euclidean, in the scale the shield used)
    projection_distance: Optional[float] = None
    #: the allowed values of each parameter in the state before, as intervals (low, high),
    #: None for an unbounded end; only where each parameter's set is a union of intervals
    allowed_intervals: Optional[Mapping[str, tuple[tuple[Optional[float], Optional[float]],
                                                   ...]]] = None


@dataclass(frozen=True)
class EpisodeEnd:
    steps: int
    crashed: bool
    total_reward: float
    reason: str


@dataclass(frozen=True)
class SearchPoint:
    """The search evaluation an episode is (``tracecheck falsify``): which repetition of
    the search and which evaluation in it, the parameters tried, the objective's value
    (lower is closer to a violation; negative: a violation), whether the property was
    violated, and the optimiser that chose the parameters."""

    repetition: int
    evaluation: int
    parameters: Mapping[str, Any]
    objective: float
    violated: bool
    optimizer: str = ""
    #: why it failed (:mod:`tracecheck.search.attribution`): the kind, the step it names,
    #: and the reason in words; None where not attributed (no violation, or not asked)
    attribution: Optional[str] = None
    attribution_step: Optional[int] = None
    attribution_detail: Optional[str] = None


@dataclass(frozen=True)
class Episode:
    """A whole episode: states ``steps[0] … steps[n]`` and how it ended. ``config``: the
    environment settings of this episode on top of the run's (a search's parameters);
    ``search``: the search evaluation it is, if any; ``reset_options``: what it started
    from besides its seed."""

    id: int
    steps: tuple[StepRecord, ...]
    end: EpisodeEnd
    seed: Optional[int] = None
    origin: Optional[str] = None
    config: Optional[Mapping[str, Any]] = None
    search: Optional[SearchPoint] = None
    #: what the episode started from besides its seed: the values of its environment's
    #: ``reset_parameters`` a search chose (the adapter's ``reset`` took them)
    reset_options: Optional[Mapping[str, Any]] = None

    @property
    def states(self) -> list[Mapping[str, Any]]:
        return [s.state for s in self.steps]

    @property
    def actions(self) -> list[Optional[str]]:
        return [s.action for s in self.steps]

    @property
    def last_time(self) -> float:
        """The time of its last step."""
        return self.steps[-1].time

    @property
    def action_names(self) -> tuple[str, ...]:
        """The action names its steps take, then those they score, in the order they first
        appear."""
        out = dict.fromkeys(s.action for s in self.steps if s.action is not None)
        for s in self.steps:
            out.update(dict.fromkeys(s.action_values or ()))
        return tuple(out)

    @property
    def deadlocks(self) -> int:
        """The steps where the shield allowed nothing (and the fallback was taken)."""
        return sum(bool(s.deadlock) for s in self.steps)

    def digest(self) -> "EpisodeDigest":
        """What writing it encoded elsewhere needs and a recording reports, without its
        steps."""
        problems = [(s.step, s.shield_problem) for s in self.steps if s.shield_problem]
        return EpisodeDigest(self.id, self.end, self.last_time, self.action_names,
                             self.deadlocks, len(problems), problems[0] if problems else None)


@dataclass(frozen=True)
class EpisodeDigest:
    """An episode without its steps (:meth:`Episode.digest`): what writing it, encoded
    where it was made, needs of it, and what a recording reports of it. A recording's
    workers send this while the episode itself stays with them until they encode it."""

    id: int
    end: EpisodeEnd
    last_time: float  # the time of its last step
    action_names: tuple[str, ...]  # see Episode.action_names
    deadlocks: int  # see Episode.deadlocks
    problems: int = 0  # the steps whose shield could not evaluate a guard
    first_problem: Optional[tuple[int, str]] = None  # (step, why) of the first

    def digest(self) -> "EpisodeDigest":
        return self


def make_end(steps: tuple[StepRecord, ...], reason: Optional[str] = None) -> EpisodeEnd:
    """The end record of ``steps``: crashed if the last state crashed; the reward summed over
    the steps after the initial state."""
    crashed = bool(steps[-1].crashed)
    total = float(sum(s.reward for s in steps[1:]))
    return EpisodeEnd(steps=len(steps) - 1, crashed=crashed, total_reward=total,
                      reason=reason or ("crashed" if crashed else "end-of-trace"))
