"""Plug-ins that misbehave, for the registry's tests: declarations of the wrong type, a
name another environment declares, a claims() that raises."""

from __future__ import annotations

from pathlib import Path

from tests.live.toy import Corridor

HERE = Path(__file__).parent


class BadShields(Corridor):
    name = "badshields"
    shields = ["not", "a", "mapping"]
    property_sets = {"ok": 3}


class PaperToo(Corridor):
    """Declares a shield named like the highway's, for another machine."""

    name = "papertoo"
    shields = {"paper": HERE / "papertoo.mch"}


class ClaimsRaises(Corridor):
    name = "claimsraises"

    def claims(self, variables):
        raise RuntimeError("no idea")


class FailsAt(Corridor):
    """The corridor whose environment raises when reset with the seed ``fail_seed``."""

    name = "failsat"

    def default_config(self):
        return {"slip": True, "fail_seed": -1}

    def make_env(self, config, render_mode=None):
        env = super().make_env({"slip": config.get("slip", True)})
        fail = config.get("fail_seed", -1)
        reset = env.reset

        def failing_reset(*, seed=None, options=None):
            if seed == fail:
                raise RuntimeError(f"the corridor broke at seed {seed}")
            return reset(seed=seed, options=options)
        env.reset = failing_reset
        return env
