"""Shielded training: the learner never asks for an action the shield blocks, in exploration
or exploitation, and what it learns records with no infeasible step."""

from __future__ import annotations

import json

import pytest

from tests.cli.test_cli import run
from tracecheck.checking.shield import load_shield
from tracecheck.live.adapter import get_adapter
from tracecheck.live.training import train_shielded
from tracecheck.live.wrapper import ShieldWrapper

pytest.importorskip("stable_baselines3")


@pytest.fixture
def blocked_requests(monkeypatch):
    """Every step's request, and how many were actions the shield blocked."""
    seen = {"steps": 0, "blocked": 0}
    step = ShieldWrapper.step

    def spy(self, action):
        seen["steps"] += 1
        seen["blocked"] += not self.action_masks()[int(action)]
        return step(self, action)

    monkeypatch.setattr(ShieldWrapper, "step", spy)
    return seen


@pytest.mark.parametrize("algorithm", ["dqn", "maskable-ppo"])
def test_a_masked_learner_never_asks_for_a_blocked_action(tmp_path, blocked_requests,
                                                          algorithm):
    if algorithm == "maskable-ppo":
        pytest.importorskip("sb3_contrib")
    adapter = get_adapter("cliffwalking")
    shield = load_shield("cliffwalking", actions=adapter.actions)
    card = train_shielded(adapter, adapter.config(), shield, algorithm, tmp_path / "a.zip",
                          steps=600, seed=1)
    assert blocked_requests["steps"] >= 600 and blocked_requests["blocked"] == 0
    assert (card["shield"], card["shield_sha256"]) == ("cliffwalking", shield.sha256)
    assert json.loads((tmp_path / "a.json").read_text())["masked"] is True


def test_an_unmasked_learner_does_ask_for_blocked_actions(blocked_requests):
    """The control: the spy sees blocked requests from a DQN that ignores the masks."""
    import stable_baselines3 as sb3

    adapter = get_adapter("cliffwalking")
    env = ShieldWrapper(adapter.make_env(adapter.config()),
                        load_shield("cliffwalking", actions=adapter.actions), adapter=adapter)
    sb3.DQN("MlpPolicy", env, seed=1, learning_starts=100, device="cpu").learn(300)
    assert blocked_requests["blocked"] > 0


def test_train_on_the_highway_then_record_with_no_infeasible_step(capsys, tmp_path):
    pytest.importorskip("sb3_contrib")
    agent = tmp_path / "shielded.zip"
    code, out, _ = run(capsys, "train", "--env", "highway", "--shield", "paper", "--algorithm",
                       "maskable-ppo", "--steps", "200", "--duration", "10", "-o", str(agent))
    said = " ".join(out.split())  # wrapped between words at 80 columns
    assert code == 0 and "(MaskablePPO under shield paper, 200 steps, seed 0)" in said
    card = json.loads(agent.with_suffix(".json").read_text())
    assert card["shield_sha256"] == load_shield("paper").sha256
    recorded = tmp_path / "run.mcap"
    assert run(capsys, "record", "--agent", str(agent), "--shield", "paper", "--episodes", "2",
               "--duration", "10", "-o", str(recorded))[0] == 0
    code, out, _ = run(capsys, "replay", str(recorded), "--shield", "paper", "--json")
    assert code == 0 and json.loads(out)["infeasible_steps"] == 0


def test_shielded_training_says_what_it_cannot_do(capsys, tmp_path):
    code, _, err = run(capsys, "train", "--env", "frozenlake", "--shield", "paper",
                       "--algorithm", "dqn", "-o", str(tmp_path / "a.zip"))
    assert code == 2 and "Move_" in err
    code, _, err = run(capsys, "train", "--env", "frozenlake", "--shield", "frozenlake",
                       "--algorithm", "q-learning", "-o", str(tmp_path / "a.npy"))
    assert code == 2 and "shielded training takes --algorithm dqn or maskable-ppo" in err
    code, _, err = run(capsys, "train", "--env", "frozenlake", "--shield", "frozenlake",
                       "--algorithm", "dqn", "-o", str(tmp_path / "a.npy"))
    assert code == 2 and "saved as .zip, not a.npy" in err


def test_without_sb3_contrib_maskable_ppo_says_how_to_get_it(capsys, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "sb3_contrib", None)  # as if not installed
    code, _, err = run(capsys, "train", "--env", "cliffwalking", "--shield", "cliffwalking",
                       "--algorithm", "maskable-ppo", "--steps", "10", "-o",
                       str(tmp_path / "a.zip"))
    assert code == 2 and "--algorithm maskable-ppo needs sb3-contrib" in err
    assert "pip install 'tracecheck[maskable]'" in err
