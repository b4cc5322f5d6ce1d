"""The recorded crash flag as a B variable: ``crashed``, a BOOL every LTL atom and property
can read in every environment (``{crashed = FALSE}``), unless the environment's machine or
states have a ``crashed`` of their own, which is then what the name means."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

__all__ = ["CRASH_FLAG", "flagged", "with_crash_flag"]

CRASH_FLAG = "crashed"


class _Flagged:
    """A machine, with the recorded crash flag as one more BOOL variable (LTL atoms are
    type-checked and evaluated through it; everything else is the machine's)."""

    def __init__(self, machine) -> None:
        from ..b.btypes import BOOL

        self._machine = machine
        self.type_objects = {**machine.type_objects, CRASH_FLAG: BOOL}
        self.variables = (*machine.variables, CRASH_FLAG)

    def __getattr__(self, name: str):
        return getattr(self._machine, name)


def flagged(machine):
    """``machine`` with ``crashed`` in scope (itself where it has a ``crashed``)."""
    if isinstance(machine, _Flagged) or CRASH_FLAG in machine.type_objects:
        return machine
    return _Flagged(machine)


def with_crash_flag(cols):
    """Run columns whose states also hold the recorded crash flag as ``crashed`` (unless they
    have a ``crashed`` of their own)."""
    if CRASH_FLAG in cols.states.names():
        return cols
    states = replace(cols.states, booleans={**cols.states.booleans,
                                            CRASH_FLAG: np.asarray(cols.crashed, dtype=bool)})
    return replace(cols, states=states)
