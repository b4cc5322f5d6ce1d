"""Shielding continuous actions: the agent proposes a vector, the shield executes an allowed one.

An adapter for a ``Box`` action space declares which operation the action is and which REAL
parameter of it each component binds (``parameters = {"ACCELERATE": ("a",)}``, see
:class:`~tracecheck.live.adapter.EnvAdapter`). In each state the shield computes the
allowed set of that operation's parameters (:mod:`tracecheck.b.linear`: exact over the
reals when the guard is linear in them), intersected with the space's bounds, and then, by
its mode:

``project``
    the proposal if the guard allows it, else the allowed action nearest it (Euclidean, each
    component's difference divided by its ``scale``);
``replace``
    the proposal if allowed, else the adapter's fallback action.

Every executed action is confirmed by the ordinary guard evaluation (the evaluator's float
arithmetic); when none is (nothing allowed, or a set :mod:`~tracecheck.b.linear` cannot
project onto), the fallback action is taken and the step is marked a deadlock — the shield
fails closed, and says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Sequence

import numpy as np

from ..b.linear import AllowedSet, linear_form, parameter_range, real_parameters
from ..errors import InputError, UnsupportedError

__all__ = ["ContinuousShield", "Decision", "MODES", "interval_pairs"]

#: how a continuous shield makes an action allowed
MODES = ("project", "replace")


@dataclass(frozen=True)
class Decision:
    """What the shield did with one proposal."""

    executed: np.ndarray  # the action vector taken
    parameters: dict[str, float]  # the executed values, by parameter name
    proposal: dict[str, float]  # the agent's values (moved into the space's bounds)
    distance: float  # between them, in the shield's scale
    intervened: bool  # the executed action is not the proposal
    deadlock: bool  # no action confirmed: the fallback was taken


class ContinuousShield:
    """The continuous side of a live shield (see the module docstring): built once per
    environment, it checks the declaration against the machine and the action space."""

    def __init__(self, machine, adapter, space, *, mode: str = "project",
                 scale: Optional[Sequence[float]] = None) -> None:
        if mode not in MODES:
            raise InputError(f"unknown shield mode {mode!r}; the modes are {', '.join(MODES)}")
        where = f"the adapter {adapter.name}"
        if len(adapter.parameters) != 1 or tuple(adapter.actions) != tuple(adapter.parameters):
            raise InputError(f"{where} declares parameters for {', '.join(adapter.parameters)} "
                             f"and the actions {', '.join(adapter.actions)}: a Box action "
                             "space is one operation, the only action, whose parameters "
                             "take the components",
                             hint='actions = ("DRIVE",); parameters = {"DRIVE": ("a", "s")}')
        (self.op, params), = adapter.parameters.items()
        self.params = tuple(params)
        low, high, shape = (getattr(space, k, None) for k in ("low", "high", "shape"))
        if low is None or high is None or shape is None or len(shape) != 1:
            raise InputError(f"{where} declares continuous parameters, but the environment's "
                             f"action space is {space}, not a one-dimensional Box")
        if shape[0] != len(self.params):
            raise InputError(f"{where} names {len(self.params)} parameter(s) "
                             f"({', '.join(self.params)}) for {self.op}, but the action space "
                             f"{space} has {shape[0]} component(s)")
        self.low = np.asarray(low, dtype=np.float64)
        self.high = np.asarray(high, dtype=np.float64)
        #: the float type the environment takes its actions in (float32 for most)
        kind = np.dtype(getattr(space, "dtype", np.float64))
        self.dtype = kind if kind.kind == "f" else np.dtype(np.float64)
        self._low = dict(zip(self.params, self.low.tolist()))
        self._high = dict(zip(self.params, self.high.tolist()))
        self.machine, self.mode = machine, mode
        self.scale = self._scale(scale)
        self.fallback = self._fallback(adapter, where)
        self._check_operation(where)
        self.allowed: Optional[AllowedSet] = None
        self.problem: Optional[str] = None  # why nothing could be confirmed, if so

    def _scale(self, scale: Optional[Sequence[float]]) -> np.ndarray:
        if scale is None:
            return np.ones(len(self.params))
        scale = np.asarray([float(s) for s in scale], dtype=np.float64)
        if scale.shape != (len(self.params),) or not np.all(np.isfinite(scale)) or \
                not np.all(scale > 0):
            raise InputError(f"--scale takes {len(self.params)} positive number(s), one per "
                             f"component ({', '.join(self.params)}), not "
                             f"{', '.join(map(str, scale.tolist()))}")
        return scale

    def _fallback(self, adapter, where: str) -> np.ndarray:
        declared = adapter.fallback_action
        if declared is None:
            return np.clip(np.zeros(len(self.params)), self.low, self.high)
        try:
            fallback = np.asarray([float(v) for v in declared], dtype=self.dtype
                                  ).astype(np.float64)  # as the environment will get it
        except (TypeError, ValueError):
            fallback = np.zeros(0)
        if fallback.shape != (len(self.params),) or not np.all(np.isfinite(fallback)) or \
                np.any(fallback < self.low) or np.any(fallback > self.high):
            raise InputError(f"{where} has fallback_action = {declared!r}; it must be "
                             f"{len(self.params)} finite number(s) within the action space's "
                             f"bounds {self.low.tolist()} … {self.high.tolist()}")
        return fallback

    def _check_operation(self, where: str) -> None:
        """Before any episode: the operation exists, its parameters are the declared ones,
        typed REAL, and none is also a state variable."""
        machine = self.machine
        op = machine.operation(self.op)
        if tuple(op.params) != self.params:
            raise InputError(f"{where} binds the components of its action to "
                             f"{self.op}({', '.join(self.params)}), but the shield "
                             f"{machine.name} has {self.op}({', '.join(op.params)})",
                             hint="name the parameters in the operation's order")
        if not real_parameters(op):
            raise InputError(f"the operation {self.op} of {machine.name} must type each "
                             f"parameter REAL in its guard (PRE {self.params[0]} : REAL & …) to "
                             "take a continuous action")
        try:
            linear_form(machine, self.op)
        except UnsupportedError as exc:
            raise InputError(f"the shield {machine.name} cannot decide {self.op}'s continuous "
                             f"actions: {exc.message}",
                             hint="write the guard linear in the parameters once the state is "
                                  "known (docs/continuous.md); tracecheck guards --state "
                                  "shows the allowed set") from None
        clash = [p for p in self.params if p in machine.variables]
        if clash:
            raise InputError(f"the parameter {clash[0]} of {self.op} is also a variable of "
                             f"{machine.name}; give it another name")
        try:
            own = parameter_range(machine, self.op)
        except UnsupportedError:
            own = None  # not linear: every state's allowed set says so
        if own is not None and own.separable and own.within(self._low, self._high).distance(
                {p: 0.0 for p in self.params}) is None:
            raise InputError(f"the guard of {self.op} in {machine.name} allows only {own}, "
                             f"none of it within the action space's bounds "
                             f"{self.low.tolist()} … {self.high.tolist()}: no action could "
                             "ever be allowed",
                             hint="check the parameters' order and units against the "
                                  "environment's action space")

    # -- one state
    def decide(self, env: dict) -> None:
        """The allowed set in the state of ``env`` (a machine environment), kept for
        :meth:`filter`."""
        from ..b.linear import allowed_set

        self.problem = None
        try:
            self.allowed = allowed_set(self.machine, self.op, env=env).within(
                self._low, self._high)
        except UnsupportedError as exc:
            self.allowed, self.problem = None, str(exc)

    def any_allowed(self) -> bool:
        """Whether some action is allowed in the state :meth:`decide` saw."""
        if self.allowed is None:
            return False
        try:
            return self.allowed.witness() is not None
        except UnsupportedError as exc:
            self.problem = str(exc)
            return False

    def bands(self) -> Optional[dict[str, tuple[tuple[Optional[float], Optional[float]], ...]]]:
        """The allowed intervals of each parameter (see :meth:`AllowedSet.bands`)."""
        bands = self.allowed.bands() if self.allowed is not None else None
        return None if bands is None else {p: interval_pairs(b) for p, b in bands.items()}

    def filter(self, action: Any) -> Decision:
        """The action taken for the agent's ``action`` in the state :meth:`decide` saw."""
        proposal = np.clip(_vector(action, len(self.params)), self.low, self.high)
        point = dict(zip(self.params, proposal.tolist()))
        allowed = self.allowed
        executed: Optional[np.ndarray] = None
        as_is = self._sendable(proposal) if allowed is not None else None
        if as_is is not None:
            executed = as_is
        elif allowed is not None and self.mode == "project":
            try:
                nearest = allowed.nearest(point, dict(zip(self.params, self.scale.tolist())))
            except UnsupportedError as exc:  # too many constraints to project onto
                nearest, self.problem = None, str(exc)
            if nearest is not None:
                executed = self._sendable(
                    np.array([nearest[p] for p in self.params], dtype=np.float64), proposal)
        elif allowed is not None:  # replace: the fallback, or the nearest allowed to it
            executed = self._sendable(self.fallback)
            if executed is None:
                try:
                    near = allowed.nearest(dict(zip(self.params, self.fallback.tolist())))
                except UnsupportedError as exc:
                    near, self.problem = None, str(exc)
                if near is not None:
                    executed = self._sendable(
                        np.array([near[p] for p in self.params], dtype=np.float64),
                        self.fallback)
        deadlock = executed is None
        if deadlock:
            executed = self.fallback.copy()
        distance = float(np.sqrt(np.sum(((executed - proposal) / self.scale) ** 2)))
        return Decision(executed=executed,
                        parameters=dict(zip(self.params, executed.tolist())),
                        proposal=point, distance=distance,
                        intervened=bool(np.any(executed != proposal)), deadlock=deadlock)


    def _sendable(self, action: np.ndarray,
                  away: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
        """``action`` as the environment receives it (in its action space's float type: a
        float32 space rounds it), if the guard allows that value; with ``away`` (a refused
        proposal that ``action`` was projected from), else the nearest value of that type
        a few steps further from it that the guard allows; None if none."""
        sent = np.asarray(action, dtype=self.dtype)
        direction = np.sign(action - away) if away is not None else None
        for _ in range(NUDGES if direction is not None else 1):
            value = sent.astype(np.float64)
            if np.all(value >= self.low) and np.all(value <= self.high) and \
                    self.allowed.contains(dict(zip(self.params, value.tolist()))):
                return value
            if direction is None or not np.any(direction):
                return None
            sent = np.where(direction != 0, np.nextafter(
                sent, (direction * np.inf).astype(self.dtype)), sent).astype(self.dtype)
        return None


#: how many values of the action space's float type past a projected point are tried
NUDGES = 64


def _vector(action: Any, n: int) -> np.ndarray:
    try:
        vector = np.asarray(action, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"the agent's action {action!r} is not a vector of numbers") from None
    if vector.shape != (n,) or not np.all(np.isfinite(vector)):
        raise InputError(f"the agent's action {vector.tolist()} is not {n} finite number(s)")
    return vector


def interval_pairs(intervals) -> tuple[tuple[Optional[float], Optional[float]], ...]:
    """Intervals as (low, high) floats, None for an unbounded end (what files and plots
    keep: open and closed ends alike)."""
    return tuple((None if i.low is None else float(i.low),
                  None if i.high is None else float(i.high)) for i in intervals)
