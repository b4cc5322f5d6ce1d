"""Why a falsifying episode failed (crash attribution), by branching re-simulation.

From the episode's seed and settings, the recorded actions are replayed up to the state
before each of the last ``window`` steps up to the failure (each reproduced state checked
against the recording, as ``replay --resimulate`` does), and there every action the shield
allowed in the recording is tried instead of the one taken, the agent then going on under
the shield to the horizon. A branch *avoids* the failure where its episode does not violate
the property. With the failure at step n:

* **unavoidable under the shield**: at every step of the window, no allowed action avoids
  it (or the shield allowed nothing and the fallback was taken): the episode was doomed
  before the window (a wider ``window`` looks further back);
* **shield gap** at step j < n: the shield allowed, at step j, an action after which every
  allowed continuation fails (each later step of the window has no avoiding action), while
  an allowed action at j avoids it: the shield let the agent into a state its model did not
  see was doomed — j's action sealed the failure;
* **agent's choice** at step n: at the failing step itself the shield allowed an action that
  avoids it, and the agent took another.

Branches run exactly: the same seed, the same settings, the recorded actions before; an
episode that does not reproduce up to a branch point is *not attributed*, with the step where
it diverged — never guessed. Continuous actions (a continuum of allowed values) are not
attributed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

from ..episodes.model import Episode
from .objective import Objective

__all__ = ["Attribution", "Branch", "attribute", "failure_step", "KINDS"]

GAP, UNAVOIDABLE, CHOICE, NOT_ATTRIBUTED = ("shield gap", "unavoidable under the shield",
                                            "agent's choice", "not attributed")
KINDS = (GAP, UNAVOIDABLE, CHOICE, NOT_ATTRIBUTED)


@dataclass(frozen=True)
class Branch:
    """The episode with ``action`` at ``step`` instead of the recorded one: whether it
    still violates the property."""

    step: int
    action: str
    violated: bool


@dataclass(frozen=True)
class Attribution:
    """What sealed a failure: ``kind`` (one of :data:`KINDS`), the ``step`` it names and the
    action taken there, the allowed actions there that avoid it, and why in words."""

    kind: str
    step: Optional[int]
    action: Optional[str]
    avoiding: tuple[str, ...]
    detail: str
    branches: tuple[Branch, ...] = ()


def failure_step(episode: Episode, objective: Objective) -> int:
    """The step of the failure: the crash, or the end of the shortest beginning of the
    episode that already violates the property (the first bad state of a safety property;
    the last step where only the whole episode does)."""
    if objective.logic == "crash":
        return episode.end.steps
    for n in range(1, episode.end.steps + 1):
        steps = episode.steps[:n + 1]
        prefix = replace(episode, steps=steps, end=replace(episode.end, steps=n,
                                                           crashed=steps[-1].crashed))
        if objective.value(prefix)[1]:
            return n
    return episode.end.steps


def attribute(session, episode: Episode, objective: Objective, window: int = 5
              ) -> Attribution:
    """The attribution of the violating ``episode`` (run in ``session``'s environment, which
    the caller configured with the episode's settings)."""
    from ..live.rollout import Diverged, run_episode

    if session.env.continuous is not None:
        return Attribution(NOT_ATTRIBUTED, None, None, (), "continuous actions: the allowed "
                           "values are a continuum, not a list of actions to try")
    if episode.seed is None:
        return Attribution(NOT_ATTRIBUTED, None, None, (), "the episode has no seed")
    n = failure_step(episode, objective)
    recorded = [s.action for s in episode.steps[1:]]
    branches: list[Branch] = []
    avoiding: dict[int, tuple[str, ...]] = {}
    deadlocks: list[int] = []
    for j in range(n, max(0, n - window), -1):
        step = episode.steps[j]
        allowed = tuple(step.allowed_actions or ())
        if step.deadlock or not allowed:
            deadlocks.append(j)
            avoiding[j] = ()
            continue
        found = []
        for action in allowed:
            if action == step.action:
                continue  # the recording is that branch: it violates
            script = recorded[:j - 1] + [action]
            try:
                alt = run_episode(session, episode.id, seed=int(episode.seed), script=script,
                                  check=_checker(episode, j),
                                  options=dict(episode.reset_options or {}) or None)
            except Diverged as exc:
                return Attribution(NOT_ATTRIBUTED, None, None, (),
                                   f"the episode does not reproduce from its seed "
                                   f"({exc}): its branches cannot be run exactly",
                                   tuple(branches))
            violated = objective.value(alt)[1]
            branches.append(Branch(j, action, violated))
            if not violated:
                found.append(action)
        avoiding[j] = tuple(found)
    steps = sorted(avoiding)
    open_steps = [j for j in steps if avoiding[j]]
    first = steps[0]
    if not open_steps:
        why = (f"from step {first} to the failure at step {n}, no action the shield allowed "
               "avoids it" + (f" (at step {', '.join(map(str, sorted(deadlocks)))} it allowed "
                              "nothing: the fallback)" if deadlocks else "")
               + (f"; the episode was doomed at step {first} or before" if first > 1 else ""))
        return Attribution(UNAVOIDABLE, first, episode.steps[first].action, (), why,
                           tuple(branches))
    j = open_steps[-1]
    taken = episode.steps[j].action
    others = ", ".join(avoiding[j])
    if j == n:
        return Attribution(CHOICE, j, taken, avoiding[j],
                           f"at step {j}, the failing step, the shield also allowed {others}, "
                           f"which avoid{'s' if len(avoiding[j]) == 1 else ''} it; the agent "
                           f"took {taken}", tuple(branches))
    return Attribution(GAP, j, taken, avoiding[j],
                       f"the shield allowed {taken} at step {j}, after which every action it "
                       f"allowed fails (steps {j + 1}–{n}); {others} at step {j} avoid"
                       f"{'s' if len(avoiding[j]) == 1 else ''} it", tuple(branches))


def _checker(episode: Episode, branch: int):
    """The reproduced states before the branch point must be the recorded ones."""
    from ..live.resimulate import same_state

    def check(k: int, state) -> Optional[str]:
        if k >= branch:
            return None
        return same_state(episode.steps[k].state, state)
    return check
