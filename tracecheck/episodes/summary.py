"""What a set of run files holds (``tracecheck info``)."""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

import numpy as np

from .columns import read_blocks

from .reader import read_header

__all__ = ["summarise", "search_text", "space_text"]


def summarise(paths: Iterable[str | Path], *, salvage: bool = False) -> dict:
    """Episodes, steps (agent actions), crashes, sources, agents and shields of the files
    (``salvage``: as :func:`~tracecheck.episodes.columns.read_columns`), a block of
    episodes at a time."""
    files, warnings = [], []
    for path in paths:
        header = read_header(path)
        episodes = rows = crashes = 0
        for cols in read_blocks(path, salvage=salvage):
            warnings += cols.warnings
            episodes += len(cols.episode_ids)
            rows += cols.n
            crashes += int(np.count_nonzero(cols.crashed[cols.starts[1:] - 1]))
        files.append({
            "path": str(path), "source": header.source, "created": header.created,
            "model_name": header.model_name, "episodes": episodes,
            "steps": rows - episodes, "crashes": crashes,
            "agent": header.agent_id, "shield": header.shield_name,
            "environment": header.environment_id,
            "continuous": _continuous(header),
            "search": header.search.model_dump() if header.search is not None else None,
        })
    return {
        "episodes": sum(f["episodes"] for f in files),
        "steps": sum(f["steps"] for f in files),
        "crashes": sum(f["crashes"] for f in files),
        "sources": sorted({f["source"] for f in files}),
        "agents": sorted({f["agent"] for f in files if f["agent"]}),
        "shields": sorted({f["shield"] for f in files if f["shield"]}),
        "continuous": sorted({f["continuous"] for f in files if f["continuous"]}),
        "files": files,
        "warnings": warnings,
    }


def space_text(space: dict, choices=None) -> str:
    """A search's space in words: ``seed 0..9999, is_slippery {True,False}`` — the
    dimensions ``choices`` names are lists (a file without it: a list that is not two
    numbers)."""
    def listed(k, v) -> bool:
        if len(v) != 2 or choices is not None and k in choices:
            return True
        if choices is not None:
            return False
        return not (len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                        for x in v))
    return ", ".join(f"{k} {{{','.join(map(str, v))}}}" if listed(k, v) else
                     f"{k} {v[0]}..{v[1]}" for k, v in space.items())


def search_text(search: dict) -> str:
    """A search's run header (``falsify``) in words: its optimisers, budget, property and
    space."""
    beside = f" beside {search['baseline']}" if search.get("baseline") else ""
    space = space_text(search["space"], search.get("choices"))
    guide = f", guided by the shield's {search['guide']}s" if search.get("guide") else ""
    stop = ", each ended at its first violation" if search.get("stop_at_first") else ""
    return (f"{search['optimizer']}{beside}, {search['repeat']} search(es) of "
            f"{search['budget']} episode(s){stop}, property {search['property']}{guide}; "
            f"space {space}")


def _continuous(header) -> str:
    """A run's continuous actions in words: the operations with their parameters, the
    shield's mode and the scale of its distances ("" for discrete actions)."""
    if not header.action_parameters:
        return ""
    ops = ", ".join(f"{op}({', '.join(p)})" for op, p in header.action_parameters.items())
    mode = f", shield mode {header.shield_mode}" if header.shield_mode else ""
    scale = (f", scale {', '.join(f'{x:g}' for x in header.projection_scale)}"
             if header.projection_scale else "")
    return ops + mode + scale
