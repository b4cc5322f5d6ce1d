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

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .diffing import ChangedStep, DiffReport, diff
    from .proving import Result, prove, symbolic_diff
    from .replaying import EpisodeReplay, ReplayReport, replay
    from .shield import Shield, load_shield

_WHERE = {
    "load_shield": "shield", "Shield": "shield",
    "replay": "replaying", "ReplayReport": "replaying", "EpisodeReplay": "replaying",
    "diff": "diffing", "DiffReport": "diffing", "ChangedStep": "diffing",
    "prove": "proving", "symbolic_diff": "proving", "Result": "proving",
}

__all__ = [
    "load_shield", "Shield", "replay", "ReplayReport", "EpisodeReplay", "diff", "DiffReport",
    "ChangedStep", "prove", "symbolic_diff", "Result",
]


__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())

