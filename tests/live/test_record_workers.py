"""Recording with workers that also encode Foxglove's channels: the one writer only appends
what they made, and the file is the one a single process writes (apart from measured times)."""

from __future__ import annotations

import json
from unittest import mock

import pytest
from mcap.reader import make_reader

from tests.helpers import ROOT, FixedDate, run
from tracecheck.interop.foxglove import FoxgloveChannels
from tracecheck.live.record import RecordSettings, record


def _messages(path):
    out = []
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
            data = message.data
            if channel.topic == "/tracecheck/step":  # the shield's measured time aside
                step = json.loads(data)
                step.pop("shield_time_us", None)
                data = json.dumps(step, sort_keys=True).encode()
            out.append((channel.topic, message.log_time, data))
    return out


def test_workers_encode_foxgloves_channels_as_the_writer_would(tmp_path):
    from tracecheck.episodes import writer as writer_module

    files, here, encoded = [], [], []
    made = FoxgloveChannels.messages
    encode = writer_module.encode_episode

    def counted(self, *args, **kw):  # counted in this process only (workers are forked)
        here[-1] += 1
        return made(self, *args, **kw)

    def encoding(*args, **kw):
        encoded[-1] += 1
        return encode(*args, **kw)
    for workers in (1, 2):
        here.append(0)
        encoded.append(0)
        settings = RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                                  shield="frozenlake", env="frozenlake",
                                  env_config={"is_slippery": True}, episodes=12, seed=3,
                                  workers=workers)
        out = tmp_path / f"w{workers}.mcap"
        with mock.patch("time.time_ns", return_value=1_700_000_000_000_000_000), \
                mock.patch("tracecheck.episodes.writer._dt", FixedDate), \
                mock.patch.object(FoxgloveChannels, "messages", counted), \
                mock.patch.object(writer_module, "encode_episode", encoding):
            assert record(settings, out, channels=FoxgloveChannels)[0] == 12
        files.append(_messages(out))
    one, two = files
    scenes = [m for m in one if m[0].startswith("/scene") or "foxglove" in m[0] or
              m[0].startswith("/log")]
    assert len(one) == len(two) and scenes
    assert one == two
    assert here[0] > 0 and here[1] == 0  # with workers, the writer made none of them itself
    # … nor encoded an episode: the workers' steps, chunks and columns appended as they are
    assert encoded == [12, 0]


def test_workers_encode_the_episodes_without_foxglove_too(tmp_path):
    files = []
    for workers in (1, 2):
        settings = RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                                  shield="frozenlake", env="frozenlake", episodes=9, seed=5,
                                  workers=workers)
        out = tmp_path / f"w{workers}.mcap"
        with mock.patch("time.time_ns", return_value=1_700_000_000_000_000_000), \
                mock.patch("tracecheck.episodes.writer._dt", FixedDate):
            assert record(settings, out)[0] == 9
        files.append(_messages(out))
    assert files[0] == files[1] and len(files[0]) == 1 + 9 * 2 + sum(
        1 for topic, _, _ in files[0] if topic == "/tracecheck/step")


def test_simulate_with_workers_writes_what_one_process_writes(tmp_path):
    """simulate's workers encode the episodes too; an early stop (narrow intervals) keeps
    the same episodes whatever the number of workers, and the workers stop at once."""
    from tracecheck.stats.properties import parse_properties
    from tracecheck.stats.simulate import simulate

    from tracecheck.episodes import writer as writer_module

    pset = parse_properties('[properties.alive]\npredicate = "x >= 0"\n', name="t",
                            file="<t>")
    files, results, encoded = [], [], []
    encode = writer_module.encode_episode

    def encoding(*args, **kw):
        encoded[-1] += 1
        return encode(*args, **kw)
    for workers in (1, 2):
        encoded.append(0)
        settings = RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                                  shield="frozenlake", env="frozenlake", episodes=40, seed=1,
                                  workers=workers)
        out = tmp_path / f"s{workers}.mcap"
        with mock.patch("time.time_ns", return_value=1_700_000_000_000_000_000), \
                mock.patch("tracecheck.episodes.writer._dt", FixedDate), \
                mock.patch.object(writer_module, "encode_episode", encoding):
            results.append(simulate(settings, out, pset, until_width=0.5, batch=10,
                                    channels=FoxgloveChannels))
        files.append(_messages(out))
    assert files[0] == files[1]
    assert results[0]["sequential"] == results[1]["sequential"]
    assert results[0]["sequential"]["stopped_early"]
    assert results[0]["runs"][0]["episodes"] == results[1]["runs"][0]["episodes"] < 40
    assert encoded[0] == results[0]["runs"][0]["episodes"] and encoded[1] == 0


