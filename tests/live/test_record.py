"""Agents, shielded recording, and counterfactual re-simulation, with the bundled agent."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
import warnings
import zipfile

import pytest

from tests.helpers import ROOT, run
from tracecheck.live.agents import load_agent
from tracecheck.episodes import EpisodeWriter, read_columns, read_run
from tracecheck.episodes.model import Episode, StepRecord, make_end
from tracecheck.errors import InputError
from tracecheck.live.envs.highway import ENV_ID, env_config
from tracecheck.live.record import RecordSettings, record
from tracecheck.checking.replaying import replay
from tracecheck.checking.replaying import OUTCOMES
from tracecheck.live.resimulate import resimulate, summary
from tracecheck.checking.shield import load_shield

BASE = ROOT / "models" / "agents" / "base.zip"


def settings(**kw):
    values = dict(agent=str(BASE), shield="paper", episodes=3, seed=40, duration=8, env="highway")
    values.update(kw)
    return RecordSettings(**values)


def test_bundled_agents_load():
    for name in ("base", "higher_penalty"):
        agent = load_agent(ROOT / "models" / "agents" / f"{name}.zip")
        assert agent.algorithm == "DQN" and len(agent.sha256) == 64
        card = json.loads((ROOT / "models" / "agents" / f"{name}.json").read_text())
        assert card["sha256"] == agent.sha256 and card["steps"] == 20000


def test_record_under_the_shield(tmp_path):
    path = tmp_path / "run.mcap"
    n, steps, crashes = record(settings(), path)
    run_ = read_run(path)
    header = run_.header
    assert (header.source, header.agent_id, header.shield_name, header.base_seed) == (
        "recorded", "base", "paper", 40)
    assert header.environment_id == ENV_ID and header.environment_config == env_config("base", 8)
    assert len(header.agent_sha256) == 64 and len(header.shield_sha256) == 64
    assert [e.seed for e in run_.episodes] == [40, 41, 42]
    for episode in run_.episodes:
        for s in episode.steps[1:]:
            assert s.action in s.allowed_actions  # pre-shielding
            assert s.preferred_action and s.action_values and s.observation
            assert s.shield_time_us > 0
            best = max(s.allowed_actions, key=lambda a: s.action_values[a])
            assert s.action == best
    # the live shield and replay agree: nothing recorded under paper is infeasible for paper
    report = replay([path], load_shield("paper"))
    assert report.infeasible_steps == 0 and report.postcondition_violations == 0
    assert n == 3 and steps == report.steps


def test_an_agent_that_raises_is_said_with_its_episode_and_step(tmp_path, monkeypatch):
    """A policy whose weights hold NaN makes torch raise in its distribution: the user is
    told which agent, episode and step, not shown torch's traceback; no file is left."""
    from tracecheck.live import agents

    def broken(self, obs):
        raise ValueError("Expected parameter loc … but found invalid values: nan")
    monkeypatch.setattr(agents.Agent, "values", broken)
    path = tmp_path / "run.mcap"
    with pytest.raises(InputError) as info:
        record(settings(episodes=1), path)
    assert info.value.message.startswith(
        "episode 0 (seed 40), step 1: the agent base.zip raised ValueError for the "
        "observation: Expected parameter loc")
    assert "weights" in info.value.hint and not path.exists()


def test_workers_do_not_change_episodes(tmp_path):
    one, two = tmp_path / "one.mcap", tmp_path / "two.mcap"
    record(settings(episodes=4, shield="none"), one)
    record(settings(episodes=4, shield="none", workers=2), two)
    a, b = read_run(one).episodes, read_run(two).episodes
    assert [[s.state for s in e.steps] for e in a] == [[s.state for s in e.steps] for e in b]
    assert [e.actions for e in a] == [e.actions for e in b]


def test_a_campaign_in_tasks_of_several_episodes_is_the_same_campaign(tmp_path):
    """Over 64 episodes per worker, a worker runs several per task: the same episodes, in
    order, as one process gives."""
    from tracecheck.live import record as recording

    fl = dict(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"), shield="frozenlake",
              env="frozenlake", env_config={"is_slippery": True}, episodes=300, duration=None)
    shield = load_shield("frozenlake")
    one = list(recording.episodes(settings(**fl), shield))
    two = list(recording.episodes(settings(**fl, workers=2), shield))
    assert recording.batch_size(300, 2) == 4  # tasks of four episodes, not one
    assert [e.id for e in two] == list(range(300))
    assert [e.actions for e in one] == [e.actions for e in two]
    assert [[s.state for s in e.steps] for e in one] == [[s.state for s in e.steps] for e in two]


