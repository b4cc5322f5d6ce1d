"""Run files written by the output rule (tracecheck/episodes/files.py): never over an input,
never through a link planted where a temporary or lock file goes; a recording's lock."""

from __future__ import annotations

import pytest

from tests.helpers import episode
from tracecheck.episodes.columns import read_columns
from tracecheck.episodes.files import recording_into, write_run
from tracecheck.episodes.writer import new_header
from tracecheck.errors import InputError


@pytest.fixture
def target(tmp_path):
    path = tmp_path / "precious"
    path.write_bytes(b"keep")
    return path


def test_write_run_never_follows_a_link_at_the_old_temporary_name(tmp_path, target):
    out = tmp_path / "run.mcap"
    (tmp_path / "run.mcap.part").symlink_to(target)
    assert write_run(out, new_header("imported-simb"), [episode(0)]) == (1, 3, 0)
    assert target.read_bytes() == b"keep" and len(read_columns(out).episode_ids) == 1
    out.write_bytes(b"old")
    with pytest.raises(InputError, match="run.mcap exists; give another name, or --force"):
        write_run(out, new_header("imported-simb"), [episode(0)])
    with pytest.raises(InputError, match="run.mcap is the input"):
        write_run(out, new_header("imported-simb"), [episode(0)], force=True, inputs=[out])
    assert out.read_bytes() == b"old"


def test_a_recording_never_follows_a_link_at_its_temporary_or_lock_name(tmp_path, target):
    out = tmp_path / "run.mcap"
    out.write_bytes(b"old")
    (tmp_path / "run.mcap.part").symlink_to(target)
    with recording_into(out, new_header("recorded"), force=True) as writer:
        writer.write(episode(0))
    assert target.read_bytes() == b"keep" and len(read_columns(out).episode_ids) == 1
    (tmp_path / "new.mcap.lock").symlink_to(target)
    with pytest.raises(InputError, match="another tracecheck is writing .*new.mcap"):
        with recording_into(tmp_path / "new.mcap", new_header("recorded")):
            pass
    assert target.read_bytes() == b"keep"


def test_a_new_recording_is_created_exclusively_in_place(tmp_path, target):
    """A new file is written in place (finished episodes readable while recording) — but
    a link there is an existing output, refused, and never written through."""
    out = tmp_path / "run.mcap"
    with recording_into(out, new_header("recorded")) as writer:
        writer.write(episode(0))
        assert len(read_columns(out).episode_ids) == 1  # readable while recording
    link = tmp_path / "link.mcap"
    link.symlink_to(target)
    with pytest.raises(InputError, match="is a symbolic link"):
        with recording_into(link, new_header("recorded"), force=True):
            pass
    assert target.read_bytes() == b"keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.mcap", "precious", "run.mcap"]


def test_a_set_of_one_element_in_a_first_state_is_the_same_column_as_of_two(tmp_path):
    """A new user's `near : POW(CELL)` was {Floor} in one episode's first state and {Floor,
    Lava} in another's: record wrote the file, and every command then refused it ("a value
    of another kind in episode 0 and a set of elements in episode 1")."""
    from tracecheck.b.values import Elem
    from tracecheck.episodes.model import Episode, StepRecord, make_end
    from tracecheck.episodes.reader import read_run

    floor, lava = Elem("Floor"), Elem("Lava")

    def ep(eid, sets):
        steps = tuple(StepRecord(step=k, time=float(k), action=None if k == 0 else "Go",
                                 state={"near": s, "x": k}, reward=0.0, crashed=False)
                      for k, s in enumerate(sets))
        return Episode(id=eid, steps=steps, end=make_end(steps), seed=eid)

    path = tmp_path / "near.mcap"
    episodes = [ep(0, [frozenset({floor}), frozenset({floor, lava})]),
                ep(1, [frozenset({floor, lava}), frozenset()])]
    write_run(path, new_header("recorded", actions=["Go"], variables=["near", "x"]), episodes)
    cols = read_columns(path)
    assert "near" in cols.states.masks and cols.n == 4
    assert [e.steps[1].state["near"] for e in read_run(path).episodes] == \
        [frozenset({floor, lava}), frozenset()]


def test_an_interrupt_while_an_episode_is_written_takes_effect_once_it_is(tmp_path,
                                                                           monkeypatch):
    """Ctrl-C in the middle of writing an episode: the file ends with that episode whole
    (before, a part of it stayed, and every later read warned of a damaged file)."""
    import os
    import signal

    from tracecheck.episodes.files import record_episodes
    from tracecheck.episodes.reader import read_run
    from tracecheck.episodes.writer import EpisodeWriter

    original = EpisodeWriter._write

    def interrupted(self, ep, *rest):
        if ep.id == 1:
            os.kill(os.getpid(), signal.SIGINT)  # arrives while this episode is written
        return original(self, ep, *rest)
    monkeypatch.setattr(EpisodeWriter, "_write", interrupted)
    out = tmp_path / "cut.mcap"
    with pytest.raises(KeyboardInterrupt):
        record_episodes(out, new_header("recorded"), (episode(i) for i in range(5)))
    run = read_run(out)
    assert [ep.id for ep in run.episodes] == [0, 1] and not run.warnings
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.parametrize("ahead,ready", [(1, False), (5, False), (64, False), (64, True)])
def test_episodes_encoded_elsewhere_are_asked_for_ahead_and_written_as_the_writer_would(
        tmp_path, ahead, ready):
    # a recording's workers encode the episodes: the writer asks for up to `ahead` at once
    # (so that each worker has the next to do while it waits for the oldest), writes each
    # as soon as its encoding has come (an interrupted recording keeps it), and the file
    # is the one it writes when it encodes them itself
    from unittest import mock

    from tests.helpers import FixedDate
    from tracecheck.episodes.files import record_episodes
    from tracecheck.episodes.writer import encode_episode

    episodes = [episode(i, n=2 + i % 3) for i in range(12)]
    asked, waiting, most = [], set(), [0]

    class Handle:
        def __init__(self, ep, context):
            self.ep, self.context = ep, context

        def get(self):
            waiting.discard(self.ep.id)
            return encode_episode(self.ep, self.context)

        def ready(self):  # an encoding that has come at once, or one that is slow
            return ready

    def encode(ep, context):
        asked.append(ep.id)
        waiting.add(ep.id)
        most[0] = max(most[0], len(waiting))
        return Handle(ep, context)

    with mock.patch("time.time_ns", return_value=1_700_000_000_000_000_000), \
            mock.patch("tracecheck.episodes.writer._dt", FixedDate):  # one clock for both
        header = new_header("recorded", variables=["Crash"], actions=["IDLE"])
        record_episodes(tmp_path / "elsewhere.mcap", header, iter(episodes), encode=encode,
                        ahead=ahead)
        record_episodes(tmp_path / "here.mcap", header, iter(episodes))
    assert asked == list(range(12))
    assert most[0] == (1 if ready else min(ahead + 1, 12))
    assert (tmp_path / "elsewhere.mcap").read_bytes() == (tmp_path / "here.mcap").read_bytes()
