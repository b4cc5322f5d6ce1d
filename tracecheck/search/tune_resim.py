"""Validate chosen values of a tuned number by re-simulation (``tracecheck tune --resimulate K
--at VALUE``): the first K recorded episodes with a seed are run again from their seeds, the
recorded agent under the shield with each value written in (and with the machine's own), and
the crashes and interventions compared — each value paired with the machine's own on the same
seeds.

Crashes: the share with a Wilson interval; paired: exact McNemar on the seeds where the two
differ. Interventions (the shield overruled the agent's preferred action, or moved a
continuous action): per episode the share of its steps, their mean with a t interval; paired:
Wilcoxon's signed-rank test.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from ..checking.shield import Shield
from ..episodes.columns import read_columns
from ..episodes.reader import read_header
from ..errors import InputError
from .tune_target import Target, number_text

__all__ = ["resimulate_values", "CONFIDENCE"]

CONFIDENCE = 0.95


def _seeded(paths: Sequence[str], k: int) -> list[tuple[str, int, int]]:
    """(file, episode, seed) of the first ``k`` episodes with a seed."""
    found: list[tuple[str, int, int]] = []
    for path in paths:
        cols = read_columns(path)
        for i, ep in enumerate(cols.episode_ids.tolist()):
            seed = cols.seeds[i] if i < len(cols.seeds) else None
            if seed is not None:
                found.append((path, int(ep), int(seed)))
            if len(found) == k:
                return found
    if not found:
        raise InputError("--resimulate: no recorded episode has a seed (imported traces "
                         "cannot be run again)", hint="record episodes with tracecheck record")
    return found


def resimulate_values(paths: Sequence[str], shield: Shield, target: Target,
                      values: Sequence[float], k: int, *, agent: Optional[str | Path] = None,
                      env: Optional[str] = None,
                      progress: Optional[Callable[[], None]] = None) -> dict:
    """Re-run ``k`` episodes under ``shield`` with each of ``values`` (and the machine's own
    value) written in; the JSON the report shows (see the module docstring)."""
    from .tuning import shield_with

    episodes = _seeded([str(p) for p in paths], k)
    own = float(target.value)
    chosen = list(dict.fromkeys([own, *map(float, values)]))
    runs: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    for v in chosen:
        tuned = shield if v == own else shield_with(shield, target, v)
        crashed, shares = [], []
        for episode in _runs(episodes, tuned, agent, env, progress):
            crashed.append(episode.end.crashed)
            steps = [s for s in episode.steps if s.step > 0]
            shares.append(sum(_intervened(s) for s in steps) / len(steps) if steps else 0.0)
        runs[v] = (np.array(crashed, dtype=bool), np.array(shares, dtype=float))
    rows = [_row(v, target, runs[v], None if v == own else runs[own]) for v in chosen]
    return {"episodes": len(episodes), "interval": "wilson / t", "confidence": CONFIDENCE,
            "seeds": [s for _, _, s in episodes], "values": rows}


def _runs(episodes, shield: Shield, agent, env, progress):
    """Each of ``episodes`` (file, id, seed) run again from its seed under ``shield``, one
    session per file (the run's environment settings; a search's episode with its own on
    top, and what it started from)."""
    from ..episodes.reader import read_run
    from ..live.adapter import MakeError
    from ..live.resimulate import rerun_settings
    from ..live.rollout import Session, run_episode

    for path in dict.fromkeys(p for p, _, _ in episodes):
        header = read_header(path)
        adapter, config, _, settings = rerun_settings(path, shield, header, agent=agent, env=env)
        ids = [e for p, e, _ in episodes if p == path]
        own = {ep.id: ep for ep in read_run(path, only=set(ids)).episodes}
        try:
            session = Session(settings, config=config, shield=shield)
        except MakeError as exc:
            raise InputError(f"{path}: the {adapter.name} environment rejects the run header's "
                             f"settings: {exc.reason}") from exc.__cause__
        try:
            for p, ep, seed in episodes:
                if p != path:
                    continue
                mine = own[ep]
                wanted = adapter.config({**config, **dict(mine.config)}) if mine.config \
                    else config
                if session.config != wanted:
                    session.reconfigure(wanted)
                yield run_episode(session, ep, seed=seed,
                                  options=dict(mine.reset_options or {}) or None)
                if progress is not None:
                    progress()
        finally:
            session.env.close()


def _intervened(step) -> bool:
    if step.projection_distance is not None:
        return step.projection_distance > 0
    return step.preferred_action is not None and step.preferred_action != step.action


def _row(value: float, target: Target, run, base) -> dict:
    from scipy import stats

    crashed, shares = run
    n = len(crashed)
    ci = stats.binomtest(int(crashed.sum()), n).proportion_ci(confidence_level=CONFIDENCE,
                                                              method="wilson")
    mean = float(shares.mean())
    if n > 1 and shares.std() > 0:
        half = float(stats.t.ppf((1 + CONFIDENCE) / 2, n - 1) * shares.std(ddof=1) / n ** 0.5)
    else:
        half = 0.0
    own = base is None
    row = {"value": value, "label": f"{target.label} = {number_text(value, target.integer)}"
           + (" (the machine's)" if own else ""),
           "crashes": int(crashed.sum()), "crash_rate": int(crashed.sum()) / n,
           "crash_low": float(ci.low), "crash_high": float(ci.high),
           "intervention_rate": mean, "intervention_low": max(0.0, mean - half),
           "intervention_high": min(1.0, mean + half), "paired": None}
    if base is not None:
        row["paired"] = _paired(base, run)
    return row


def _paired(base, run) -> str:
    from scipy import stats

    (c0, s0), (c1, s1) = base, run
    fewer, more = int(np.sum(c0 & ~c1)), int(np.sum(~c0 & c1))
    p_crash = float(stats.binomtest(fewer, fewer + more, 0.5).pvalue) if fewer + more else 1.0
    diff = s1 - s0
    p_int = float(stats.wilcoxon(s1, s0).pvalue) if np.any(diff != 0) else 1.0
    return (f"{fewer} crash(es) avoided, {more} new (exact McNemar p = {p_crash:.3g}); "
            f"interventions {float(diff.mean()):+.3f} per step (Wilcoxon p = {p_int:.3g})")
