"""The Ray executor: same episodes as the local one, and no episode lost to a killed worker."""

from __future__ import annotations

import dataclasses
import threading
import time

import pytest

from tests.helpers import ROOT
from tracecheck.episodes import read_run
from tracecheck.live.record import RecordSettings, record

ray = pytest.importorskip("ray", reason="the ray extra is not installed (pip install "
                                        "-e '.[ray]')")
psutil = pytest.importorskip("psutil")

AGENT = str(ROOT / "models" / "agents" / "base.zip")


def settings(**kw):
    values = dict(agent=AGENT, shield="paper", episodes=6, seed=300, duration=12, workers=2,
                  env="highway")
    values.update(kw)
    return RecordSettings(**values)


def states(path):
    return [[s.state for s in e.steps] for e in read_run(path).episodes]


def test_ray_gives_the_local_episodes(local_ray, tmp_path):
    record(settings(executor="ray"), tmp_path / "ray.mcap")
    record(settings(), tmp_path / "local.mcap")
    assert [e.id for e in read_run(tmp_path / "ray.mcap").episodes] == list(range(6))
    assert states(tmp_path / "ray.mcap") == states(tmp_path / "local.mcap")


def _kill_a_running_episode(stop: threading.Event, killed: list) -> None:
    while not stop.is_set() and not killed:
        for proc in psutil.process_iter(["cmdline"]):
            cmd = " ".join(proc.info.get("cmdline") or [])
            if "ray::_ray_episode" in cmd:
                proc.kill()
                killed.append(proc.pid)
                return
        time.sleep(0.05)


def test_killed_worker_loses_and_duplicates_nothing(local_ray, tmp_path):
    stop, killed = threading.Event(), []
    killer = threading.Thread(target=_kill_a_running_episode, args=(stop, killed))
    killer.start()
    try:
        record(settings(executor="ray", episodes=8, seed=500, duration=20),
               tmp_path / "ray.mcap")
    finally:
        stop.set()
        killer.join()
    assert killed, "no running episode task was found to kill"
    record(settings(episodes=8, seed=500, duration=20), tmp_path / "local.mcap")
    ids = [e.id for e in read_run(tmp_path / "ray.mcap").episodes]
    assert ids == list(range(8))  # each episode once, in order
    assert states(tmp_path / "ray.mcap") == states(tmp_path / "local.mcap")



def test_replay_diff_stats_per_file_on_ray(local_ray):
    from tracecheck.stats.properties import load_properties

    HIGHWAY_SET = load_properties("highway")
    from tracecheck.checking.diffing import diff
    from tracecheck.checking.replaying import replay
    from tracecheck.checking.shield import load_shield
    from tracecheck.stats.estimates import statistics

    files = [ROOT / "sample_traces" / "base_none.mcap", ROOT / "sample_traces" / "base_paper.mcap"]
    paper, none = load_shield("paper"), load_shield("none")
    a, b = replay(files, paper), replay(files, paper, executor="ray")
    assert a.per_episode == b.per_episode and a.infeasible_steps == b.infeasible_steps
    da, db = diff(files, paper, none), diff(files, paper, none, executor="ray")
    assert (da.changed_steps, da.changes) == (db.changed_steps, db.changes)
    sa = statistics(files, HIGHWAY_SET)
    sb = statistics(files, HIGHWAY_SET, executor="ray")
    assert sa["runs"] == sb["runs"] and sa["comparisons"] == sb["comparisons"]


def test_a_campaign_goes_to_ray_in_batches_of_episodes(local_ray, tmp_path):
    """Issue 28: a Monte Carlo campaign of many short episodes is sent to Ray as batches of
    consecutive episodes (a task per episode costs more than the episode); the file is the
    local one, episode for episode."""
    from tracecheck.live.executors import batch_size

    assert [batch_size(n, 2) for n in (6, 20, 200, 10 ** 5)] == [1, 1, 3, 64]
    lake = dict(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"), shield="frozenlake",
                env="frozenlake", env_config={"is_slippery": True}, episodes=200, seed=7,
                workers=2)
    record(RecordSettings(**lake, executor="ray"), tmp_path / "ray.mcap")
    record(RecordSettings(**lake), tmp_path / "local.mcap")
    assert [e.id for e in read_run(tmp_path / "ray.mcap").episodes] == list(range(200))
    assert states(tmp_path / "ray.mcap") == states(tmp_path / "local.mcap")


