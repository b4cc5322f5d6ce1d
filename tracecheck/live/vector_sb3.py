"""Stable-Baselines3's vector environments shielded in one batch per step (MaskablePPO's
training environments): see :mod:`tracecheck.live.vector`. Needs ``stable-baselines3``
(``pip install 'tracecheck[agents]'``).

Example::

    venv = ShieldedVecEnv(DummyVecEnv([lambda: ShieldWrapper(gym.make("Corridor-v0"),
                                                             shield)] * 16))
    model = MaskablePPO("MlpPolicy", venv).learn(100_000)  # masks: venv's sub-environments'
"""

from __future__ import annotations

from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from ..errors import InputError
from .vector import ShieldGroup, local_envs, sub_shields

__all__ = ["ShieldedVecEnv"]


class ShieldedVecEnv(VecEnvWrapper):
    """A ``DummyVecEnv`` of ShieldWrappers, decided together. ``infos[i]["shield"]`` is
    sub-environment ``i``'s step as its ShieldWrapper alone gives it (after an episode's
    end, the decision in its last state; the reset's is in ``reset_infos[i]``); the masks
    (``action_masks()``, or sb3-contrib's ``get_action_masks``) those of the states the
    observations show."""

    def __init__(self, venv: VecEnv) -> None:
        if not isinstance(venv, VecEnv):
            raise InputError(f"ShieldedVecEnv takes a Stable-Baselines3 vector environment, "
                             f"not {type(venv).__name__}",
                             hint="ShieldedVecEnv(DummyVecEnv([lambda: ShieldWrapper(…)] * n))")
        super().__init__(venv)
        where = "ShieldedVecEnv"
        self.group = ShieldGroup(sub_shields(local_envs(venv.unwrapped, where), where))

    def action_masks(self):
        """(sub-environments, actions): which actions the shield allows in each."""
        return self.group.masks()

    def reset(self):
        obs = self.venv.reset()
        self.group.collect()  # the reset infos (reset_infos) completed in place
        self.reset_infos = self.venv.reset_infos
        return obs

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for info, made in zip(infos, self.group.collect()):
            shield = info.get("shield")
            if made and shield is not None and "allowed" not in shield:
                shield.update(made[0])  # a copy of the step's info: the step's decision
        self.reset_infos = self.venv.reset_infos
        return obs, rewards, dones, infos