def test_in_order_keeps_order_and_at_most_limit_jobs_ahead():
    from tracecheck.live.executors import in_order

    started, given = [], []

    def submit(job):
        started.append(job)
        assert len(started) - len(given) <= 3  # never more than the limit not yet given
        return job * 10

    for value in in_order(submit, range(10), 3, lambda handle: handle + 1):
        given.append(value)
    assert given == [10 * i + 1 for i in range(10)] and started == list(range(10))
    assert list(in_order(submit, [], 3, lambda h: h)) == []
    with pytest.raises(ValueError, match="at least 1"):
        next(in_order(submit, range(3), 0, lambda h: h))


def test_workers_run_only_a_few_episodes_ahead_of_the_writer(tmp_path, monkeypatch):
    """A writer slower than the workers (the CLI's Foxglove channels) must not make finished
    episodes pile up in the recording process: workers wait for it."""
    from tracecheck.live import record as recording
    from tracecheck.live.rollout import Session

    log = tmp_path / "started"
    episode = Session.episode

    def logged(self, index):
        with open(log, "a") as f:
            f.write(f"{index}\n")
        return episode(self, index)

    monkeypatch.setattr(Session, "episode", logged)  # the forked workers inherit it
    fl = settings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"), shield="frozenlake",
                  env="frozenlake", episodes=40, workers=2, duration=None)
    shield = load_shield("frozenlake")
    episodes = recording.episodes(fl, shield)
    first = next(episodes)
    time.sleep(2.0)  # ample for the workers to run all 40 had they not to wait
    assert first.id == 0
    ahead = 1 + recording.LOCAL_IN_FLIGHT * 2  # batches of one episode here (40 in all)
    assert ahead < 40 and len(log.read_text().split()) <= ahead
    rest = list(episodes)
    assert [e.id for e in rest] == list(range(1, 40))
    assert sorted(map(int, log.read_text().split())) == list(range(40))


def test_a_worker_that_cannot_start_is_an_error_not_a_hang():
    """A shield the environment's actions do not fit, given past :func:`check_settings`: the
    workers cannot start, and the recording says why instead of waiting for ever."""
    from tracecheck.live import record as recording

    fl = settings(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"), shield="none",
                  env="frozenlake", episodes=4, workers=2, duration=None)
    with pytest.raises(InputError, match="one operation per action"):
        list(recording.episodes(fl, load_shield("none")))


def _wait_for_episodes(path, count: int, seconds: float) -> None:
    """Until a recording being written holds ``count`` finished episodes."""
    deadline = time.time() + seconds
    seen = 0
    while time.time() < deadline and seen < count:
        time.sleep(0.5)
        if path.exists():
            try:
                seen = len(read_columns(path).episode_ids)
            except Exception:  # noqa: BLE001 - the file may be mid-write
                seen = 0


def test_interrupted_recording_keeps_finished_episodes(tmp_path):
    path = tmp_path / "run.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "tracecheck.cli", "record", "--agent", str(BASE), "--shield",
         "none", "--episodes", "200", "--duration", "5", "-o", str(path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_episodes(path, 3, 60)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "keeps every finished episode" in err
    episodes = read_run(path).episodes
    assert len(episodes) >= 3
    assert [e.id for e in episodes] == list(range(len(episodes)))


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in open(f"/proc/{pid}/task/{pid}/children").read().split()]
    except OSError:
        return []


def _alive(pid: int) -> bool:
    try:
        return open(f"/proc/{pid}/stat").read().split()[2] not in ("Z", "X")
    except OSError:
        return False