def test_ray_tasks_are_blocks_of_a_file(local_ray, tmp_path, monkeypatch):
    """Issue 28: the unit of work on Ray is a block of a file's episodes; the answers are
    the local ones (which read the file a block at a time in one process)."""
    from tracecheck.checking.diffing import diff
    from tracecheck.checking.executors import file_blocks
    from tracecheck.checking.replaying import replay
    from tracecheck.checking.shield import load_shield
    from tracecheck.episodes import EpisodeWriter
    from tracecheck.episodes import writer as W
    from tracecheck.stats.estimates import statistics
    from tracecheck.stats.properties import load_properties

    HIGHWAY_SET = load_properties("highway")

    source = ROOT / "sample_traces" / "base_none.mcap"
    run = read_run(source)
    monkeypatch.setattr(W, "BLOCK_ROWS", 150)
    path = tmp_path / "blocks.mcap"
    with EpisodeWriter(path, run.header) as out:
        for ep in run.episodes:
            out.write(ep)
    units = file_blocks([path, source], "ray")
    assert len(units) > 4 and [u[2].index for u in units if u[1] == str(path)] == list(
        range(len(units) - 1))
    paper, none = load_shield("paper"), load_shield("none")
    a, b = replay([path], paper), replay([path], paper, executor="ray")
    assert a.per_episode == b.per_episode and len(a.per_episode) == len(run.episodes)
    assert replay([source], paper).per_episode == [
        dataclasses.replace(e, file=str(source)) for e in a.per_episode]
    da, db = diff([path], paper, none), diff([path], paper, none, executor="ray")
    assert (da.changed_steps, da.changes, da.episodes) == (db.changed_steps, db.changes,
                                                           db.episodes) and da.changed_steps
    sa = statistics([path], HIGHWAY_SET)
    sb = statistics([path], HIGHWAY_SET, executor="ray")
    assert sa["runs"] == sb["runs"]


def test_a_damaged_block_on_ray_is_read_as_locally(local_ray, tmp_path, monkeypatch):
    """A block that does not check in its Ray task: its file is read again whole, walked, as
    the local executor reads it — the damage named, or salvaged with --salvage."""
    from tracecheck.checking.replaying import replay
    from tracecheck.checking.shield import load_shield
    from tracecheck.episodes import EpisodeWriter
    from tracecheck.episodes import writer as W
    from tracecheck.errors import InputError

    run = read_run(ROOT / "sample_traces" / "base_none.mcap")
    monkeypatch.setattr(W, "BLOCK_ROWS", 150)
    path, good = tmp_path / "damaged.mcap", tmp_path / "good.mcap"
    for p in (path, good):
        with EpisodeWriter(p, run.header, compress=False) as out:
            for ep in run.episodes:
                out.write(ep)
    data = bytearray(path.read_bytes())
    data[data.find(b'"episode":7,"step":3') + 30] ^= 1
    path.write_bytes(bytes(data))
    paper = load_shield("paper")
    for executor in ("local", "ray"):
        with pytest.raises(InputError, match="damaged.mcap, episode 7"):
            replay([good, path], paper, executor=executor)
    a = replay([good, path], paper, salvage=True)
    b = replay([good, path], paper, salvage=True, executor="ray")
    assert a.per_episode == b.per_episode and a.warnings == b.warnings
    assert len(a.per_episode) == 2 * len(run.episodes) - 1


@pytest.fixture(scope="module")
def frozen_runs(tmp_path_factory):
    """Two short unshielded frozenlake runs of the bundled Q-table."""
    folder = tmp_path_factory.mktemp("frozen")
    paths = []
    for i in range(2):
        path = folder / f"fl{i}.mcap"
        record(RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                              shield="none", episodes=4, seed=10 * i, env="frozenlake",
                              env_config={"is_slippery": True}), path)
        paths.append(path)
    return paths


def test_ray_tasks_get_the_shield_itself_not_a_name(local_ray, frozen_runs):
    """Issue 23: ``replay --executor ray --shield none`` on a frozenlake run loaded the
    highway's ``none`` by name in the workers; they now get the shield (pickled as its
    text), ``none`` made from the run's actions included."""
    from tracecheck.checking.diffing import diff
    from tracecheck.checking.replaying import replay
    from tracecheck.checking.shield import load_shield
    from tracecheck.cli.common import run_shield

    none = run_shield("none", frozen_runs)
    assert list(none.machine.operations) == ["Move_Left", "Move_Down", "Move_Right", "Move_Up"]
    a, b = replay(frozen_runs, none), replay(frozen_runs, none, executor="ray")
    assert a.per_episode == b.per_episode and b.episodes == 8
    lake = load_shield("frozenlake")
    da, db = diff(frozen_runs, lake, none), diff(frozen_runs, lake, none, executor="ray")
    assert (da.changed_steps, da.changes) == (db.changed_steps, db.changes)
    assert db.shield == lake.identity and db.against == none.identity


def test_record_on_ray_sends_the_shield_itself(local_ray, tmp_path):
    """Issue 23: ``record --executor ray`` had each worker load the shield again by its name
    or path (on a worker: another file, or none). The workers now get the shield that was
    checked, itself: its file is gone before they start, and the episodes are the local ones."""
    import dataclasses
    import shutil

    from tracecheck.checking.shield import SHIELD_DIR
    from tracecheck.live.record import check_settings, episodes

    copy = tmp_path / "lake.mch"
    shutil.copy(SHIELD_DIR / "frozenlake.mch", copy)
    lake = RecordSettings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                          shield=str(copy), episodes=4, seed=7, env="frozenlake",
                          env_config={"is_slippery": True}, executor="ray", workers=2)
    _, shield = check_settings(lake, tmp_path / "out.mcap")
    copy.unlink()  # what a worker would have looked up again
    on_ray = list(episodes(lake, shield))
    local = list(episodes(dataclasses.replace(lake, executor="local", workers=1), shield))
    assert [e.id for e in on_ray] == list(range(4))
    assert [[s.state for s in e.steps] for e in on_ray] == \
        [[s.state for s in e.steps] for e in local]
    assert all(s.allowed_actions is not None for e in on_ray for s in e.steps[1:])
