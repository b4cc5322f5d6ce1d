"""A report's episodes kept compactly behave as the list of records they stand for."""

from __future__ import annotations

import dataclasses
import pickle

from tracecheck.checking.episode_results import EpisodeReplay, EpisodeRows


def record(episode: int, steps: int = 5, **kw) -> EpisodeReplay:
    fields = dict(file="run.mcap", episode=episode, steps=steps, first_infeasible=None,
                  action=None, enabled=None, alternative=None, infeasible_steps=0,
                  crashed=False, crash_step=None, crash_after_infeasible=False,
                  deadlock_states=[], postcondition_violations=[], invariant_violations=[])
    return EpisodeReplay(**{**fields, **kw})


def test_quiet_episodes_share_one_record_and_read_as_their_own():
    quiet = record(0)
    rows = EpisodeRows()
    rows.append(quiet)
    rows.append(record(1, first_infeasible=2, action="FASTER", infeasible_steps=1))
    for ep in range(2, 6):
        rows.append_as(quiet, ep)
    as_list = [quiet, record(1, first_infeasible=2, action="FASTER", infeasible_steps=1),
               *(dataclasses.replace(quiet, episode=ep) for ep in range(2, 6))]
    assert len(rows) == 6 and list(rows) == as_list and rows == as_list
    assert rows[4].episode == 4 and rows[-1].episode == 5 and rows[1:3] == as_list[1:3]
    assert [e.episode for e in rows.records()] == [0, 1, 0, 0, 0, 0]  # kept, not made
    assert pickle.loads(pickle.dumps(rows)) == rows  # a Ray task sends them back
    rows[3] = record(9, crashed=True, crash_step=4)
    assert rows[3].episode == 9 and rows[3].crashed and rows[4].episode == 4
    more = EpisodeRows([record(7)])
    more += rows
    assert [e.episode for e in more] == [7, 0, 1, 2, 9, 4, 5]
    assert rows != [quiet] and rows != "not episodes"