@pytest.mark.skipif(not os.path.exists("/proc/self/task"), reason="needs Linux /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["term", "kill"])
def test_workers_stop_quietly_with_their_parent(tmp_path, sig):
    """A recording with worker processes, stopped by SIGTERM or SIGKILL: no traceback from
    any worker, no worker left running, the finished episodes kept."""
    path = tmp_path / "run.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "tracecheck.cli", "record", "--agent", str(BASE), "--shield",
         "none", "--episodes", "400", "--duration", "5", "--workers", "2", "-o", str(path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_episodes(path, 2, 90)
    workers = _children(proc.pid)
    assert len(workers) >= 2
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    deadline = time.time() + 20
    while time.time() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.2)
    assert not any(_alive(w) for w in workers)
    assert "Traceback" not in err, err
    if sig == signal.SIGTERM:
        assert proc.returncode == 130 and "keeps every finished episode" in err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        episodes = read_run(path).episodes
    assert len(episodes) >= 2 and [e.id for e in episodes] == list(range(len(episodes)))


def test_resimulation(tmp_path):
    path = tmp_path / "free.mcap"
    record(settings(shield="none", episodes=6, duration=30, seed=100), path)
    shield = load_shield("strict")
    report = replay([path], shield)
    results = resimulate(path, shield, report)
    assert len(results) == sum(e.first_infeasible is not None for e in report.per_episode)
    assert all(r.outcome in OUTCOMES for r in results)
    assert not [r for r in results if r.outcome == "did not reproduce"]  # they reproduce
    data = summary(results)
    for key in ("crashes_prevented", "crashes_not_prevented", "new_crashes"):
        assert key in data


def test_resimulation_reports_a_mismatch(tmp_path):
    """A recording whose states the environment does not reproduce is reported, not trusted."""
    real = tmp_path / "real.mcap"
    record(settings(shield="none", episodes=1, duration=5, seed=7), real)
    episode = read_run(real).episodes[0]
    tampered_state = dict(episode.steps[0].state, Reward=99.0)
    steps = (StepRecord(0, 0.0, None, tampered_state, 0.0, False),) + tuple(
        StepRecord(s.step, s.time, "FASTER" if s.step == 1 else s.action, s.state, s.reward,
                   s.crashed) for s in episode.steps[1:])
    fake = tmp_path / "fake.mcap"
    header = read_run(real).header
    with EpisodeWriter(fake, header) as w:
        w.write(Episode(0, steps, make_end(steps), seed=7))
    shield = load_shield("none")
    report = replay([fake], shield)
    # force the episode to be re-simulated from step 1
    item = report.per_episode[0]
    report.per_episode[0] = dataclasses.replace(item, first_infeasible=1)
    (result,) = resimulate(fake, shield, report, agent=BASE)
    assert result.outcome == "did not reproduce" and result.detail.startswith("step 0: Reward")


def test_agent_errors(tmp_path):
    with pytest.raises(InputError, match="no such agent file"):
        load_agent(tmp_path / "none.zip")
    text = tmp_path / "agent.zip"
    text.write_text("not a zip")
    with pytest.raises(InputError, match="not a stable-baselines3 agent \\(not a zip archive\\)"):
        load_agent(text)
    other = tmp_path / "other.zip"
    with zipfile.ZipFile(other, "w") as z:
        z.writestr("hello.txt", "hi")
    with pytest.raises(InputError, match="is not a stable-baselines3 DQN, PPO or A2C agent"):
        load_agent(other)


def test_agent_with_the_wrong_action_space(tmp_path):
    import stable_baselines3 as sb3

    model = sb3.PPO("MlpPolicy", "CartPole-v1", n_steps=16, batch_size=16, device="cpu")
    path = tmp_path / "cartpole.zip"
    model.save(path)
    from tracecheck.live.adapter import get_adapter

    with pytest.raises(InputError, match="action space Discrete\\(2\\); highway has 5"):
        load_agent(path, get_adapter("highway"))
    # without an adapter no environment is assumed (the highway was): loaded as it is
    assert load_agent(path).algorithm == "PPO"


@pytest.mark.parametrize("args,fragment", [
    (["--agent", "missing.zip"], "no such agent file: missing.zip"),
    (["--agent", str(BASE), "--shield", "sturdy"], "unknown shield 'sturdy'"),
    (["--agent", str(BASE), "-o", "/proc/nope/run.mcap"], "cannot write /proc/nope/run.mcap"),
    (["--agent", str(BASE), "--fallback", "BRAKE"], "unknown fallback action 'BRAKE'"),
])
def test_record_bad_input_before_any_episode(capsys, tmp_path, args, fragment):
    cmd = ["record", "--episodes", "2", "-o", str(tmp_path / "r.mcap"), *args]
    code, _, err = run(capsys, *cmd)
    assert code == 2 and fragment in err and "Traceback" not in err


def test_train_writes_agent_and_card(capsys, tmp_path):
    out = tmp_path / "agent.zip"
    code, text, _ = run(capsys, "train", "--env", "highway", "--steps", "64", "--seed", "3", "-o", str(out))
    assert code == 0 and out.exists()
    card = json.loads(out.with_suffix(".json").read_text())
    assert card["steps"] == 64 and card["seed"] == 3 and card["reward_profile"] == "base"
    assert card["settings"]["learning_rate"] == 5e-4 and card["settings"]["gamma"] == 0.9
    assert card["settings"]["policy_kwargs"] == {"net_arch": [256, 256]}
    assert set(card["versions"]) >= {"torch", "stable_baselines3", "highway_env"}
    assert load_agent(out).sha256 == card["sha256"]


def test_cli_record_and_resimulate(capsys, tmp_path):
    path = tmp_path / "run.mcap"
    code, out, _ = run(capsys, "record", "--agent", str(BASE), "--episodes", "2",
                       "--duration", "6", "--seed", "5", "-o", str(path))
    assert code == 0 and out.startswith("recorded 2 episode(s)")
    # the quick start's first line: wrapped between words at 80 columns, the path whole
    assert max(map(len, out.splitlines())) <= max(80, len(str(path)))
    assert str(path) in out.splitlines()[-1]
    code, out, _ = run(capsys, "replay", str(path), "--shield", "strict", "--resimulate",
                       "--json")
    data = json.loads(out)
    assert code == 0 and "resimulation" in data
    assert data["resimulation"]["resimulated"] == data["infeasible_episodes"]


def test_sample_traces_are_paired_and_consistent():
    none = read_run(ROOT / "sample_traces" / "base_none.mcap")
    paper = read_run(ROOT / "sample_traces" / "base_paper.mcap")
    assert [e.seed for e in none.episodes] == [e.seed for e in paper.episodes] == list(range(24))
    for a, b in zip(none.episodes, paper.episodes):
        assert a.steps[0].state == b.steps[0].state  # the same scenario
    shield = load_shield("paper")
    assert replay([ROOT / "sample_traces" / "base_paper.mcap"], shield).infeasible_steps == 0
    assert replay([ROOT / "sample_traces" / "base_none.mcap"], shield).infeasible_steps > 0


def test_a_run_file_cannot_point_resimulation_at_an_agent_of_its_choosing(tmp_path):
    """The header's agent id is looked up by plain name among the bundled agents, with the
    sha256 required: `../` paths, absolute paths and a missing hash are never followed."""
    from types import SimpleNamespace

    from tracecheck.live.resimulate import AGENT_DIR, _agent_path
    from tracecheck.live.agents import file_sha256

    evil = tmp_path / "evil.zip"
    evil.write_bytes((AGENT_DIR / "base.zip").read_bytes())
    digest = file_sha256(evil)
    for agent_id, sha in [(str(tmp_path / "evil"), digest),
                          ("../../" + str(tmp_path / "evil").lstrip("/"), digest),
                          ("base", None), (str(tmp_path / "evil"), None)]:
        header = SimpleNamespace(agent_id=agent_id, agent_sha256=sha, agent_file=str(evil))
        with pytest.raises(InputError, match="cannot tell which agent recorded"):
            _agent_path(header, None)
    bundled = SimpleNamespace(agent_id="base", agent_sha256=file_sha256(AGENT_DIR / "base.zip"),
                              agent_file=None)
    assert _agent_path(bundled, None) == str(AGENT_DIR / "base.zip")


def test_an_existing_output_is_kept_until_a_new_episode_is_complete(tmp_path, capsys):
    """record refuses an existing file without --force; with it, a run that fails before
    its first episode leaves the old file as it was; a lock stops a second writer."""
    from tracecheck.episodes.files import recording_into
    from tracecheck.episodes.writer import new_header

    out = tmp_path / "run.mcap"
    code, _, err = run(capsys, "record", "--agent", str(BASE), "--shield", "none", "-n", "1",
                       "--duration", "2", "-o", str(out))
    assert code == 0, err
    before = out.read_bytes()
    code, _, err = run(capsys, "record", "--agent", str(BASE), "--shield", "none", "-n", "1",
                       "--duration", "2", "-o", str(out))
    assert code == 2 and "run.mcap exists; give another name, or --force" in err
    with pytest.raises(RuntimeError):
        with recording_into(out, new_header("recorded"), force=True):
            raise RuntimeError("the agent broke before its first episode")
    assert out.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]  # no temporary file, no lock
    with recording_into(tmp_path / "other.mcap", new_header("recorded")):
        with pytest.raises(InputError, match="another tracecheck is writing .*other.mcap"):
            with recording_into(tmp_path / "other.mcap", new_header("recorded")):
                pass
    assert not (tmp_path / "other.mcap.lock").exists()
    code, _, err = run(capsys, "record", "--agent", str(BASE), "--shield", "none", "-n", "1",
                       "--duration", "3", "-o", str(out), "--force")
    assert code == 0 and out.read_bytes() != before, err


