"""Pre-shielding (the paper's Fig. 3): the shield allows, the agent chooses among what it allows.

:class:`ShieldWrapper` is a ``gymnasium.Wrapper`` around any environment with an adapter
(:mod:`tracecheck.live.adapter`; when none is given, the installed adapter whose ``env_id``
is the environment's Gymnasium id): after each reset and step it turns the observation into
the B state (numpy values converted exactly, see :func:`tracecheck.b.state.native_state`),
asks the shield which actions are enabled, exposes
them as ``action_masks()`` (the sb3-contrib MaskablePPO convention) and reports the decision,
the B state and whether the step crashed in ``info``. Any agent can so be shielded, in
training too. When the shield allows nothing it fails closed: the step is a deadlock and the
fallback action (the adapter's ``fallback``) is taken, and said so.

For continuous actions (an adapter that declares ``parameters`` for a ``Box`` action space)
``step`` takes the agent's action vector and executes the proposal if the shield allows it,
else by the mode (``project``: the nearest allowed action; ``replace``: the fallback action);
``info["shield"]`` holds the ``proposal``, the ``executed`` parameters, the ``distance``,
the allowed ``intervals`` and ``fallback_taken`` (see :mod:`tracecheck.live.continuous`).

Under a vector environment (Gymnasium's or Stable-Baselines3's), wrap each sub-environment
and the vector environment around them (:mod:`tracecheck.live.vector`): the shield then
decides all sub-environments in one batch per step (docs/environments.md, "Vector
environments").
"""

from __future__ import annotations

import copy
import gc
import time
from typing import Any, Optional, Sequence

import gymnasium as gym
import numpy as np

from ..b.memo import MEMO_KEY
from ..errors import InputError, TracecheckError
from ..b.conversion import convert_state
from ..checking.shield import Shield, for_actions, typing_machine
from .adapter_checks import USERS, raised
from .decisions import Decision, Decisions

__all__ = ["ShieldWrapper", "BState", "ShieldInfo", "choose", "adapter_for", "indexed",
           "discrete_start"]


def adapter_for(env: gym.Env):
    """The installed adapter for ``env``: the one whose ``env_id`` is the environment's
    Gymnasium id (``env.spec.id``, set by ``gymnasium.make``); an :class:`InputError` saying
    what to give when there is none, or several."""
    from .adapter import adapters, adapters_for_env_id

    spec = getattr(env, "spec", None)
    env_id = getattr(spec, "id", None)
    found = [a for a in adapters() if a.adapter is not None]
    known = ", ".join(f"{a.name} ({a.adapter.env_id or 'no id'})" for a in found) or "none"
    if not env_id:
        raise InputError(f"ShieldWrapper cannot tell which adapter turns the observations of "
                         f"{type(env.unwrapped).__name__} into B states: the environment has "
                         "no Gymnasium id (it was not made with gymnasium.make)",
                         hint="give it: ShieldWrapper(env, shield, adapter=MyAdapter()); the "
                              f"installed adapters are {known}")
    matches = adapters_for_env_id(env_id, found)
    if len(matches) > 1:  # one id, two action spaces (discrete and continuous)
        continuous = getattr(env.action_space, "n", None) is None
        matches = [a for a in matches if bool(a.adapter.parameters) == continuous] or matches
    if len(matches) == 1:
        return matches[0].adapter
    if not matches:
        raise InputError(f"no installed adapter is for the environment {env_id!r}",
                         hint="give it: ShieldWrapper(env, shield, adapter=MyAdapter()), or "
                              "install your adapter as an entry point (docs/environments.md); "
                              f"the installed adapters are {known}")
    raise InputError(f"the adapters {', '.join(a.name for a in matches)} are all for "
                     f"{env_id!r}; give the one you mean: ShieldWrapper(env, shield, "
                     "adapter=…)")


class BState(dict):
    """A B state, ``{variable: B value}``: ``info["b_state"]``. Its values are immutable, so
    a deep copy (Stable-Baselines3's vector environments deep-copy every step's infos) is a
    copy of the dict alone."""

    def __deepcopy__(self, memo: dict) -> "BState":
        out = memo[id(self)] = BState(self)
        return out


class ShieldInfo(dict):
    """``info["shield"]``: deep-copied as its values need (lists of names copied, plain
    values shared, anything else deep-copied)."""

    def __deepcopy__(self, memo: dict) -> "ShieldInfo":
        out = memo[id(self)] = ShieldInfo()
        for key, value in self.items():
            kind = type(value)
            if kind is list and all(type(v) is str for v in value):
                value = list(value)
            elif kind not in (str, bool, int, float, type(None)):
                value = copy.deepcopy(value, memo)
            out[key] = value
        return out


