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
