"""Cutting episodes' columns by row (what a project does for each task) gives the columns of
the cut episodes."""

from __future__ import annotations

import numpy as np
import pytest

from tracecheck.b.values import Elem, FuncValue
from tracecheck.episodes.columns import episode_columns, take_episodes
from tracecheck.episodes.model import Episode, StepRecord, make_end

A, B = Elem("A"), Elem("B")


def _episode(eid: int, n: int) -> Episode:
    steps = tuple(StepRecord(k, k * 0.5, None if k == 0 else ("Go" if k % 2 else "Stop"),
                             {"x": float(k + eid), "on": k % 3 == 0,
                              "f": FuncValue({A: k, B: eid} if k % 2 else {A: k}),
                              "s": frozenset({A} if k % 2 else {A, B}),
                              "seq": (k, eid)}, float(k), k == n - 1 and eid == 1)
                  for k in range(n))
    return Episode(eid, steps, make_end(steps))


def _same(a, b) -> None:
    for name in ("episode_ids", "starts", "episode", "step", "time", "reward", "crashed"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert [a.action_names[i] if i >= 0 else None for i in a.action.tolist()] == \
        [b.action_names[i] if i >= 0 else None for i in b.action.tolist()]
    assert (a.seeds, a.reasons, a.values) == (b.seeds, b.reasons, b.values)
    assert [a.states.row(i) for i in range(a.states.n)] == \
        [b.states.row(i) for i in range(b.states.n)]


@pytest.mark.parametrize("ranges", [
    [(0, 5), (0, 3), (0, 4)], [(1, 3), (2, 3), (0, 1)], [(4, 5), (3, 3), (0, 9)],
    [(0, 2)], [(2, 1), (-2, 10), (1, 2)]], ids=["whole", "middles", "ends", "prefix", "odd"])
def test_taken_rows_are_the_cut_episodes_columns(ranges):
    from dataclasses import replace

    episodes = [_episode(0, 5), _episode(1, 3), _episode(2, 4)]
    whole = episode_columns(episodes, ["Go", "Stop"])
    cut = [replace(ep, steps=ep.steps[lo:hi]) for ep, (lo, hi) in zip(episodes, ranges)]
    _same(take_episodes(whole, ranges), episode_columns(cut, ["Go", "Stop"]))
