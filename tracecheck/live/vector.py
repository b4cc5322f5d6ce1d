"""Shielded vector environments: all sub-environments decided in one batch per step.

Wrap each sub-environment in a :class:`~tracecheck.live.wrapper.ShieldWrapper` as for one
environment, then the vector environment around them:

* Gymnasium (``SyncVectorEnv``, ``gym.make_vec(…, vectorization_mode="sync")``):
  :class:`ShieldedVectorEnv`; ``envs.action_masks()`` gives a row per sub-environment;
* Stable-Baselines3 (``DummyVecEnv``, what MaskablePPO trains on):
  :class:`tracecheck.live.vector_sb3.ShieldedVecEnv`.

After each reset and step of the vector environment the shield decides the states of every
sub-environment together (:class:`~tracecheck.live.decisions.Decisions`: each distinct state
once, the rest in one batch evaluation) and each sub-environment's ``action_masks()``,
``info["shield"]`` and its next ``step`` are exactly what its ShieldWrapper alone would have
given. Sub-environments in other processes (``AsyncVectorEnv``, ``SubprocVecEnv``) decide on
their own: their ShieldWrappers work there unchanged, without this module.

Example::

    envs = ShieldedVectorEnv(gym.vector.SyncVectorEnv(
        [lambda: ShieldWrapper(gym.make("Corridor-v0"), shield)] * 16))
    obs, infos = envs.reset(seed=0)
    obs, rewards, terminated, truncated, infos = envs.step(envs.action_masks().argmax(1))
"""

from __future__ import annotations

import time
from typing import Any, Optional, Sequence

import gymnasium as gym
import numpy as np

from ..errors import InputError
from .wrapper import ShieldWrapper

__all__ = ["ShieldGroup", "ShieldedVectorEnv", "sub_shields"]


class _Waiting:
    """A sub-environment's state, waiting for the group's batch."""

    __slots__ = ("wrapper", "state", "infos")

    def __init__(self, wrapper: ShieldWrapper) -> None:
        self.wrapper = wrapper
        self.state = wrapper.state
        self.infos: list[dict] = []  # its info["shield"] dicts, completed by the batch


class ShieldGroup:
    """The ShieldWrappers of one vector environment, decided together.

    Args:
        wrappers: one discrete ShieldWrapper per sub-environment, all of the same shield.
    """

    def __init__(self, wrappers: Sequence[ShieldWrapper]) -> None:
        if not wrappers:
            raise InputError("a shielded vector environment needs its sub-environments "
                             "each in a ShieldWrapper; none was found")
        first = wrappers[0]
        for w in wrappers:
            if w.continuous is not None:
                raise InputError(
                    f"the sub-environments' adapter {w.env_adapter.name} has continuous "
                    "actions; a vector environment decides discrete actions together",
                    hint="use the vector environment without ShieldedVectorEnv / "
                         "ShieldedVecEnv: each ShieldWrapper decides its own")
            if w.shield.sha256 != first.shield.sha256 or w.actions != first.actions:
                raise InputError("the sub-environments are shielded by different shields or "
                                 "actions; a vector environment decides them together only "
                                 "under one shield", hint="wrap every sub-environment with "
                                                          "the same loaded shield")
        self.wrappers = tuple(wrappers)
        self.decisions = first.decisions  # one memo for all
        self._queue: list[_Waiting] = []
        #: for each sub-environment, the ``info["shield"]`` fields of the decisions made
        #: since the vector environment last collected them, in order
        self.made: list[list[dict]] = [[] for _ in wrappers]
        self._index = {id(w): i for i, w in enumerate(wrappers)}
        for w in wrappers:
            w.decisions = self.decisions
            w.group = self

    def wait(self, wrapper: ShieldWrapper) -> _Waiting:
        """``wrapper``'s current state, to be decided at the next :meth:`settle`."""
        waiting = _Waiting(wrapper)
        self._queue.append(waiting)
        return waiting

    def settle(self) -> None:
        """Decide every waiting state in one batch and give each wrapper its decision."""
        queue = self._queue
        if not queue:
            return
        start = time.perf_counter()
        decisions = self.decisions.many([w.state for w in queue])  # raises: all still wait
        self._queue = []
        each_us = (time.perf_counter() - start) * 1e6 / len(queue)
        for waiting, decision in zip(queue, decisions):
            fields = waiting.wrapper.settle(decision, each_us)
            for info in waiting.infos:
                info.update(fields)
            self.made[self._index[id(waiting.wrapper)]].append(fields)

    def collect(self) -> list[list[dict]]:
        """The decisions' fields made since the last call, per sub-environment."""
        self.settle()
        made, self.made = self.made, [[] for _ in self.wrappers]
        return made

    def masks(self) -> np.ndarray:
        """(sub-environments, actions): each one's ``action_masks()``."""
        self.settle()
        return np.stack([w.action_masks() for w in self.wrappers])


def sub_shields(envs: Sequence[Any], where: str) -> list[ShieldWrapper]:
    """The ShieldWrapper inside each of ``envs`` (a vector environment's sub-environments,
    outer wrappers such as Monitor allowed); an InputError naming the one without."""
    found = []
    for i, env in enumerate(envs):
        inner: Optional[Any] = env
        while inner is not None and not isinstance(inner, ShieldWrapper):
            inner = getattr(inner, "env", None)
        if inner is None:
            raise InputError(f"{where}: sub-environment {i} ({type(env).__name__}) has no "
                             "ShieldWrapper", hint="make each sub-environment "
                                                   "ShieldWrapper(env, shield)")
        found.append(inner)
    return found


def local_envs(venv: Any, where: str) -> list[Any]:
    """The sub-environments of ``venv`` when they live in this process (``.envs``)."""
    envs = getattr(venv, "envs", None)
    if envs is None:
        raise InputError(f"{where}: the sub-environments of {type(venv).__name__} run in "
                         "other processes, where one batch cannot decide them",
                         hint="use a vector environment in this process (SyncVectorEnv, "
                              "DummyVecEnv), or leave this wrapper out: each sub-environment's"
                              " ShieldWrapper then decides on its own")
    return list(envs)


class ShieldedVectorEnv(gym.vector.VectorWrapper):
    """A Gymnasium vector environment of ShieldWrappers, decided together (see the module
    docstring). ``infos["shield"]`` holds each sub-environment's fields as Gymnasium's
    vector environments hold them (an array and its ``_`` mask per key)."""

    def __init__(self, env: gym.vector.VectorEnv) -> None:
        super().__init__(env)
        where = "ShieldedVectorEnv"
        self.group = ShieldGroup(sub_shields(local_envs(env.unwrapped, where), where))

    def action_masks(self) -> np.ndarray:
        """(sub-environments, actions): which actions the shield allows in each."""
        return self.group.masks()

    def reset(self, *, seed=None, options=None):
        obs, infos = self.env.reset(seed=seed, options=options)
        return obs, self._completed(infos)

    def step(self, actions):
        obs, rewards, terminated, truncated, infos = self.env.step(actions)
        return obs, rewards, terminated, truncated, self._completed(infos)

    def _completed(self, infos: dict) -> dict:
        """``infos`` with the batch's fields: a sub-environment stepped and reset in one
        vector step (the same-step autoreset) has the step's under ``final_info``."""
        add = self.env.unwrapped._add_info  # Gymnasium's own way to gather infos
        for i, made in enumerate(self.group.collect()):
            if not made:
                continue
            infos = add(infos, {"shield": made[-1]}, i)
            if len(made) > 1 and "final_info" in infos:
                infos["final_info"] = add(infos["final_info"], {"shield": made[-2]}, i)
        return infos