def test_export_simb_refuses_a_folder_that_is_not_empty(tmp_path, capsys):
    folder = tmp_path / "simb"
    folder.mkdir()
    (folder / "Timed_Simulation_99.json").write_text("{}")
    sample = ROOT / "sample_traces" / "base_none.mcap"
    code, _, err = run(capsys, "export", "simb", str(sample), "-o", str(folder))
    assert code == 2 and "simb is not empty" in err and "or --force to replace" in err
    code, _, err = run(capsys, "export", "simb", str(sample), "-o", str(folder), "--force")
    assert code == 0 and not (folder / "Timed_Simulation_99.json").exists()
    assert len(list(folder.glob("Timed_Simulation_*.json"))) == 24


def test_a_shield_whose_sets_do_not_fit_the_environment_is_refused_before_recording():
    """A 4x4 lake under the 8x8 shield: the map is no function on the shield's cells, and
    replay would report an invariant violation at every state; record says so at once."""
    from tracecheck.checking.shield import check_vocabulary, load_shield
    from tracecheck.errors import InputError
    from tracecheck.live.adapter import get_adapter

    adapter = get_adapter("frozenlake")
    shield = load_shield("frozenlake", actions=adapter.actions)
    env = adapter.make_env({"map_name": "4x4"})
    try:
        with pytest.raises(InputError, match=r"the first state of frozenlake breaks the "
                                             r"invariant of the shield frozenlake: field : "
                                             r"\(0..n-1\) \* \(0..n-1\) --> GROUND\n"
                                             r".*a map of another size"):
            check_vocabulary(shield, adapter, env)
        check_vocabulary(shield, adapter, adapter.make_env(adapter.default_config()))  # 8x8 fits
    finally:
        env.close()