def test_each_episode_is_encoded_by_the_worker_that_ran_it():
    """Issue 46: a worker keeps the episodes it ran and encodes them itself when the writer
    asks (the episode does not cross back, and what the worker remembers for its values
    holds): the bytes are those the writer would make, each kept episode is encoded once and
    forgotten, and an episode the workers did not give is still encoded (by any worker)."""
    import dataclasses

    from tracecheck.checking.shield import load_shield
    from tracecheck.episodes.codec import decode_columns
    from tracecheck.episodes.writer import EncodeContext, encode_episode
    from tracecheck.live import record as record_module

    settings = RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                              shield="frozenlake", env="frozenlake",
                              env_config={"is_slippery": True}, episodes=6, seed=1, workers=2)
    context = EncodeContext(clock_ns=5_000_000_000, channels=(
        ("tracecheck.EpisodeHeader", 1), ("tracecheck.Step", 2), ("tracecheck.EpisodeEnd", 3)),
        actions=(), run_crc=7, compress=True, name="x.mcap")
    with record_module._Pooled(settings, load_shield("frozenlake"), keep=True) as pooled:
        episodes = list(pooled)
        assert len(episodes) == 6 and len(pooled._given) == 6
        made = [pooled.encode(ep, context).get() for ep in episodes]
        assert not pooled._given
        for ep, got in zip(episodes, made):
            assert got == encode_episode(ep, context)
        with pytest.raises(KeyError):  # the worker forgot it once encoded
            pooled._workers[0].call(record_module._encode_kept, 0, context).get()
        copy = dataclasses.replace(episodes[0])
        assert pooled.encode(copy, context).get() == made[0]
    with record_module._Pooled(settings, load_shield("frozenlake"), keep=True,
                               digests=True) as pooled:
        digests = list(pooled)  # only digests cross; the workers encode the episodes
        assert digests == [ep.digest() for ep in episodes]
        again = [pooled.encode(d, context).get() for d in digests]

        def columns(encoded):  # the shield's times in the messages change their checksum
            header, arrays = decode_columns(encoded.blob)
            return ({k: v for k, v in header.items() if k != "messages_crc"},
                    {k: (v.dtype, v.shape, v.tobytes()) for k, v in arrays.items()},
                    encoded.actions, encoded.damage)
        assert [columns(e) for e in again] == [columns(e) for e in made]


@pytest.mark.parametrize("episodes,fail", [(14, 7), (200, 41)])
def test_an_episode_that_fails_keeps_those_before_it_with_workers_as_without(
        tmp_path, capsys, episodes, fail):
    """An environment that raises at episode ``fail``: the recording stops with its error
    and the file keeps the episodes before it, with two workers as with one — those that
    came back and were being encoded ahead of the writer, and those before it in its own
    task (200 episodes: tasks of 3), are written before the error is said; the command
    says what the file keeps."""

    from tracecheck.episodes.reader import read_run
    from tracecheck.errors import TracecheckError

    import numpy as np

    agent = tmp_path / "right.npy"
    table = np.zeros((6, 2))
    table[:, 1] = 1.0  # always Right
    np.save(agent, table)
    kept = []
    for workers in (1, 2):
        settings = RecordSettings(agent=str(agent),
                                  shield="none", env="tests.live.plugins:FailsAt",
                                  env_config={"fail_seed": fail}, episodes=episodes, seed=0,
                                  workers=workers)
        out = tmp_path / f"w{workers}.mcap"
        with pytest.raises((TracecheckError, RuntimeError), match=f"seed {fail}"):
            record(settings, out, channels=FoxgloveChannels)
        kept.append([e.id for e in read_run(out).episodes])
    assert kept == [list(range(fail))] * 2
    out = tmp_path / "cli.mcap"
    code, _, err = run(capsys, "record", "--env", "tests.live.plugins:FailsAt", "--env-config",
                       f"fail_seed={fail}", "--agent", agent, "--shield", "none",
                       "--episodes", episodes, "--workers", 2, "-o", out)
    assert code == 2 and f"the corridor broke at seed {fail}" in err
    assert f"the recording failed: {out} keeps the {fail} episode(s) finished before" in err
    assert "Traceback" not in err


class _BreaksAt(FoxgloveChannels):
    """Foxglove's channels, which cannot draw episode 5 (made in the workers, by name)."""

    def messages(self, step, *, episode, **kw):
        if episode == 5:
            raise ValueError("cannot draw episode 5")
        return super().messages(step, episode=episode, **kw)


def test_an_episode_whose_encoding_fails_keeps_those_before_it(tmp_path):
    """Where an episode cannot be encoded (the workers encode them), those before it are
    written, then its error is said — with two workers as with one (where the writer
    encodes)."""
    from tracecheck.episodes.reader import read_run

    for workers in (1, 2):
        settings = RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                                  shield="frozenlake", env="frozenlake", episodes=20, seed=3,
                                  workers=workers)
        out = tmp_path / f"w{workers}.mcap"
        with pytest.raises(ValueError, match="cannot draw episode 5"):
            record(settings, out, channels=_BreaksAt)
        assert [e.id for e in read_run(out).episodes] == [0, 1, 2, 3, 4]
