"""Checking shields against recorded episodes and over every state: load a shield, replay
episodes against it, diff two shields, prove properties with an SMT solver.

>>> from tracecheck.checking import load_shield, replay
>>> report = replay(["sample_traces/base_paper.mcap"], load_shield("paper"))  # repo root
>>> report.episodes, report.infeasible_steps
(24, 0)

The names below are imported on first use: ``tracecheck replay`` loads neither the SMT
solver nor anything else it does not need.
"""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .diff import ChangedStep, DiffReport, diff
    from .prove import Result, prove, symbolic_diff
    from .replay import EpisodeReplay, ReplayReport, replay
    from .shield import Shield, load_shield

_WHERE = {
    "load_shield": "shield", "Shield": "shield",
    "replay": "replay", "ReplayReport": "replay", "EpisodeReplay": "replay",
    "diff": "diff", "DiffReport": "diff", "ChangedStep": "diff",
    "prove": "prove", "symbolic_diff": "prove", "Result": "prove",
}

__all__ = [
    "load_shield", "Shield", "replay", "ReplayReport", "EpisodeReplay", "diff", "DiffReport",
    "ChangedStep", "prove", "symbolic_diff", "Result",
]


__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())


class _Package(types.ModuleType):
    """This package, whose ``replay``, ``diff`` and ``prove`` are the functions of the
    submodules of the same names: importing such a submodule (as the modules that use it
    do) sets the package's attribute to the module, and here to its function instead. The
    module itself: ``from tracecheck.checking.replay import …``."""

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, types.ModuleType) and _WHERE.get(name) == name:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
