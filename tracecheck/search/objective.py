"""What a search minimises (``--property``): a temporal property of each episode, as a
number that is lower the closer the episode comes to violating it and negative where it
does.

* An STL formula (``G({d > 2.0})``, :mod:`tracecheck.checking.stl`): its robustness at the
  episode's first state — the episode violates it where the robustness is negative, keeps it
  where positive; at exactly 0 (``G({pos >= 2})`` with a smallest ``pos`` of 2) the formula's
  truth decides, read as LTL (where it cannot be, 0 is a violation).
* An LTL formula (``G({Crash = FALSE})``, :mod:`tracecheck.checking.ltl`): true or false
  per episode, so its value is -1 where violated and +1 where not: nothing guides the search
  between violations (the baselines and the optimisers see the same flat value); an STL
  property of the same situation guides it.
* None given: the episode must not crash (the environment's own crash flag, which every
  adapter gives), valued as an LTL property.

An episode that keeps a true/false property (LTL, or no crash) is valued by the shield's
guard margin where a guide is given (:mod:`.margins`: how close the actions taken came to
their guards flipping; 0 or more), else +1.

The formula is read in the shield's machine (its variables are the states'), and is
checked before any episode runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional

from ..episodes.model import Episode
from ..errors import InputError, TracecheckError

__all__ = ["Objective", "DEFAULT_PROPERTY", "load_objective", "search_objective"]

#: the property where none is given: the episode does not crash
DEFAULT_PROPERTY = "no crash"


@dataclass(frozen=True)
class Objective:
    """A property and how an episode's value is computed (``logic``: ``LTL``, ``STL`` or
    ``crash``, the default)."""

    text: str
    logic: str
    formula: Any
    machine: Any
    actions: tuple[str, ...]
    #: an STL formula read as LTL too, where it can be: its truth where the robustness is 0
    truth: Any = None
    #: the shield's guard margins (:mod:`.margins`), the value of an LTL or crash property
    #: where it holds (None: +1)
    guide: Any = None

    def value(self, episode: Episode) -> tuple[float, bool]:
        """(the episode's value, whether it violates the property)."""
        from ..episodes.columns import episode_columns

        if self.logic == "crash":
            return (-1.0, True) if episode.end.crashed else (self._held(episode), False)
        from ..checking.crashflag import with_crash_flag
        from ..checking.ltl import evaluate_ltl

        cols = with_crash_flag(episode_columns([episode], self.actions))
        if self.logic == "STL":
            from ..checking.stl import episode_robustness

            rho = float(episode_robustness(self.formula, cols, self.machine)[0])
            if math.isnan(rho):
                raise InputError(f"episode {episode.id}: the robustness of {self.text} has no "
                                 "value (a NaN in the states)")
            if rho == 0.0 and self.truth is not None:  # on the boundary: G({pos >= 2}) at 2
                holds = bool(evaluate_ltl(self.truth, cols, self.machine)[cols.starts[0]])
                return rho, not holds
            return rho, not rho > 0
        holds = bool(evaluate_ltl(self.formula, cols, self.machine)[cols.starts[0]])
        return (self._held(episode), False) if holds else (-1.0, True)

    def _held(self, episode: Episode) -> float:
        """The value of an episode that keeps a true/false property: its guard margin
        where a guide measures one, else 1."""
        margin = self.guide.episode(episode) if self.guide is not None else None
        return 1.0 if margin is None else margin


def load_objective(text, machine, actions: tuple[str, ...], guide=None) -> Objective:
    """The property ``text`` read as STL where it has a robustness (comparisons of numbers
    only), else as LTL; an error naming ``--property`` where it is neither. None: the
    episode does not crash. ``guide``: the shield's guard margins, the value of a
    true/false property's episodes that keep it."""
    from ..checking.ltl import parse_ltl
    from ..checking.stl import parse_stl

    if text is None:
        return Objective(DEFAULT_PROPERTY, "crash", None, machine, actions, guide=guide)
    try:
        stl = parse_stl(text, machine, where="--property")
    except TracecheckError:
        stl = None  # not STL (an LTL atom, a non-numeric comparison): tried as LTL
    if stl is not None:
        try:
            truth = parse_ltl(text, machine, where="--property")
        except TracecheckError:
            truth = None  # STL only (G[a,b]): a robustness of 0 is a violation
        return Objective(text, "STL", stl, machine, actions, truth)
    try:
        return Objective(text, "LTL", parse_ltl(text, machine, where="--property"), machine,
                         actions, guide=guide)
    except TracecheckError as exc:
        raise InputError(f"--property {text!r}: {exc.message}",
                         hint=exc.hint or "an LTL formula (G({Crash = FALSE})) or an STL one "
                                          "(G({d > 2.0}))") from None


def search_objective(prop: Optional[str], guide: str, shield, session) -> "Objective":
    """A search's objective: its property ``prop`` (None: no crash), read in the property
    machine, guided by the shield's guard margins where asked (``guide="margin"``) and the
    shield has guards — for continuous actions measured within the bounds of the action
    space of ``session``'s environment (a bound of the space is no guard's)."""
    from .margins import GuardMargins, action_bounds

    adapter = session.adapter
    machine = getattr(shield, "machine", None)
    margins = GuardMargins(machine, action_bounds(getattr(session.env, "continuous", None))) \
        if guide == "margin" and machine is not None and machine.operations else None
    return load_objective(prop, _property_machine(shield, adapter, prop),
                          tuple(adapter.actions), margins)


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
