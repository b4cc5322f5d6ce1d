"""Minari both ways: a run exported as a dataset that minari itself loads with the same
episodes, and the dataset imported back replaying exactly like the original."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.cli.test_cli import run
from tests.cli.test_formats import _untimed
from tests.conftest import ROOT
from tracecheck.episodes.codec import encode_state
from tracecheck.episodes.reader import read_run

minari = pytest.importorskip("minari")
pytest.importorskip("h5py")

PAPER = ROOT / "sample_traces" / "base_paper.mcap"
NONE = ROOT / "sample_traces" / "base_none.mcap"
ACTIONS = ["LANE_LEFT", "IDLE", "LANE_RIGHT", "FASTER", "SLOWER"]


@pytest.fixture(autouse=True)
def datasets(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "datasets"))
    return tmp_path / "datasets"


def _replay(capsys, path, shield="paper"):
    code, out, _ = run(capsys, "replay", str(path), "--shield", shield, "--json")
    assert code == 0
    data = _untimed(json.loads(out))
    data.pop("files")
    for e in data["per_episode"]:
        e.pop("file")
    return data


def test_minari_loads_the_same_episodes(capsys):
    code, out, _ = run(capsys, "export", "minari", str(PAPER), "--dataset-id",
                       "tracecheck/highway/paper-v0")
    assert code == 0 and "wrote 24 episode(s), 1370 step(s) -> Minari dataset" in out
    dataset = minari.load_dataset("tracecheck/highway/paper-v0")
    original = read_run(PAPER).episodes
    loaded = list(dataset.iterate_episodes())
    assert dataset.total_episodes == 24 and len(loaded) == 24
    seeds = [m["seed"] for m in dataset.storage.get_episode_metadata(range(24))]
    assert seeds == [e.seed for e in original] == list(range(24))
    for ep, data in zip(original, loaded):
        assert data.id == ep.id
        assert [ACTIONS[a] for a in data.actions] == [s.action for s in ep.steps[1:]]
        assert np.allclose(data.rewards, [s.reward for s in ep.steps[1:]])
        assert np.allclose(data.observations, [s.observation for s in ep.steps])
        assert bool(data.terminations[-1]) == (ep.end.reason != "time-limit")
        assert bool(data.truncations[-1]) == (ep.end.reason == "time-limit")
        assert not data.terminations[:-1].any() and not data.truncations[:-1].any()
        step = ep.steps[3]
        assert [ACTIONS[i] for i in np.flatnonzero(data.infos["allowed"][3])] == \
            sorted(step.allowed_actions, key=ACTIONS.index)
        assert bool(data.infos["intervened"][3]) == (step.preferred_action != step.action)
        assert not data.infos["allowed"][0].any()  # the reset: no shield decision
        assert json.loads(data.infos["b_state"][3]) == encode_state(step.state)
    about = json.loads(dataset.storage.metadata["tracecheck"])
    assert (about["agent"], about["shield"]) == ("base", "paper")
    assert about["shield_sha256"] == read_run(PAPER).header.shield_sha256
    assert "paper" in dataset.storage.metadata["description"]
    env = dataset.recover_environment()
    assert env.spec.id == "highway-fast-v0" and env.unwrapped.config["lanes_count"] == 3
    env.close()
    code, _, err = run(capsys, "export", "minari", str(PAPER), "--dataset-id",
                       "tracecheck/highway/paper-v0")
    assert code == 2 and "cannot create the Minari dataset tracecheck/highway/paper-v0" in err


@pytest.mark.parametrize("source,shield", [(NONE, "paper"), (NONE, "strict"), (PAPER, "paper")])
def test_an_imported_dataset_replays_like_the_original(capsys, tmp_path, source, shield):
    dataset_id = f"tracecheck/highway/{source.stem.replace('_', '-')}-v0"
    if not (tmp_path / "datasets" / dataset_id).exists():
        assert run(capsys, "export", "minari", str(source), "--dataset-id", dataset_id)[0] == 0
    back = tmp_path / "back.mcap"
    code, out, _ = run(capsys, "import", "minari", dataset_id, "--env", "highway", "-o",
                       str(back))
    assert code == 0 and "imported 24 episode(s)" in out
    assert _replay(capsys, back, shield) == _replay(capsys, source, shield)
    header = read_run(back).header
    assert (header.source, header.agent_id, header.shield_name) == ("imported-minari", "base",
                                                                    source.stem.split("_")[1])
    assert [e.seed for e in read_run(back).episodes] == list(range(24))


def test_a_grid_world_goes_both_ways(capsys, tmp_path):
    recorded = tmp_path / "lake.mcap"
    code, _, _ = run(capsys, "record", "--env", "frozenlake", "--agent",
                     str(ROOT / "models" / "agents" / "frozenlake.npy"), "--shield", "none",
                     "--episodes", "3", "--seed", "5", "-o", str(recorded))
    assert code == 0
    assert run(capsys, "export", "minari", str(recorded), "--dataset-id",
               "tracecheck/lake/test-v0")[0] == 0
    data = next(minari.load_dataset("tracecheck/lake/test-v0").iterate_episodes())
    assert data.observations.dtype.kind == "i"  # FrozenLake's Discrete observations
    back = tmp_path / "back.mcap"
    assert run(capsys, "import", "minari", "tracecheck/lake/test-v0", "--env", "frozenlake",
               "-o", str(back))[0] == 0
    assert _replay(capsys, back, "frozenlake") == _replay(capsys, recorded, "frozenlake")


def test_what_cannot_be_exported_or_imported_is_said(capsys, tmp_path, paper_traces):
    imported = tmp_path / "simb.mcap"
    assert run(capsys, "import", "simb", str(paper_traces / "simb" / "base"), "-o",
               str(imported))[0] == 0
    code, _, err = run(capsys, "export", "minari", str(imported), "--dataset-id", "t/h/x-v0")
    assert code == 2
    assert "has no observation (imported traces record none)" in err or \
        "names no environment adapter" in err
    code, _, err = run(capsys, "import", "minari", "t/h/missing-v0", "--env", "highway", "-o",
                       str(tmp_path / "x.mcap"))
    assert code == 2 and "cannot load the Minari dataset t/h/missing-v0" in err
    assert not (tmp_path / "x.mcap").exists()


def test_without_minari_the_commands_say_how_to_get_it(capsys, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "minari", None)  # as if not installed
    code, _, err = run(capsys, "export", "minari", str(PAPER), "--dataset-id", "t/h/x-v0")
    assert code == 2 and "Minari is not installed" in err
    assert "pip install 'tracecheck[minari]'" in err


def test_a_users_own_adapter_is_named_on_the_command_line(capsys, tmp_path):
    """A run of the user's own environment: the file names its adapter, but only the command
    line may import one (--env package.module:Class)."""
    import numpy as np

    from tests.live.toy import SHIELD, left_leaning_table

    shield, agent = tmp_path / "corridor.mch", tmp_path / "left.npy"
    shield.write_text(SHIELD)
    np.save(agent, left_leaning_table())
    recorded = tmp_path / "toy.mcap"
    toy = "tests.live.toy:Corridor"
    assert run(capsys, "record", "--env", toy, "--agent", str(agent), "--shield", "none", "-n",
               "4", "-o", str(recorded))[0] == 0
    code, _, err = run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/toy/x-v0")
    assert code == 2 and "unknown environment 'corridor'" in err and "--env" in err
    assert run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/toy/x-v0",
               "--env", toy)[0] == 0
    code, _, err = run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/toy/y-v0",
                       "--env", "highway")  # the wrong adapter: its spaces do not fit
    assert code == 2 and f"{recorded}: unknown setting 'slip' for the environment highway" \
        in " ".join(err.split())
    back = tmp_path / "back.mcap"
    assert run(capsys, "import", "minari", "t/toy/x-v0", "--env", toy, "-o", str(back))[0] == 0
    assert _replay(capsys, back, str(shield)) == _replay(capsys, recorded, str(shield))


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("actions,space,message", [
    ([0.5, 0.75], "box", "the action [0.5] is not an action index"),
    ([1, 7], "discrete", "action 7 is not one of the adapter's 2 actions"),
], ids=["continuous", "out-of-range"])
def test_a_dataset_whose_actions_are_not_the_adapter_s_is_refused(capsys, tmp_path, actions,
                                                                  space, message):
    """Never rounded or cut to fit: a wrong action would replay as another one."""
    import gymnasium as gym
    import numpy as np
    from minari.data_collector.episode_buffer import EpisodeBuffer

    spaces = {"box": gym.spaces.Box(0.0, 1.0, (1,)), "discrete": gym.spaces.Discrete(8)}
    values = ([np.array([a], dtype=np.float32) for a in actions] if space == "box"
              else actions)
    minari.create_dataset_from_buffers(
        dataset_id=f"t/toy/{space}-v0", buffer=[EpisodeBuffer(
            observations=[2, 3, 4], actions=values, rewards=[0.0, 0.0],
            terminations=[False, False], truncations=[False, True])],
        action_space=spaces[space], observation_space=gym.spaces.Discrete(6),
        algorithm_name="x", author="x", author_email="x", code_permalink="x")
    code, _, err = run(capsys, "import", "minari", f"t/toy/{space}-v0", "--env",
                       "tests.live.toy:Corridor", "-o", str(tmp_path / "x.mcap"))
    assert code == 2 and message in err and f"t/toy/{space}-v0, episode 0, step" in err
    assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize("meta", ['{"agent": ', '[1, 2]', '{"shield": 5}'])
def test_malformed_provenance_is_refused(capsys, tmp_path, meta):
    assert run(capsys, "export", "minari", str(PAPER), "--dataset-id", "t/h/p-v0")[0] == 0
    minari.load_dataset("t/h/p-v0").storage.update_metadata({"tracecheck": meta})
    code, _, err = run(capsys, "import", "minari", "t/h/p-v0", "--env", "highway", "-o",
                       str(tmp_path / "x.mcap"))
    assert code == 2 and "t/h/p-v0: its 'tracecheck' metadata is not what tracecheck" in err