def test_a_q_table_refuses_an_observation_outside_its_rows(tmp_path):
    """An observation past the Q-table's rows was numpy's IndexError; -1 silently read the
    last row (an action chosen from another state's values)."""
    import numpy as np

    table = tmp_path / "q.npy"
    np.save(table, np.arange(12, dtype=float).reshape(4, 3))
    agent = load_agent(table)
    assert agent.values(3).tolist() == [9.0, 10.0, 11.0]
    for obs in (4, -1):
        with pytest.raises(InputError, match=rf"the observation {obs} is no row of the "
                                             r"Q-table q.npy \(4 rows\)"):
            agent.values(obs)


def test_a_run_in_another_world_than_the_agents_card_says_so(tmp_path, capsys):
    """The bundled Q-table learnt a slippery lake; the lake's default is not slippery (as
    the authors' code): record ran it there and said nothing (a new user saw it push
    Move_Up against the wall for 100 steps). The card and the default agree on the
    highway: no note."""
    from tests.helpers import run as cli
    from tracecheck.live.adapter import get_adapter
    from tracecheck.live.agents import card_config_note

    lake = ROOT / "models" / "agents" / "frozenlake.npy"
    note = card_config_note(lake, get_adapter("frozenlake"))
    assert note == ("note: frozenlake.npy was trained with is_slippery = True (its model "
                    "card); this run takes frozenlake's default, is_slippery = False "
                    "(--env-config is_slippery=true gives the card's)")
    assert card_config_note(BASE, get_adapter("highway")) is None
    code, _, err = cli(capsys, "record", "--env", "frozenlake", "--agent", lake, "-n", 1,
                       "-o", tmp_path / "a.mcap")
    assert code == 0 and "was trained with is_slippery = True" in " ".join(err.split())
    code, _, err = cli(capsys, "record", "--env", "frozenlake", "--agent", lake, "-n", 1,
                       "-o", tmp_path / "b.mcap", "--env-config", "is_slippery=true")
    assert code == 0 and "trained with" not in err
