"""Training: every algorithm on any environment with an adapter, one path; the shield in the
loop (masked learners never ask for a blocked action, PPO and A2C have theirs replaced); the
model card, the learning curve and the progress bar's mean return."""

from __future__ import annotations

import json
import struct
from contextlib import contextmanager

import numpy as np
import pytest

from tests.helpers import run
from tests.live.toy import SHIELD, Corridor
from tracecheck.checking.shield import load_shield
from tracecheck.errors import InputError
from tracecheck.live.adapter import get_adapter
from tracecheck.live.agents import load_agent
from tracecheck.live.envs.highway import PAPER_DQN
from tracecheck.live.training import LEARNERS, Training, train_agent
from tracecheck.live.wrapper import ShieldWrapper
from tracecheck.render.curves import CURVE_SIZE

pytest.importorskip("stable_baselines3")

TOY = "tests.live.toy:Corridor"
CLASSES = {"dqn": "DQN", "ppo": "PPO", "a2c": "A2C", "maskable-ppo": "MaskablePPO",
           "q-learning": "q-learning"}


def png_size(path) -> tuple[int, int]:
    """Width and height from a PNG's header (its IHDR chunk comes first)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


@pytest.fixture
def blocked_requests(monkeypatch):
    """Every step's request, how many were actions the shield blocked, and how many blocked
    actions the environment was given."""
    seen = {"steps": 0, "blocked": 0, "taken_blocked": 0}
    step = ShieldWrapper.step

    def spy(self, action):
        seen["steps"] += 1
        seen["blocked"] += not self.action_masks()[int(action)]
        allowed = self.action_masks().copy()
        result = step(self, action)
        taken = self.actions.index(result[4]["shield"]["taken"])
        seen["taken_blocked"] += not allowed[taken]
        return result

    monkeypatch.setattr(ShieldWrapper, "step", spy)
    return seen


@pytest.mark.parametrize("algorithm", list(CLASSES))
def test_every_algorithm_trains_on_a_users_environment_and_records(capsys, tmp_path,
                                                                   algorithm):
    """No --shield needed (dqn was refused off the highway; ppo and a2c were no choice), and
    what is trained records; PPO and A2C files load as what they are (an A2C file loads as a
    PPO too)."""
    if algorithm == "maskable-ppo":
        pytest.importorskip("sb3_contrib")
    agent = tmp_path / ("a.npy" if algorithm == "q-learning" else "a.zip")
    code, out, err = run(capsys, "train", "--env", TOY, "--algorithm", algorithm, "--steps",
                         "300", "-o", str(agent))
    said = " ".join(out.split())
    assert code == 0, err
    assert f"trained {agent.name} ({CLASSES[algorithm]} on corridor" in said
    assert "episodes" in said and str(tmp_path / "a.curve.png") in said
    card = json.loads(agent.with_suffix(".json").read_text())
    assert card["algorithm"] == CLASSES[algorithm] and card["environment"] == "corridor"
    assert card["steps"] == 300 and card["environment_steps"] >= 300
    assert card["horizon"] == Corridor.horizon and card["seed"] == 0
    assert card["shielding"] == ("masked" if algorithm == "maskable-ppo" else "none")
    curve = card["learning_curve"]
    assert curve["file"] == "a.curve.png" and curve["episodes"] == len(curve["returns"]) > 0
    assert all(0 <= r <= 1 for r in curve["returns"])  # the corridor pays 1 at its end
    assert curve["end_steps"] == sorted(curve["end_steps"])
    assert png_size(tmp_path / "a.curve.png") == CURVE_SIZE
    assert load_agent(agent, Corridor(), Corridor().make_env({})).algorithm == \
        CLASSES[algorithm]
    code, out, err = run(capsys, "record", "--env", TOY, "--agent", str(agent), "-n", "2",
                         "-o", str(tmp_path / "run.mcap"))
    assert code == 0 and "recorded 2 episode(s)" in out, err


@pytest.mark.parametrize("algorithm", ["dqn", "maskable-ppo"])
def test_a_masked_learner_never_asks_for_a_blocked_action(tmp_path, blocked_requests,
                                                          algorithm):
    if algorithm == "maskable-ppo":
        pytest.importorskip("sb3_contrib")
    adapter = get_adapter("cliffwalking")
    shield = load_shield("cliffwalking", actions=adapter.actions)
    card = train_agent(adapter, adapter.config(), algorithm, tmp_path / "a.zip",
                       Training(steps=600, seed=1), shield=shield)
    assert blocked_requests["steps"] >= 600 and blocked_requests["blocked"] == 0
    assert (card["shield"], card["shield_sha256"]) == ("cliffwalking", shield.sha256)
    card = json.loads((tmp_path / "a.json").read_text())
    assert card["masked"] is True and card["shielding"] == "masked"


@pytest.mark.parametrize("algorithm", ["ppo", "a2c"])
def test_ppo_and_a2c_under_a_shield_have_blocked_actions_replaced(capsys, tmp_path,
                                                                  blocked_requests, algorithm):
    """They take no mask: the learner asks for blocked actions, the environment never gets
    one, and the card and the output line say how the shield reached the learner."""
    shield = tmp_path / "corridor.mch"
    shield.write_text(SHIELD)
    agent = tmp_path / "a.zip"
    code, out, err = run(capsys, "train", "--env", TOY, "--algorithm", algorithm, "--shield",
                         str(shield), "--steps", "300", "-o", str(agent))
    assert code == 0, err
    assert f"({CLASSES[algorithm]} on corridor under shield corridor, blocked actions " \
           "replaced, 300 steps" in " ".join(out.split())
    assert blocked_requests["blocked"] > 0 and blocked_requests["taken_blocked"] == 0
    card = json.loads(agent.with_suffix(".json").read_text())
    assert (card["shielding"], card["masked"], card["shield"]) == ("replaced", False,
                                                                   "corridor")


def test_an_unmasked_learner_does_ask_for_blocked_actions(blocked_requests):
    """The control: the spy sees blocked requests from a DQN that ignores the masks."""
    import stable_baselines3 as sb3

    adapter = get_adapter("cliffwalking")
    env = ShieldWrapper(adapter.make_env(adapter.config()),
                        load_shield("cliffwalking", actions=adapter.actions), adapter=adapter)
    sb3.DQN("MlpPolicy", env, seed=1, learning_starts=100, device="cpu").learn(300)
    assert blocked_requests["blocked"] > 0


def test_the_paper_settings_stay_the_highways_and_others_get_their_own():
    dqn = LEARNERS["dqn"].settings
    highway = get_adapter("highway")
    assert {**dqn(20_000), **highway.training_settings("dqn", 20_000)} == dict(
        PAPER_DQN, exploration_fraction=0.3)
    assert get_adapter("cliffwalking").training_settings("dqn", 20_000) == {}
    assert dqn(20_000)["gamma"] == 0.99 and "policy_kwargs" not in dqn(20_000)
    assert {**LEARNERS["ppo"].settings(20_000), **highway.training_settings("ppo", 20_000)} == {
        "n_steps": 2048, "batch_size": 64, "learning_rate": 3e-4, "gamma": 0.8}
    assert LEARNERS["ppo"].settings(300)["n_steps"] == 320  # one rollout, whole batches
    assert LEARNERS["ppo"].settings(3000)["n_steps"] == 1536  # two, not 2 × 2048
    assert LEARNERS["ppo"] is not LEARNERS["maskable-ppo"]
    assert LEARNERS["maskable-ppo"].settings is LEARNERS["ppo"].settings


def test_the_progress_bar_shows_the_running_mean_return(capsys, tmp_path, monkeypatch):
    """The one progress helper, given the mean of the last 20 finished episodes."""
    import tracecheck.cli.live as live

    seen = []

    @contextmanager
    def fake(label, total=None, unit="episodes", detail="", **fields):
        seen.append((label, total, unit, detail, fields))
        yield lambda n=1, **changed: seen.append(changed)

    monkeypatch.setattr(live, "progress", fake)
    agent = tmp_path / "a.zip"
    assert run(capsys, "train", "--env", TOY, "--algorithm", "a2c", "--steps", "300", "-o",
               str(agent))[0] == 0
    label, total, unit, detail, fields = seen[0]
    assert (label, total, unit, fields) == ("training a2c on corridor", 300, "steps",
                                            {"mean": "-"})
    assert "mean return {task.fields[mean]}" in detail
    assert [c["completed"] for c in seen[1:]] == list(range(50, 301, 50))
    assert {c["total"] for c in seen[1:]} == {300}
    curve = json.loads(agent.with_suffix(".json").read_text())["learning_curve"]
    assert seen[-1]["mean"] == f"{np.mean(curve['returns'][-20:]):.2f}"


def test_train_on_the_highway_then_record_with_no_infeasible_step(capsys, tmp_path):
    pytest.importorskip("sb3_contrib")
    agent = tmp_path / "shielded.zip"
    code, out, _ = run(capsys, "train", "--env", "highway", "--shield", "paper", "--algorithm",
                       "maskable-ppo", "--steps", "200", "--duration", "10", "-o", str(agent))
    said = " ".join(out.split())  # wrapped between words at 80 columns
    assert code == 0 and "(MaskablePPO on highway under shield paper, actions masked, 200 steps, seed 0)" in said
    card = json.loads(agent.with_suffix(".json").read_text())
    assert card["shield_sha256"] == load_shield("paper").sha256
    assert card["horizon"] == 10 and card["settings"]["gamma"] == 0.8
    assert max(np.diff([0] + card["learning_curve"]["end_steps"])) <= 10  # cut at --duration
    recorded = tmp_path / "run.mcap"
    assert run(capsys, "record", "--agent", str(agent), "--shield", "paper", "--episodes", "2",
               "--duration", "10", "-o", str(recorded))[0] == 0
    code, out, _ = run(capsys, "replay", str(recorded), "--shield", "paper", "--json")
    assert code == 0 and json.loads(out)["infeasible_steps"] == 0


def test_replay_resimulates_with_a_ppo_agent(capsys, tmp_path):
    """A run of an agent that walks Right from the start, into the cliff; re-simulated under
    the shield, the PPO agent takes over at the first blocked step."""
    agent = tmp_path / "ppo.zip"
    assert run(capsys, "train", "--env", "cliffwalking", "--algorithm", "ppo", "--steps", "64",
               "-o", str(agent))[0] == 0
    right = tmp_path / "right.npy"
    np.save(right, np.eye(4)[[1] * 48])  # Move_Right everywhere
    recorded = tmp_path / "run.mcap"
    assert run(capsys, "record", "--env", "cliffwalking", "--agent", str(right), "-n", "2",
               "--duration", "20", "-o", str(recorded))[0] == 0
    code, out, err = run(capsys, "replay", str(recorded), "--shield", "cliffwalking",
                         "--resimulate", "--agent", str(agent), "--json")
    assert code == 0, err
    resimulated = json.loads(out)["resimulation"]
    assert (resimulated["resimulated"], resimulated["mismatches"]) == (2, 0)
    assert [e["first_infeasible"] for e in resimulated["per_episode"]] == [1, 1]


def test_training_says_what_it_cannot_do(capsys, tmp_path):
    code, _, err = run(capsys, "train", "--env", "frozenlake", "--shield", "paper",
                       "--algorithm", "dqn", "-o", str(tmp_path / "a.zip"))
    assert code == 2 and "Move_" in err
    code, _, err = run(capsys, "train", "--env", "frozenlake", "--shield", "frozenlake",
                       "--algorithm", "q-learning", "-o", str(tmp_path / "a.npy"))
    assert code == 2 and "--algorithm q-learning trains without a shield; with --shield, give " \
                         "--algorithm dqn, maskable-ppo, ppo or a2c" in " ".join(err.split())
    for algorithm, name, message in [("ppo", "a.npy", "a trained agent is saved as .zip, not "
                                      "a.npy"),
                                     ("q-learning", "a.zip", "a Q-table is saved as .npy, not "
                                      "a.zip")]:
        code, _, err = run(capsys, "train", "--env", "frozenlake", "--algorithm", algorithm,
                           "-o", str(tmp_path / name))
        assert code == 2 and message in err
    # a reward profile is the highway's: elsewhere it was silently ignored
    code, _, err = run(capsys, "train", "--env", "frozenlake", "--profile", "higher-penalty",
                       "-o", str(tmp_path / "a.zip"))
    assert code == 2 and ("--profile higher-penalty: the environment frozenlake has no named "
                          "configurations") in " ".join(err.split())
    assert "--env-config key=value" in err
    assert list(tmp_path.iterdir()) == []


def test_an_existing_learning_curve_is_kept_without_force(capsys, tmp_path):
    """The curve is an output like the agent and its card: checked before training starts."""
    (tmp_path / "a.curve.png").write_bytes(b"old")
    argv = ["train", "--env", TOY, "--algorithm", "a2c", "--steps", "50", "-o",
            str(tmp_path / "a.zip")]
    code, _, err = run(capsys, *argv)
    assert code == 2 and "a.curve.png exists; give another name, or --force" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.curve.png"]
    assert run(capsys, *argv, "--force")[0] == 0
    assert png_size(tmp_path / "a.curve.png") == CURVE_SIZE


def test_an_environment_without_discrete_actions_is_refused(tmp_path):
    import gymnasium as gym

    class Sliding(Corridor):
        def make_env(self, config, render_mode=None):
            env = super().make_env(config)
            env.action_space = gym.spaces.Box(-1.0, 1.0, (1,))
            return env

    with pytest.raises(InputError, match=r"corridor has the action space Box\(-1\.0, 1\.0, "
                       r"\(1,\), float32\); train needs 2 discrete actions, one per action of "
                       r"the adapter \(Left, Right\)"):
        train_agent(Sliding(), {}, "ppo", tmp_path / "a.zip", Training(steps=10))
    assert not (tmp_path / "a.zip").exists()


def test_without_sb3_contrib_maskable_ppo_says_how_to_get_it(capsys, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "sb3_contrib", None)  # as if not installed
    code, _, err = run(capsys, "train", "--env", "cliffwalking", "--shield", "cliffwalking",
                       "--algorithm", "maskable-ppo", "--steps", "10", "-o",
                       str(tmp_path / "a.zip"))
    assert code == 2 and "--algorithm maskable-ppo needs sb3-contrib" in err
    assert "pip install 'tracecheck[maskable]'" in err


@pytest.mark.parametrize("algorithm", ["ppo", "dqn"])
def test_an_agent_trained_on_images_records_on_the_same_adapter(capsys, tmp_path, algorithm):
    """Issue 42: stable-baselines3 trains on the channel-first transpose of a 7×7×3 image
    (3, 7, 7); record refused the agent `train` had just written for that adapter."""
    image = "tests.live.toy:ImageCorridor"
    agent = tmp_path / "a.zip"
    code, _, err = run(capsys, "train", "--env", image, "--algorithm", algorithm, "--steps",
                       "100", "-o", str(agent))
    assert code == 0, err
    code, out, err = run(capsys, "record", "--env", image, "--agent", str(agent), "-n", "2",
                         "-o", str(tmp_path / "run.mcap"))
    assert code == 0 and "recorded 2 episode(s)" in out, err
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", str(agent), "-n", "1",
                       "-o", str(tmp_path / "other.mcap"))
    assert code == 2 and "the agent observes Box(0, 255, (3, 7, 7), uint8)" in err


@pytest.mark.parametrize("workers", ["1", "2"])
def test_an_agent_trained_on_dict_observations_records_them_flattened(capsys, tmp_path,
                                                                       workers):
    """A new user's drone with a Dict observation (its position, its battery): train
    wrote the agent (SB3's MultiInputPolicy), and record failed with a traceback on the
    first observation."""
    from mcap.reader import make_reader

    env = "tests.live.toy:DictCorridor"
    agent, out = tmp_path / "a.zip", tmp_path / "run.mcap"
    code, _, err = run(capsys, "train", "--env", env, "--algorithm", "dqn", "--steps", "64",
                       "-o", str(agent))
    assert code == 0, err
    code, said, err = run(capsys, "record", "--env", env, "--agent", str(agent), "-n", "3",
                          "--workers", workers, "-o", str(out))
    assert code == 0 and "recorded 3 episode(s)" in said, err
    with open(out, "rb") as f:
        steps = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(
            topics=["/tracecheck/step"])]
    # gymnasium's flatten, as FlattenObservation gives it: the cell one-hot, then the lamps
    for step in steps:
        cell = step["state"]["pos"]
        assert step["observation"] == [[float(i == cell) for i in range(6)] +
                                       [np.float32(cell / 5).item(), 0.5]]


def test_an_environment_that_cannot_reset_is_said_by_record_and_train(capsys, tmp_path):
    """A new user's warehouse whose reset() raised: record under a shield (its first state
    tried against the shield) and train without one ended in a traceback."""
    shield = tmp_path / "corridor.mch"
    shield.write_text(SHIELD)
    table = tmp_path / "q.npy"
    np.save(table, np.zeros((6, 2)))
    broken = "tests.live.toy:BrokenCorridor"
    for args in (("record", "--env", broken, "--agent", str(table), "--shield", str(shield),
                  "-n", "1", "-o", str(tmp_path / "run.mcap")),
                 ("train", "--env", broken, "--algorithm", "ppo", "--steps", "64", "-o",
                  str(tmp_path / "a.zip"))):
        code, _, err = run(capsys, *args)
        assert code == 2 and "Traceback" not in err, err
        assert "raised RuntimeError in reset(): lidar not connected" in err, err


@pytest.mark.parametrize("shield", ["none", "cruise"])
def test_a_nan_observation_names_the_episode_step_and_variable(capsys, tmp_path, shield):
    """Issue 42: under a shield "the real result is out of range (overflow) in `W - M - X`",
    naming no NaN, episode or step; with --shield none a stable-baselines3 traceback."""
    from tests.live.toy import CRUISE_SHIELD

    agent = tmp_path / "a.zip"
    code, _, err = run(capsys, "train", "--env", "tests.live.toy:Cruise", "--algorithm", "ppo",
                       "--steps", "64", "-o", str(agent))
    assert code == 0, err
    path = tmp_path / "cruise.mch"
    path.write_text(CRUISE_SHIELD)
    code, _, err = run(capsys, "record", "--env", "tests.live.toy:NanCruise", "--agent",
                       str(agent), "--shield", str(path) if shield == "cruise" else "none",
                       "-n", "1", "-o", str(tmp_path / "run.mcap"))
    assert code == 2 and "Traceback" not in err
    said = " ".join(err.split())
    assert "episode 0 (seed 0), step 3: state() of the adapter nancruise: Gap is nan, not a " \
           "B real" in said, said
    assert "hint: B reals are finite numbers" in said


def test_a_continuous_agent_for_an_adapter_without_parameters_says_how_to_declare_them(
        tmp_path):
    import gymnasium as gym
    from stable_baselines3 import PPO

    from tests.live.toy import CorridorEnv

    env = CorridorEnv()
    env.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    path = tmp_path / "push.zip"
    PPO("MlpPolicy", env, n_steps=8, batch_size=8).save(path)
    with pytest.raises(InputError, match=r"has 2 discrete actions \(Left, Right\)") as info:
        load_agent(path, Corridor(), None)
    assert 'parameters = {"Left": ("u",)} in the adapter' in info.value.render()


def test_the_wrapper_takes_only_action_indices(tmp_path):
    path = tmp_path / "corridor.mch"
    path.write_text(SHIELD)
    from tests.live.toy import CorridorEnv

    env = ShieldWrapper(CorridorEnv(slip=False), load_shield(path), adapter=Corridor())
    env.reset(seed=0)
    for bad in (-1, 2, 2.7, "Left"):
        with pytest.raises(InputError, match=r"an action is an index 0 … 1"):
            env.step(bad)
    env.step(np.int64(1))


def test_actions_and_observations_of_spaces_that_do_not_start_at_0(capsys, tmp_path):
    """A new user's thermostat, Discrete(3, start=-1): the environment was given the action
    index (0, 1, 2) where it takes start + index, so every recorded Heat heated twice as much
    and Cool ran as Off — silently; train ended in a traceback (SB3 sampled -1). The agent,
    masks and records speak of indexes; the environment gets start + index."""
    from mcap.reader import make_reader

    from tracecheck.live.wrapper import indexed
    from tests.live.toy import OffsetCorridor, OffsetCorridorEnv

    path = tmp_path / "corridor.mch"
    path.write_text(SHIELD)
    shield = load_shield(path)
    env = ShieldWrapper(OffsetCorridorEnv(slip=False), shield, adapter=OffsetCorridor())
    assert env.action_space == __import__("gymnasium").spaces.Discrete(2)
    env.reset(seed=0)  # cell 2 (12): Left is -1, Right is 0 for the environment
    obs, *_, info = env.step(1)
    assert obs == 13 and info["shield"]["taken"] == "Right"
    obs, *_, info = env.step(0)
    assert obs == 12 and info["shield"]["taken"] == "Left"
    env.env.step = lambda action: (_ for _ in ()).throw(ValueError("lidar lost"))
    with pytest.raises(InputError, match=r"the environment of the adapter offsetcorridor "
                                         r"raised ValueError in step\(\): lidar lost"):
        env.step(1)  # the environment's own error: said, no traceback (exit 2)
    plain = indexed(OffsetCorridorEnv(slip=False))  # training's view: indexes from 0
    assert plain.reset(seed=0)[0] == 2 and plain.observation_space.n == 6
    assert plain.action_space.n == 2 and plain.step(1)[0] == 3
    assert indexed(env.env) is not env.env and indexed(OffsetCorridorEnv().unwrapped
                                                       ).action_space.start == 0
    spec = "tests.live.toy:OffsetCorridor"
    for args in (("--algorithm", "dqn"), ("--algorithm", "maskable-ppo", "--shield", str(path)),
                 ("--algorithm", "q-learning")):
        out = tmp_path / ("q.npy" if "q-learning" in args else f"{args[1]}.zip")
        code, _, err = run(capsys, "train", "--env", spec, *args, "--steps", "300", "-o", out)
        assert code == 0, err
    # the Q-table's rows are the cells 10 … 15 in order: Right (index 1) learnt near the goal
    table = np.load(tmp_path / "q.npy")
    assert table.shape == (6, 2) and table[4, 1] > 0.0
    run_file = tmp_path / "run.mcap"
    code, _, err = run(capsys, "record", "--env", spec, "--agent", tmp_path / "dqn.zip",
                       "--shield", path, "-n", "6", "-o", run_file)
    assert code == 0, err
    with open(run_file, "rb") as f:
        steps = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(
            topics=["/tracecheck/step"])]
    for before, after in zip(steps, steps[1:]):  # each action moved as its name says
        if after["step"] == before["step"] + 1:
            move = after["state"]["pos"] - before["state"]["pos"]
            assert move == {"Left": -1, "Right": 1}[after["action"]], (before, after)


def test_a_dict_observation_with_a_part_not_starting_at_0_is_refused(capsys, monkeypatch):
    """SB3 one-hot encodes a Discrete part from 0: Discrete(6, start=10) inside a Dict ended
    in its "Class values must be smaller than num_classes" traceback."""
    import gymnasium as gym

    from tests.live import toy

    space = gym.spaces.Dict({"cell": gym.spaces.Discrete(6, start=10),
                             "lamps": gym.spaces.Box(0.0, 1.0, (2,), np.float32)})
    monkeypatch.setattr(toy.DictCorridorEnv, "__init__", lambda self, slip=True,
                        render_mode=None: (toy.CorridorEnv.__init__(self, slip),
                                           setattr(self, "observation_space", space)) and None)
    code, _, err = run(capsys, "train", "--env", "tests.live.toy:DictCorridor", "--algorithm",
                       "dqn", "--steps", "64", "-o", "unused.zip")
    said = " ".join(err.split())
    assert code == 2 and "holds a discrete part that does not start at 0 (['cell'] " \
                         "Discrete(6, start=10)): Stable-Baselines3 one-hot encodes" in said
    from tracecheck.live.training import _offset_parts

    # a MultiDiscrete part (its start an array) is no error unless it starts elsewhere
    assert _offset_parts(gym.spaces.Dict({"m": gym.spaces.MultiDiscrete([6, 2])})) == []
    assert _offset_parts(gym.spaces.MultiDiscrete([6, 2], start=[1, 0])) == [
        "MultiDiscrete([6 2], start=[1 0])"]
    assert _offset_parts(gym.spaces.Discrete(6, start=10)) == []  # whole: made an index