def discrete_start(space) -> int:
    """The first action of a ``Discrete(n, start)`` space (0 for any other space)."""
    return int(space.start) if isinstance(space, gym.spaces.Discrete) else 0


def indexed(env: gym.Env) -> gym.Env:
    """``env`` as Stable-Baselines3's agents act and observe (and :class:`ShieldWrapper`'s
    agent acts): where its action space is ``Discrete(n, start=s)`` with s ≠ 0, taking the
    indexes 0 … n-1 (the environment gets s + i); where its observation space is one, its
    observations as indexes (o - s); else ``env`` itself."""
    act, obs = discrete_start(env.action_space), discrete_start(env.observation_space)
    return _Indexed(env, act, obs) if act or obs else env


class _Indexed(gym.Wrapper):
    """See :func:`indexed`."""

    def __init__(self, env: gym.Env, act: int, obs: int) -> None:
        super().__init__(env)
        self._act, self._obs = act, obs
        if act:
            self.action_space = gym.spaces.Discrete(int(env.action_space.n))
        if obs:
            self.observation_space = gym.spaces.Discrete(int(env.observation_space.n))

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return (obs - self._obs if self._obs else obs), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(
            int(action) + self._act if self._act else action)
        return (obs - self._obs if self._obs else obs), reward, terminated, truncated, info

    def action_masks(self) -> np.ndarray:  # a shielded environment's, for MaskablePPO
        return self.env.action_masks()


def _action_index(action: Any, n: int) -> int:
    """A discrete action as its index 0 … n-1 (a numpy integer too); an InputError for
    anything else (-1 took the last action, 2.7 the third)."""
    try:
        index = int(action)
    except (TypeError, ValueError):
        index = -1
    if not 0 <= index < n or index != action:
        raise InputError(f"ShieldWrapper.step({action!r}): an action is an index 0 … {n - 1} "
                         f"of the adapter's actions")
    return index


def choose(values: Sequence[float], allowed: Sequence[bool],
           fallback: int) -> tuple[int, bool]:
    """The highest-valued allowed action; (fallback, True) when nothing is allowed."""
    allowed = np.asarray(allowed, dtype=bool)
    if not allowed.any():
        return fallback, True
    masked = np.where(allowed, np.asarray(values, dtype=np.float64), -np.inf)
    return int(masked.argmax()), False


