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

**Hybrid action spaces** — a discrete choice of operation, each with its own parameters —
are Gymnasium's ``Tuple((Discrete(n), Tuple((Box, …, Box))))`` (one ``Box`` per action, in
the order of the adapter's ``actions``; an operation without parameters ignores its own) or
``Tuple((Discrete(n), Box(k)))`` (every operation with parameters takes all ``k``
components). The adapter declares the parameters of each operation that has some. The
agent acts with one vector (the parameterised-action convention of P-DQN and PA-DDPG, so
that any ``Box`` learner — SAC, TD3, PPO — drives it): ``n`` scores, one per operation,
then the parameters of each operation that has some, in the order of ``actions``; or with
the environment's own ``(index, parameters)`` pair. Their modes:

``mask`` (the default)
    the discrete part as for discrete actions — the best-scored operation among those the
    shield enables (an operation with parameters is enabled when some values within the
    space's bounds are allowed) — and its parameters projected onto its allowed set;
``replace``
    the proposal if allowed, else the fallback operation with the fallback action; where the
    shield refuses that too, the best-scored enabled operation, as ``mask`` takes it.

Where the guard is not linear in the parameters the allowed set is the solver's
(:mod:`tracecheck.checking.solved_set`: z3, within ``solver_timeout_s`` per state and
operation); a guard it cannot translate either is refused when the shield is built.

Every executed action is confirmed by the ordinary guard evaluation (the evaluator's float
arithmetic); when none is (nothing allowed, or a set :mod:`~tracecheck.b.linear` cannot
project onto), the fallback action is taken and the step is marked a deadlock — the shield
fails closed, and says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

import numpy as np

from ..b.linear import (AllowedSet, linear_form, parameter_range, real_parameters,
                        real_typed)
from ..errors import InputError, TracecheckError, UnsupportedError

__all__ = ["ContinuousShield", "Decision", "MODES", "interval_pairs", "space_parts", "action_bounds",
           "SpacePart"]

#: how a continuous shield makes an action allowed (``mask``: hybrid spaces only)
MODES = ("project", "replace", "mask")


@dataclass(frozen=True)
class Decision:
    """What the shield did with one proposal."""

    executed: np.ndarray  # the executed operation's parameter values (none: no parameters)
    parameters: dict[str, float]  # the executed values, by parameter name
    proposal: dict[str, float]  # the agent's values of the operation it proposed (moved
    #                              into the space's bounds)
    distance: Optional[float]  # between them, in the shield's scale (None: the operation
    #                            changed, a hybrid space's)
    intervened: bool  # the executed action is not the proposal
    deadlock: bool  # no action confirmed: the fallback was taken
    op: str = ""  # the operation executed
    proposed_op: str = ""  # the operation the agent proposed
    sent: Any = None  # what the environment's step receives
    scores: Optional[dict[str, float]] = None  # a hybrid agent's score of each operation
    cast: bool = False  # the proposal is not a value of the space's float type: the
    #                     environment receives it rounded (not an intervention)


@dataclass(frozen=True)
class SpacePart:
    """The components of an action space one operation's REAL parameters take."""

    op: str
    params: tuple[str, ...]
    low: np.ndarray  # float64
    high: np.ndarray
    dtype: np.dtype  # the float type the environment takes them in


def action_bounds(adapter, config: Optional[dict] = None) -> dict[str, tuple[dict, dict]]:
    """The bounds the environment's action space puts on each operation's REAL parameters
    and their float type, ``{op: ({p: low}, {p: high}, {p: "float32"})}`` (an infinite end
    left out): what ``prove --env`` and ``guards --env`` take, as the live shield does.

    Args:
        adapter: an adapter that declares ``parameters``.
        config: the environment's configuration (None: its default).

    Returns:
        The bounds; empty for an adapter of discrete actions.
    """
    if not adapter.parameters:
        return {}
    env = adapter.make_env(config if config is not None else adapter.config(None))
    try:
        space = env.action_space
    finally:
        env.close()
    _, parts = space_parts(adapter, space)
    out = {}
    for part in parts:
        low = {p: float(v) for p, v in zip(part.params, part.low) if np.isfinite(v)}
        high = {p: float(v) for p, v in zip(part.params, part.high) if np.isfinite(v)}
        out[part.op] = (low, high, dict.fromkeys(part.params, part.dtype.name))
    return out


def space_parts(adapter, space) -> tuple[bool, tuple[SpacePart, ...]]:
    """(hybrid, the parts of each operation with parameters, in the order of the adapter's
    actions) of an adapter that declares ``parameters`` for ``space``; an
    :class:`InputError` saying what fits when the space is neither a one-dimensional
    ``Box`` for its one action nor a hybrid space (module docstring)."""
    where = f"the adapter {adapter.name}"
    actions, declared = tuple(adapter.actions), dict(adapter.parameters)
    unknown = [op for op in declared if op not in actions]
    if unknown:
        raise InputError(f"{where} declares parameters for {unknown[0]}, which is not one of "
                         f"its actions ({', '.join(actions)})")
    inner = getattr(space, "spaces", None)
    if inner is None:  # a Box: one operation takes every component
        if len(actions) != 1 or tuple(declared) != actions:
            raise InputError(f"{where} declares parameters for {', '.join(declared)} and the "
                             f"actions {', '.join(actions)}, but the environment's action "
                             f"space {space} is one Box: one operation, the only action, "
                             "whose parameters take the components",
                             hint='actions = ("DRIVE",); parameters = {"DRIVE": ("a", "s")}; '
                                  "or a hybrid space Tuple((Discrete(n), Tuple((Box, …))))")
        return False, (_part(where, actions[0], declared[actions[0]], space),)
    choice = inner[0] if isinstance(inner, (tuple, list)) and len(inner) == 2 else None
    if getattr(choice, "n", None) is None or getattr(choice, "start", 0) != 0:
        raise InputError(f"{where} declares continuous parameters, but the environment's "
                         f"action space {space} is neither a one-dimensional Box nor a "
                         "hybrid Tuple((Discrete(n), Tuple((Box, …)))) or "
                         "Tuple((Discrete(n), Box(k)))")
    if int(choice.n) != len(actions):
        raise InputError(f"{where} has {len(actions)} actions ({', '.join(actions)}); the "
                         f"discrete part of the environment's action space {space} has "
                         f"{int(choice.n)}")
    boxes = getattr(inner[1], "spaces", None)
    if boxes is not None and len(boxes) != len(actions):
        raise InputError(f"the environment's action space {space} has {len(boxes)} "
                         f"parameter spaces; {where} has {len(actions)} actions "
                         f"({', '.join(actions)}): one Box per action, in order")
    parts = tuple(_part(where, op, declared[op], boxes[i] if boxes is not None else inner[1])
                  for i, op in enumerate(actions) if declared.get(op))
    return True, parts


def _part(where: str, op: str, params: Sequence[str], box) -> SpacePart:
    low, high, shape = (getattr(box, k, None) for k in ("low", "high", "shape"))
    if low is None or high is None or shape is None or len(shape) != 1:
        raise InputError(f"{where} declares continuous parameters for {op}, but its action "
                         f"space is {box}, not a one-dimensional Box")
    if shape[0] != len(params):
        raise InputError(f"{where} names {len(params)} parameter(s) ({', '.join(params)}) "
                         f"for {op}, but its action space {box} has {shape[0]} component(s)")
    kind = np.dtype(getattr(box, "dtype", None) or np.float64)
    if kind.kind != "f":  # 1.5 projected would reach it as 1, recorded as 1.5
        raise InputError(f"{where} declares continuous parameters for {op}, but its action "
                         f"space {box} takes {kind} values: the shield decides REAL ones, "
                         "and a value it allows could reach the environment rounded to one "
                         "it does not",
                         hint="give the environment a float Box (dtype=np.float32 or "
                              "float64), or make the choice discrete (Discrete(n), one "
                              "operation per value)")
    if kind.name not in ("float16", "float32", "float64"):  # tracecheck's floats are float64
        raise InputError(f"{where} declares continuous parameters for {op}, but its action "
                         f"space {box} takes {kind} values, wider than the float64 values "
                         "tracecheck decides and records",
                         hint="give the environment a Box of dtype=np.float32 or float64")
    return SpacePart(op, tuple(params), np.asarray(low, dtype=np.float64),
                     np.asarray(high, dtype=np.float64), kind)


@dataclass
class _Op:
    """One operation with parameters, as the shield keeps it: its part of the space, scale
    and the allowed set in the state last decided."""

    part: SpacePart
    scale: np.ndarray
    low: dict = field(default_factory=dict)  # by parameter name
    high: dict = field(default_factory=dict)
    allowed: Optional[AllowedSet] = None  # or a SolvedSet (the solver decides)
    solver: bool = False  # the guard is not linear in the parameters: z3 decides

    def __post_init__(self) -> None:
        self.low = dict(zip(self.part.params, self.part.low.tolist()))
        self.high = dict(zip(self.part.params, self.part.high.tolist()))
        #: each parameter's (low, high), in order
        self.bounds = tuple(zip(self.part.low.tolist(), self.part.high.tolist()))
        #: each parameter's float type (what the environment receives)
        self.floats = dict.fromkeys(self.part.params, self.part.dtype.name)


class ContinuousShield:
    """The continuous side of a live shield (see the module docstring): built once per
    environment, it checks the declaration against the machine and the action space."""

    def __init__(self, machine, adapter, space, *, mode: Optional[str] = None,
                 scale: Optional[Sequence[float]] = None,
                 solver_timeout_s: Optional[float] = None) -> None:
        from ..checking.solved_set import DEFAULT_BUDGET_S

        where = f"the adapter {adapter.name}"
        #: the solver's time per state and operation, for a guard not linear in its
        #: parameters (:mod:`tracecheck.checking.solved_set`)
        self.solver_timeout_s = DEFAULT_BUDGET_S if solver_timeout_s is None else \
            float(solver_timeout_s)
        self.hybrid, parts = space_parts(adapter, space)
        mode = mode or ("mask" if self.hybrid else "project")
        if mode not in MODES:
            raise InputError(f"unknown shield mode {mode!r}; the modes are {', '.join(MODES)}")
        if (mode == "mask") != (self.hybrid and mode != "replace"):
            raise InputError(f"--shield-mode {mode} does not fit {adapter.name}'s action "
                             f"space {space}",
                             hint="a hybrid space (a discrete choice with parameters) takes "
                                  "mask or replace; a Box takes project or replace")
        self.machine, self.mode, self.space = machine, mode, space
        self.actions = tuple(adapter.actions)
        scales = self._scale(scale, parts)
        self.ops = {p.op: _Op(p, s) for p, s in zip(parts, scales)}
        #: every component, in order (the run header's): names, bounds, scale
        self.params = tuple(n for p in parts for n in p.params)
        self.low = np.concatenate([p.low for p in parts])
        self.high = np.concatenate([p.high for p in parts])
        self.scale = np.concatenate(scales)
        for op in self.ops:
            self._check_operation(op, where)
        self.fallback_op = adapter.fallback or self.actions[0]
        if self.fallback_op not in self.actions:
            raise InputError(f"{where} has fallback = {self.fallback_op!r}, not one of its "
                             f"actions ({', '.join(self.actions)})")
        self.fallback = self._fallback(adapter, where)
        if not self.hybrid:  # the one operation's
            self.op, self.dtype = parts[0].op, parts[0].dtype
        self.enabled: set[str] = set()
        self.problem: Optional[str] = None  # why nothing could be confirmed, if so

    @property
    def allowed(self) -> Optional[AllowedSet]:
        """A Box's one operation: its allowed set in the state :meth:`decide` saw."""
        return next(iter(self.ops.values())).allowed if not self.hybrid else None

    @property
    def agent_space(self):
        """The action space an agent acts in: the environment's for a Box; for a hybrid
        space one Box of a score per operation (-1 … 1) and then every parameter."""
        if not self.hybrid:
            return self.space
        from gymnasium import spaces

        n = len(self.actions)
        return spaces.Box(np.concatenate([-np.ones(n), self.low]).astype(np.float32),
                          np.concatenate([np.ones(n), self.high]).astype(np.float32),
                          dtype=np.float32)

    def _scale(self, scale: Optional[Sequence[float]], parts) -> list[np.ndarray]:
        names = [n for p in parts for n in p.params]
        if scale is None:
            values = np.ones(len(names))
        else:
            values = np.asarray([float(s) for s in scale], dtype=np.float64)
            if values.shape != (len(names),) or not np.all(np.isfinite(values)) or \
                    not np.all(values > 0):
                raise InputError(f"--scale takes {len(names)} positive number(s), one per "
                                 f"component ({', '.join(names)}), not "
                                 f"{', '.join(map(str, values.tolist()))}")
        cuts = np.cumsum([len(p.params) for p in parts])[:-1]
        return list(np.split(values, cuts))

    def _fallback(self, adapter, where: str) -> np.ndarray:
        """The fallback operation's parameter values (none for one without parameters)."""
        declared = adapter.fallback_action
        entry = self.ops.get(self.fallback_op)
        if entry is None:
            if declared:
                raise InputError(f"{where} has fallback_action = {declared!r}, but its "
                                 f"fallback {self.fallback_op} takes no parameters",
                                 hint="leave fallback_action out (or None) for a fallback "
                                      "without parameters")
            return np.zeros(0)
        part = entry.part
        if declared is None:
            return np.clip(np.zeros(len(part.params)), part.low, part.high)
        try:
            fallback = np.asarray([float(v) for v in declared], dtype=part.dtype
                                  ).astype(np.float64)  # as the environment will get it
        except (TypeError, ValueError):
            fallback = np.zeros(0)
        if fallback.shape != (len(part.params),) or not np.all(np.isfinite(fallback)) or \
                np.any(fallback < part.low) or np.any(fallback > part.high):
            raise InputError(f"{where} has fallback_action = {declared!r}; it must be "
                             f"{len(part.params)} finite number(s) within the action space's "
                             f"bounds {_bounds_text(part)}")
        return fallback

    def _check_operation(self, name: str, where: str) -> None:
        """Before any episode: the operation exists, its parameters are the declared ones,
        typed REAL, and none is also a state variable."""
        machine, entry = self.machine, self.ops[name]
        params = entry.part.params
        op = machine.operation(name)
        if tuple(op.params) != params:
            raise InputError(f"{where} binds the components of its action to "
                             f"{name}({', '.join(params)}), but the shield "
                             f"{machine.name} has {name}({', '.join(op.params)})",
                             hint="name the parameters in the operation's order")
        if not real_parameters(op):
            untyped = [p for p in params if p not in real_typed(op)]
            raise InputError(f"the operation {name} of {machine.name} must type each "
                             f"parameter REAL in its guard to take a continuous action; "
                             f"{' and '.join(f'`{p} : REAL`' for p in untyped)} is not in it",
                             file=machine.file, source=machine.source if op.pos else None,
                             line=op.pos.line if op.pos else None,
                             column=op.pos.column if op.pos else None,
                             hint=f"add `{untyped[0]} : REAL` to its guard (PRE {untyped[0]} "
                                  ": REAL & …); an INTEGER choice is a discrete action")
        try:
            linear_form(machine, name)
        except UnsupportedError as exc:  # not linear: the solver decides, if it can
            from ..checking.solved_set import check_solvable

            try:
                check_solvable(machine, name)
            except UnsupportedError as solver:
                raise InputError(f"the shield {machine.name} cannot decide {name}'s "
                                 f"continuous actions: {exc.message}; nor can the solver: "
                                 f"{solver.message}",
                                 hint="write the guard linear in the parameters once the "
                                      "state is known, or in what the solver translates "
                                      "(docs/continuous.md)") from None
            entry.solver = True
        clash = [p for p in params if p in machine.variables]
        if clash:
            raise InputError(f"the parameter {clash[0]} of {name} is also a variable of "
                             f"{machine.name}; give it another name")
        try:
            own = parameter_range(machine, name)
        except UnsupportedError:
            own = None  # not linear: every state's allowed set says so
        if own is not None and own.separable and own.within(entry.low, entry.high).distance(
                {p: 0.0 for p in params}) is None:
            raise InputError(f"the guard of {name} in {machine.name} allows only {own}, "
                             f"none of it within the action space's bounds "
                             f"{_bounds_text(entry.part)}: no action could ever be allowed",
                             hint="check the parameters' order and units against the "
                                  "environment's action space")

    # -- one state
    def decide(self, env: dict) -> None:
        """The allowed sets (and, for a hybrid space, the enabled operations) in the state
        of ``env`` (a machine environment), kept for :meth:`filter`."""
        from ..b.linear import allowed_set
        from ..checking.solved_set import solved_set

        self.problem = None
        for name, entry in self.ops.items():
            try:
                found = solved_set(self.machine, name, env=env,
                                   timeout_s=self.solver_timeout_s) if entry.solver else \
                    allowed_set(self.machine, name, env=env)
                entry.allowed = found.within(entry.low, entry.high, entry.floats)
            except TracecheckError as exc:  # undecided, a limit, a value it has not: it
                entry.allowed, self.problem = None, str(exc)  # cannot tell, so not allowed
        self.enabled = {name for name in self.actions if self._enabled(name, env)}

    def _enabled(self, name: str, env: dict) -> bool:
        entry = self.ops.get(name)
        try:
            if entry is None:
                return self.machine.is_enabled_in(name, env)
            return entry.allowed is not None and entry.allowed.witness() is not None
        except TracecheckError as exc:  # it cannot tell: not allowed (fails closed), and why
            self.problem = str(exc)
            return False

    def any_allowed(self) -> bool:
        """Whether some action is allowed in the state :meth:`decide` saw."""
        return bool(self.enabled)

    def bands(self, op: Optional[str] = None
              ) -> Optional[dict[str, tuple[tuple[Optional[float], Optional[float]], ...]]]:
        """The allowed intervals of each parameter of ``op`` (by default a Box's one
        operation; see :meth:`AllowedSet.bands`)."""
        entry = self.ops.get(op) if op is not None else \
            (None if self.hybrid else next(iter(self.ops.values())))
        bands = entry.allowed.bands() if entry is not None and entry.allowed is not None \
            else None
        return None if bands is None else {p: interval_pairs(b) for p, b in bands.items()}

    def filter(self, action: Any) -> Decision:
        """The action taken for the agent's ``action`` in the state :meth:`decide` saw."""
        if self.hybrid:
            return self._filter_hybrid(action)
        (op, entry), = self.ops.items()
        proposal = np.array([min(hi, max(lo, v)) for v, (lo, hi) in  # np.clip's, a tie
                             zip(_vector(action, len(self.params)).tolist(), entry.bounds)])
        #                                      (-0.0 at a bound 0.0) going to the bound
        executed = self._allowed_values(entry, proposal, project=self.mode == "project")
        if executed is None and self.mode == "replace":
            executed = self._allowed_values(entry, self.fallback, project=True)
        deadlock = executed is None
        if deadlock:
            executed = self.fallback.copy()
        return self._decision(op, executed, op, proposal, deadlock)

    def _allowed_values(self, entry: _Op, proposal: np.ndarray, *,
                        project: bool) -> Optional[np.ndarray]:
        """``proposal`` (an operation's values) if the guard allows it as the environment
        receives it; else, with ``project``, the allowed values nearest it; else None."""
        if entry.allowed is None:
            return None
        as_is = self._sendable(entry, proposal)
        if as_is is not None or not project:
            return as_is
        params = entry.part.params
        try:
            nearest = entry.allowed.nearest(dict(zip(params, proposal.tolist())),
                                            dict(zip(params, entry.scale.tolist())))
        except TracecheckError as exc:  # too many constraints, a limit: nothing confirmed
            nearest, self.problem = None, str(exc)
        if nearest is None:
            return None
        return self._sendable(entry, np.array([nearest[p] for p in params],
                                              dtype=np.float64), proposal)

    def _filter_hybrid(self, action: Any) -> Decision:
        scores, proposed, values = self._hybrid_proposal(action)
        entry = self.ops.get(proposed)
        proposal = np.clip(values, entry.part.low, entry.part.high) if entry is not None \
            else np.zeros(0)
        chosen: Optional[tuple[str, np.ndarray]] = None
        if self.mode == "replace":
            if proposed in self.enabled:
                kept = self._allowed_values(entry, proposal, project=False) \
                    if entry is not None else proposal
                chosen = (proposed, kept) if kept is not None else None
            if chosen is None and self.fallback_op in self.enabled:
                fallback = self.ops.get(self.fallback_op)
                kept = self._allowed_values(fallback, self.fallback, project=True) \
                    if fallback is not None else self.fallback
                chosen = (self.fallback_op, kept) if kept is not None else None
        if chosen is None:  # mask, or a refused fallback: the best-scored enabled operation,
            #                 its values projected
            for i in sorted((i for i, a in enumerate(self.actions) if a in self.enabled),
                            key=lambda i: -scores[i]):
                op = self.actions[i]
                mine = self.ops.get(op)
                if mine is None:
                    chosen = (op, np.zeros(0))
                    break
                start = proposal if op == proposed else \
                    np.clip(self._values_of(op, action), mine.part.low, mine.part.high)
                kept = self._allowed_values(mine, start, project=True)
                if kept is not None:
                    chosen = (op, kept)
                    break
        deadlock = chosen is None
        op, executed = (self.fallback_op, self.fallback.copy()) if deadlock else chosen
        return self._decision(op, executed, proposed, proposal, deadlock,
                              dict(zip(self.actions, scores.tolist())))

    def _decision(self, op: str, executed: np.ndarray, proposed: str, proposal: np.ndarray,
                  deadlock: bool, scores: Optional[dict] = None) -> Decision:
        entry = self.ops.get(op)
        params = entry.part.params if entry is not None else ()
        same = op == proposed
        mine = self.ops.get(proposed)
        done, asked = executed.tolist(), proposal.tolist()
        # the proposal as the environment receives it (a float32 space rounds a float64
        # 0.3): the shield intervened only where it executed something else
        as_sent = asked if mine is None or mine.part.dtype == np.float64 else \
            proposal.astype(mine.part.dtype).astype(np.float64).tolist()
        intervened = not same or done != as_sent
        distance = (_norm([(x - p) / s for x, p, s in zip(done, asked, entry.scale.tolist())])
                    if len(done) <= 2 else  # numpy's order of summing, then, is its own
                    float(np.sqrt(np.sum(((executed - proposal) / entry.scale) ** 2)))) \
            if same and entry is not None and intervened else (0.0 if same else None)
        return Decision(
            executed=executed, parameters=dict(zip(params, done)),
            proposal=dict(zip(mine.part.params, asked)) if mine else {},
            distance=distance, intervened=intervened,
            deadlock=deadlock, op=op, proposed_op=proposed, sent=self._sent(op, executed),
            scores=scores, cast=as_sent != asked)

    # -- hybrid actions in and out
    def _hybrid_proposal(self, action: Any) -> tuple[np.ndarray, str, np.ndarray]:
        """(a score per operation, the proposed operation, its values) of a hybrid agent's
        action: the flat vector of :attr:`agent_space` or the environment's own pair."""
        n = len(self.actions)
        if isinstance(action, (tuple, list)) and len(action) == 2 and \
                not isinstance(action[0], (float, np.floating)):
            choice = action[0]
            index = self.actions.index(choice) if choice in self.actions else \
                _index(choice, n)
            scores = np.zeros(n)
            scores[index] = 1.0
            op = self.actions[index]
            return scores, op, self._values_of(op, action)
        vector = _vector(action, n + len(self.params))
        scores = vector[:n]
        op = self.actions[int(np.argmax(scores))]
        return scores, op, self._values_of(op, vector)

    def _values_of(self, op: str, action: Any) -> np.ndarray:
        """``op``'s values in a hybrid action (flat or the environment's pair)."""
        entry = self.ops.get(op)
        if entry is None:
            return np.zeros(0)
        k = len(entry.part.params)
        if isinstance(action, np.ndarray):  # flat: scores, then each operation's values
            offset = len(self.actions)
            for other in self.ops.values():
                if other is entry:
                    return action[offset:offset + k]
                offset += len(other.part.params)
        inner = action[1]
        if isinstance(inner, dict):
            return np.array([float(inner[p]) for p in entry.part.params])
        if isinstance(inner, (tuple, list)) and len(inner) == len(self.actions) and \
                getattr(self.space.spaces[1], "spaces", None) is not None:
            inner = inner[self.actions.index(op)]
        return _vector(inner, k)

    def _sent(self, op: str, executed: np.ndarray) -> Any:
        """What the environment's step receives for ``op`` with ``executed``."""
        if not self.hybrid:
            return executed.astype(self.dtype)
        index = self.actions.index(op)
        inner = self.space.spaces[1]
        boxes = getattr(inner, "spaces", None)

        def filled(box, values=None):
            if values is not None and len(values):
                return np.asarray(values, dtype=box.dtype).reshape(box.shape)
            return np.clip(np.zeros(box.shape), box.low, box.high).astype(box.dtype)
        if boxes is None:
            return (index, filled(inner, executed))
        return (index, tuple(filled(box, executed if i == index else None)
                             for i, box in enumerate(boxes)))

    def _sendable(self, entry: _Op, action: np.ndarray,
                  away: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
        """``action`` as the environment receives it (in its action space's float type: a
        float32 space rounds it), if the guard allows that value; with ``away`` (a refused
        proposal that ``action`` was projected from), else the nearest value of that type
        a few steps further from it that the guard allows; None if none. Where ``action``
        is the proposal itself (allowed over the reals, refused as the space's type rounds
        it: 1e-116 is 0.0 in float32, and b > 0 refuses that), the steps go from the rounded
        value back towards ``action``."""
        part, params = entry.part, entry.part.params
        if away is None and part.dtype == np.float64:  # as it is: no rounding, no steps
            listed = action.tolist()
            if all(lo <= v <= hi for v, (lo, hi) in zip(listed, entry.bounds)) and \
                    entry.allowed.contains(dict(zip(params, listed))):
                return np.array(listed)
            return None
        sent = np.asarray(action, dtype=part.dtype)
        direction = None
        if away is not None:
            drift = np.sign(action - sent.astype(np.float64))
            direction = np.sign(action - away)
            direction = np.where(direction != 0, direction, drift)
        bounds = entry.bounds
        for _ in range(NUDGES if direction is not None else 1):
            value = sent.astype(np.float64)
            listed = value.tolist()
            if all(lo <= v <= hi for v, (lo, hi) in zip(listed, bounds)) and \
                    entry.allowed.contains(dict(zip(params, listed))):
                return value
            if direction is None or not np.any(direction):
                return None
            sent = np.where(direction != 0, np.nextafter(
                sent, np.where(direction > 0, np.inf, -np.inf).astype(part.dtype)),
                sent).astype(part.dtype)
        return None


#: how many values of the action space's float type past a projected point are tried
NUDGES = 64


def _norm(steps: list[float]) -> float:
    """The length of a vector of one or two components, as numpy computes it (each square
    a product, added in order: the same float)."""
    return math.sqrt(sum(d * d for d in steps))


def _bounds_text(part) -> str:
    """An action space part's bounds by parameter: ``a ∈ [-4.0, 2.0], s ∈ [-1.0, 1.0]``."""
    return ", ".join(f"{p} ∈ [{lo}, {hi}]" for p, lo, hi in
                     zip(part.params, part.low.tolist(), part.high.tolist()))


def _vector(action: Any, n: int) -> np.ndarray:
    try:
        vector = np.asarray(action, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"the agent's action {action!r} is not a vector of numbers") from None
    if vector.shape != (n,) or not all(map(math.isfinite, vector.tolist())):
        raise InputError(f"the agent's action {vector.tolist()} is not {n} finite number(s)")
    return vector


def _index(choice: Any, n: int) -> int:
    try:
        index = int(choice)
    except (TypeError, ValueError):
        index = -1
    if not 0 <= index < n or index != choice:
        raise InputError(f"the agent's choice {choice!r} is not an action index 0 … {n - 1}")
    return index


def interval_pairs(intervals) -> tuple[tuple[Optional[float], Optional[float]], ...]:
    """Intervals as (low, high) floats, None for an unbounded end (what files and plots
    keep: open and closed ends alike)."""
    return tuple((None if i.low is None else float(i.low),
                  None if i.high is None else float(i.high)) for i in intervals)
