"""Monte Carlo simulation: record episodes and validate them in one go.

With ``until_width``, recording stops early once the 95 % interval of every property is
narrower than the width asked for. Looking at the data again and again would spoil a plain
95 % interval, so the rule is Bonferroni over the planned looks: with K = ⌈N / batch⌉ looks,
each look uses Wilson intervals at level 1 − 0.05/K. These hold simultaneously over all
looks with probability at least 95 %, so the interval at whichever look stops the run keeps
its stated 95 % coverage.
"""

from __future__ import annotations

import math
from pathlib import Path
from dataclasses import dataclass
from typing import Callable, Iterator, Optional, Sequence

from ..episodes.columns import episode_columns
from ..episodes.files import AHEAD, prepared_episodes, recording_into
from ..episodes.writer import ChannelsFactory
from ..episodes.model import Episode
from .properties import PropertySet
from ..live.record import (RecordSettings, check_settings, encoded_episodes, recording_header,
                           run_inputs)
from .estimates import evaluate_run, prepare, statistics

__all__ = ["simulate", "simulate_external"]


def _holds(episode: Episode, pset: PropertySet, formulas: dict,
           action_names: Sequence[str]) -> dict[str, bool]:
    """Which properties one new episode satisfies: the very evaluation ``stats`` makes of a
    file (every kind: state predicates, LTL, STL, end reasons)."""
    cols = episode_columns([episode], action_names)
    values = evaluate_run("<episode>", pset, formulas, cols=cols)
    return {name: bool(v[0]) for name, v in values.properties.items()}


def _widths(holds: dict[str, list[bool]], level: float) -> dict[str, float]:
    from scipy import stats

    out = {}
    for name, values in holds.items():
        ci = stats.binomtest(sum(values), len(values)).proportion_ci(confidence_level=level,
                                                                     method="wilson")
        out[name] = float(ci.high - ci.low)
    return out


def simulate(settings: RecordSettings, out: str | Path, pset: PropertySet, *,
             until_width: Optional[float] = None, batch: Optional[int] = None,
             progress: Optional[Callable[[Episode], None]] = None,
             force: bool = False, inputs: Sequence[Path] = (),
             channels: Optional[ChannelsFactory] = None) -> dict:
    """Record up to ``settings.episodes`` episodes into ``out`` and return their statistics
    (see the module docstring for the early stop); ``channels`` adds a plug-in's channels:
    without it the file has tracecheck's own channels only; the CLI gives Foxglove's drawn
    by the adapter it runs (``channels=FoxgloveChannels.drawn_by(adapter)`` from
    ``tracecheck.interop.foxglove``, which a caller in Python passes for the same file). ``out`` follows the output rule: none of
    ``inputs`` (the property file, say) nor the agent or shield file, an existing file only
    with ``force``."""
    out = Path(out)
    _check_width(until_width)
    agent, shield = check_settings(settings, out, force=force, inputs=inputs)
    from ..live.record import resolve

    adapter = resolve(settings)[0]
    header = recording_header(settings, agent, shield)
    with encoded_episodes(settings, shield, channels, header) as (made, encode):
        source = _Source(header, made, settings.episodes, tuple(adapter.actions),
                         prepare(pset, adapter), [*run_inputs(settings), *inputs], adapter,
                         encode, AHEAD * settings.workers)
        return _simulate(source, out, pset, until_width=until_width,
                         batch=batch or max(10, 10 * settings.workers), progress=progress,
                         force=force, channels=channels)


def simulate_external(settings, shield, out: str | Path, pset: PropertySet, *,
                      until_width: Optional[float] = None, batch: Optional[int] = None,
                      progress: Optional[Callable[[Episode], None]] = None,
                      force: bool = False, inputs: Sequence[Path] = (),
                      channels: Optional[ChannelsFactory] = None) -> dict:
    """:func:`simulate` with the episodes of an agent script that speaks SimB's
    external-simulation protocol (``settings``: an
    :class:`~tracecheck.live.external.ExternalSettings`; ``shield``: the loaded machine
    that answers it); the properties are checked against that machine."""
    from ..live.external import check_external, external_episodes, external_header

    out = Path(out)
    _check_width(until_width)
    given = check_external(settings, shield, out, force=force, inputs=inputs)
    source = _Source(external_header(settings, shield), external_episodes(settings, shield),
                     settings.episodes, tuple(shield.machine.operations),
                     prepare(pset, machine=shield.machine), given, None)
    return _simulate(source, out, pset, until_width=until_width, batch=batch or 10,
                     progress=progress, force=force, channels=channels)


def _check_width(until_width: Optional[float]) -> None:
    if until_width is not None and not 0.0 < until_width < 1.0:
        from ..errors import InputError

        raise InputError(f"--until-ci-width must lie strictly between 0 and 1 (a width of a "
                         f"share), not {until_width}")


@dataclass
class _Source:
    """Where a simulation's episodes come from, and what checking them needs."""

    header: object
    episodes: Iterator[Episode]
    planned: int
    actions: tuple[str, ...]
    formulas: dict
    inputs: list
    adapter: object
    encode: Optional[Callable] = None  # workers that encode the episodes for the file
    ahead: int = AHEAD  # how many they encode at once


def _simulate(source: _Source, out: Path, pset: PropertySet, *, until_width, batch,
              progress, force, channels) -> dict:
    looks = math.ceil(source.planned / batch)
    level = 1.0 - 0.05 / looks
    holds: dict[str, list[bool]] = {p.name: [] for p in pset.properties}
    sequential = None
    if until_width is not None:
        sequential = {"rule": f"Bonferroni over {looks} planned looks, Wilson intervals at "
                              f"level {level:.4f} per look", "width": until_width,
                      "batch": batch, "looks": 0, "stopped_early": False, "widths": {}}
    with recording_into(out, source.header, force=force, channels=channels,
                        inputs=source.inputs) as writer:
        try:
            for episode, encoded in prepared_episodes(writer, source.episodes, source.encode,
                                                      source.ahead):
                writer.write(episode, encoded)
                if progress is not None:
                    progress(episode)
                if sequential is None:
                    continue
                for name, value in _holds(episode, pset, source.formulas,
                                          source.actions).items():
                    holds[name].append(value)
                done = writer.episodes
                if done % batch == 0 or done == source.planned:
                    sequential["looks"] += 1
                    widths = _widths(holds, level)
                    sequential["widths"] = widths
                    if widths and max(widths.values()) < until_width and done < source.planned:
                        sequential["stopped_early"] = True
                        break
        finally:
            close = getattr(source.episodes, "close", None)
            if close is not None:  # stops the workers or the script at once
                close()
    result = statistics([out], pset, adapter=source.adapter)
    if sequential is not None:
        result["sequential"] = sequential
    return result