class ShieldWrapper(gym.Wrapper):
    """Shield an environment with a B machine (see the module docstring).

    ``step(action)`` takes an allowed action as given. An action the shield does not allow is
    replaced — by the fallback if the shield allows it, else by the first allowed action —
    and ``info["shield"]["replaced"]`` says so; MaskablePPO-style agents never send one.

    Args:
        env: the environment (an installed adapter has its id, or give ``adapter``).
        shield: the shield (:func:`~tracecheck.checking.shield.load_shield`).
        fallback: the action taken when the shield allows nothing (default: the adapter's).
        adapter: the environment's adapter (default: the installed one of ``env``'s id).
        mode: continuous actions: ``project``, ``replace`` or ``mask``.
        scale: continuous actions: the unit of each component in projection distances.

    Example::

        env = ShieldWrapper(gym.make("Corridor-v0"), load_shield("corridor"))  # installed
        obs, info = env.reset(seed=0)
        obs, reward, terminated, truncated, info = env.step(env.action_masks().argmax())
        info["shield"]["allowed"]   # the actions the shield allowed in that state
    """

    def __init__(self, env: gym.Env, shield: Shield, fallback: Optional[str] = None,
                 adapter=None, *, mode: Optional[str] = None,
                 scale: Optional[Sequence[float]] = None) -> None:
        super().__init__(env)
        self.env_adapter = adapter if adapter is not None else adapter_for(env)
        # an action no operation decides: never allowed, silently, were it let through
        for_actions(shield, tuple(self.env_adapter.actions))
        #: continuous actions (the adapter declares parameters): the projection shield
        self.continuous = None
        if self.env_adapter.parameters:
            from .continuous import ContinuousShield

            self.continuous = ContinuousShield(shield.machine, self.env_adapter,
                                               env.action_space, mode=mode, scale=scale)
            if self.continuous.hybrid:  # the agent acts with one vector (scores, values)
                self.action_space = self.continuous.agent_space
        self.actions = tuple(self.env_adapter.actions)
        n = getattr(env.action_space, "n", None)
        name = self.env_adapter.name
        if self.continuous is None and n is None:
            raise InputError(f"the adapter {name} has {len(self.actions)} discrete actions "
                             f"({', '.join(self.actions)}), but the environment's action space "
                             f"is {env.action_space}",
                             hint="for continuous actions the adapter declares parameters = "
                                  "{\"OP\": (\"u\",)}: the operation each component binds "
                                  "(docs/continuous.md)")
        if n is not None and int(n) != len(self.actions):
            raise InputError(f"the environment's action space {env.action_space} has {int(n)} "
                             f"actions, but the adapter {name} names {len(self.actions)} "
                             f"({', '.join(self.actions)}): each action index needs its B "
                             "operation", hint="list one operation per action, in the "
                                               "environment's order, in the adapter's actions")
        #: a Discrete(n, start=s) environment takes s + i for the adapter's action i: the
        #: agent, the masks and the records speak of indexes 0 … n-1 (as Stable-Baselines3's
        #: agents act), and only the environment's step gets s + i
        self.start = discrete_start(env.action_space)
        if self.start:
            self.action_space = gym.spaces.Discrete(int(n))
        fallback = fallback or self.env_adapter.fallback or self.actions[0]
        if fallback not in self.actions:
            raise InputError(f"unknown fallback action {fallback!r}; the actions are "
                             f"{', '.join(self.actions)}")
        self.shield = shield
        self.fallback = self.actions.index(fallback)
        self.observer = self.env_adapter.observer(env)
        self.state: dict[str, Any] = {}
        self.allowed = np.ones(len(self.actions), dtype=bool)
        self.decision_us = 0.0
        self.problem: Optional[str] = None  # why a guard could not be evaluated, if so
        self._env = dict(shield.machine.base_env)  # kept: each decision only updates it
        #: discrete actions: the decisions, each distinct state's once
        self.decisions = Decisions(shield.machine, self.actions) if self.continuous is None \
            else None
        #: the vector environment that decides this one with its siblings (vector.py)
        self.group = None
        self._waiting = None  # the decision asked of the group, not yet made
        self._allowed_names: tuple[str, ...] = self.actions
        #: the machine whose types make the adapter's states B values: the shield's, or for
        #: a shield without variables (``none``) the environment's own shield, if any
        self._typing = (shield.machine if shield.machine.variables
                        else typing_machine(self.env_adapter))
        self._checked = False  # the first state checked against the shield's types

    def _decide(self) -> None:
        """The shield's decision in :attr:`state`; under a vector environment that decides
        its sub-environments together, asked of it and made when first needed."""
        if self.group is not None:
            self._waiting = self.group.wait(self)
            return
        # no garbage collection inside the decision: its latency is the shield's own
        collecting = gc.isenabled()
        gc.disable()
        try:
            start = time.perf_counter()
            if self.continuous is not None:
                env = self._env
                env.pop(MEMO_KEY, None)
                env.update(self.state)
                self.continuous.decide(env)
                enabled = self.continuous.enabled
            else:  # where a guard cannot be evaluated (a refusal, not FALSE) its action is
                #    not allowed — the shield fails closed — and ``problem`` says why
                decision = self.decisions.one(self.state)
            decision_us = (time.perf_counter() - start) * 1e6
        finally:
            if collecting:
                gc.enable()
        if self.continuous is None:
            self.settle(decision, decision_us)
        else:
            self.decision_us = decision_us
            self.allowed = np.array([a in enabled for a in self.actions], dtype=bool)
            self._allowed_names = tuple(a for a in self.actions if a in enabled)

    def settle(self, decision: Decision, decision_us: float) -> dict[str, Any]:
        """Take ``decision`` (made for :attr:`state`, in ``decision_us`` µs) as the shield's
        in the current state; its fields of ``info["shield"]``. A vector environment's
        batch gives each sub-environment its decision so."""
        self._waiting = None
        self.allowed = decision.mask
        self._allowed_names = decision.allowed
        self.problem = decision.problem
        self.decision_us = decision_us
        return self._fields()

    def _fields(self) -> dict[str, Any]:
        fields = {"allowed": list(self._allowed_names), "deadlock": not self._allowed_names,
                  "decision_us": self.decision_us}
        if self.continuous is None and self.problem is not None:
            fields["problem"] = self.problem  # guards it could not evaluate
        return fields

    def _ready(self) -> None:
        if self._waiting is not None:  # the vector environment's batch, made now
            self.group.settle()

    def _info(self, info: dict, requested: Optional[int] = None,
              taken: Optional[int] = None) -> dict:
        info = dict(info)
        info["b_state"] = self.state
        info["shield"] = ShieldInfo(name=self.shield.name)
        if self._waiting is not None:  # the fields added when the batch is made
            self._waiting.infos.append(info["shield"])
        else:
            info["shield"].update(self._fields())
        if taken is not None:
            info["shield"].update(requested=self.actions[requested],
                                  taken=self.actions[taken], replaced=requested != taken)
        return info

    def _state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        """The adapter's B state of this observation, made B values by the machine's types
        (:mod:`tracecheck.b.conversion`: a float32 becomes the float it is, a str naming an
        element the element, a dict a function), checked against them at the first state."""
        state = self.observer.state(obs, info, reward, initial)
        where = f"state() of the adapter {self.env_adapter.name}"
        machine = self._typing
        if machine is None:
            return BState(convert_state(state, None, where=where))
        state = machine.native(state, where=where)
        if not self._checked and machine is self.shield.machine:
            declared = machine.variables  # others are the environment's, not the shield's
            machine.check_state({k: v for k, v in state.items() if k in declared},
                                where=where, python=True)
            self._checked = True
        return BState(state)

    def shield_mask(self) -> np.ndarray:
        """Which actions the shield allows in the current state: none in a deadlock (where
        :meth:`action_masks` gives a learner the fallback)."""
        self._ready()
        return self.allowed.copy()

    def action_masks(self) -> np.ndarray:
        """Which actions the shield allows in the current state; in a deadlock (nothing
        allowed) the fallback alone — the action :meth:`step` takes then — so that a masked
        learner never sees an empty mask (``info["shield"]["deadlock"]`` still says so)."""
        self._ready()
        if not self.allowed.any():
            masks = np.zeros_like(self.allowed)
            masks[self.fallback] = True
            return masks
        return self.allowed.copy()

    def reset(self, *, seed=None, options=None):
        obs, info = self.env_adapter.reset(self.env, seed, options)
        self.observer = self.env_adapter.observer(self.env)
        self.state = self._state(obs, info, 0.0, True)
        self._decide()
        info = dict(info, crashed=False)
        return obs, self._info(info)

    def step(self, action):
        if self.continuous is not None:
            return self._step_continuous(action)
        requested = _action_index(action, len(self.actions))
        self._ready()
        taken = requested
        if not self.allowed[requested]:
            if self.allowed[self.fallback] or not self.allowed.any():
                taken = self.fallback
            else:
                taken = int(np.flatnonzero(self.allowed)[0])
        obs, reward, terminated, truncated, info = self._advance(
            taken + self.start if self.start else taken)
        return obs, reward, terminated, truncated, self._info(info, requested, taken)

    def _advance(self, action):
        """The environment's step with ``action``: the crash said in ``info``, the new B
        state, and the shield's decision in it."""
        try:
            obs, reward, terminated, truncated, info = self.env.step(action)
        except TracecheckError:
            raise
        except USERS as exc:  # noqa: BLE001 - the environment's own code: say whose it is
            raise raised(self.env_adapter.name, exc, "in step()", env=True) from exc
        info = dict(info, crashed=self.env_adapter.crashed(obs, float(reward), terminated, info))
        self.state = self._state(obs, info, float(reward), False)
        self._decide()
        return obs, reward, terminated, truncated, info

    def _step_continuous(self, action):
        """A continuous action: the proposal, or what the shield's mode makes of it (see
        :mod:`tracecheck.live.continuous`); ``info["shield"]`` says which, how far it moved
        and what was allowed."""
        self._ready()
        start = time.perf_counter()
        decision = self.continuous.filter(action)
        bands = self.continuous.bands(decision.op)
        decision_us = self.decision_us + (time.perf_counter() - start) * 1e6
        problem = self.continuous.problem
        obs, reward, terminated, truncated, info = self._advance(decision.sent)
        info = self._info(info, self.actions.index(decision.proposed_op),
                          self.actions.index(decision.op))
        info["shield"].update(
            replaced=decision.intervened, proposal=decision.proposal,
            executed=decision.parameters, distance=decision.distance,
            fallback_taken=decision.deadlock, step_decision_us=decision_us,
            intervals=bands, problem=problem, scores=decision.scores, cast=decision.cast)
        return obs, reward, terminated, truncated, info
