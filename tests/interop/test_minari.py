"""Minari both ways: a run exported as a dataset that minari itself loads with the same
episodes, and the dataset imported back replaying exactly like the original."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.helpers import ROOT, run, untimed
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
    data = untimed(json.loads(out))
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
                       "--env", "highway")  # the wrong adapter
    assert code == 2 and f"{recorded} was recorded in corridor, not highway" \
        in " ".join(err.split()) and "--env-config" not in err
    back = tmp_path / "back.mcap"
    assert run(capsys, "import", "minari", "t/toy/x-v0", "--env", toy, "-o", str(back))[0] == 0
    assert _replay(capsys, back, str(shield)) == _replay(capsys, recorded, str(shield))


def test_dict_observations_go_both_ways(capsys, tmp_path):
    """A Dict observation space (the cell, two lamps): recorded flattened, exported as the
    Dict it was (Minari's parts), imported back replaying as the run did."""
    env = "tests.live.toy:DictCorridor"
    agent, recorded, back = tmp_path / "a.zip", tmp_path / "dict.mcap", tmp_path / "back.mcap"
    assert run(capsys, "train", "--env", env, "--algorithm", "dqn", "--steps", "64", "-o",
               str(agent))[0] == 0
    assert run(capsys, "record", "--env", env, "--agent", str(agent), "-n", "3", "-o",
               str(recorded))[0] == 0
    assert run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/dict/x-v0",
               "--env", env)[0] == 0
    run_ = read_run(recorded)
    for ep, data in zip(run_.episodes, minari.load_dataset("t/dict/x-v0").iterate_episodes()):
        cells = [s.state["pos"] for s in ep.steps]
        assert data.observations["cell"].tolist() == cells
        assert data.observations["lamps"].tolist() == [
            [np.float32(c / 5).item(), 0.5] for c in cells]
    assert run(capsys, "import", "minari", "t/dict/x-v0", "--env", env, "-o", str(back))[0] == 0
    assert _replay(capsys, back, "none") == _replay(capsys, recorded, "none")


@pytest.mark.parametrize("row,said", [
    ([0, 1, 0, 0.5, 7, 3], None),
    ([0, 1, 0, 0.5, 0.25, 3], "the observation's number 0.25 at index 4 of its 6"),
    ([0, 1, 0, 0.5, 300, 3], "the observation's number 300.0 at index 4 of its 6"),
    ([0, 0.5, 0.5, 0.5, 7, 3], "the observation's number 0.5 at index 1 of its 6"),
    ([0, 0, 0, 0.5, 7, 3], "the observation is not a value of the environment's"),
    ([0, 1, 0, 2.0, 7, 3], "the observation is not a value of the environment's"),
])
def test_a_dict_observation_is_restored_exactly_or_refused(row, said):
    """gymnasium's unflatten casts without a word (0.25 to a uint8 0, 300 to 44, a one-hot
    of halves to its first): what would be written is flattened again and compared."""
    from gymnasium import spaces

    from tracecheck.errors import InputError
    from tracecheck.interop.minari import _unflattened

    space = spaces.Dict({"cell": spaces.Discrete(3, start=2), "f": spaces.Box(0.0, 1.0, (1,)),
                         "img": spaces.Box(0, 255, (2,), np.uint8)})
    if said is None:
        got = _unflattened(np.array(row, dtype=float), space, "run, episode 0, step 1")
        assert got["cell"] == 3 and got["f"].tolist() == [0.5] and got["img"].tolist() == [7, 3]
        return
    with pytest.raises(InputError) as info:
        _unflattened(np.array(row, dtype=float), space, "run, episode 0, step 1")
    assert info.value.message.startswith("run, episode 0, step 1: " + said)


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


TOY = "tests.live.toy:Corridor"


def _toy_dataset(dataset_id="t/toy/base-v0", episodes=3):
    """A small valid dataset of the corridor (Discrete observations), seeds 10, 11, …"""
    import gymnasium as gym
    from minari.data_collector.episode_buffer import EpisodeBuffer

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        minari.create_dataset_from_buffers(
            dataset_id=dataset_id, buffer=[EpisodeBuffer(
                id=i, seed=10 + i, observations=[2, 3, 2 + i % 2], actions=[1, i % 2],
                rewards=[0.0, 0.5], terminations=[False, i == 0], truncations=[False, i != 0])
                for i in range(episodes)],
            action_space=gym.spaces.Discrete(2), observation_space=gym.spaces.Discrete(6),
            algorithm_name="x", author="x", author_email="x", code_permalink="x")
    return dataset_id


def _box_dataset(dataset_id="t/toy/box-v0"):
    """The corridor with its position as a one-element Box (float observations)."""
    import gymnasium as gym
    from minari.data_collector.episode_buffer import EpisodeBuffer

    import warnings

    obs = [np.array([p], dtype=np.float64) for p in (2.0, 3.0, 4.0)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        minari.create_dataset_from_buffers(
            dataset_id=dataset_id, buffer=[EpisodeBuffer(
                observations=obs, actions=[1, 1], rewards=[0.0, 1.0],
                terminations=[False, True], truncations=[False, False])],
            action_space=gym.spaces.Discrete(2),
            observation_space=gym.spaces.Box(0.0, 5.0, (1,), dtype=np.float64),
            algorithm_name="x", author="x", author_email="x", code_permalink="x")
    return dataset_id


def _mutate(datasets, dataset_id, *, meta=None, h5=None):
    import h5py

    data = datasets / dataset_id / "data"
    if meta is not None:
        text = json.loads((data / "metadata.json").read_text())
        meta(text)
        (data / "metadata.json").write_text(json.dumps(text))
    if h5 is not None:
        with h5py.File(data / "main_data.hdf5", "a") as f:
            h5(f)


def _replace(f, path, values):
    del f[path]
    f.create_dataset(path, data=values)


def _import(capsys, tmp_path, dataset_id, env=TOY):
    out = tmp_path / "x.mcap"
    code, _, err = run(capsys, "import", "minari", dataset_id, "--env", env, "-o", str(out))
    return code, " ".join(err.split()), out


@pytest.mark.parametrize("meta,h5,message", [
    (None, lambda f: _replace(f, "episode_1/rewards", np.array([b"a", b"b"])),
     "t/toy/base-v0, episode 1: the rewards are |S1 of shape (2,), not numbers"),
    (None, lambda f: f["episode_1"].attrs.__setitem__("seed", "abc"),
     "t/toy/base-v0, episode 1: the seed 'abc' is not an integer"),
    (None, lambda f: f["episode_1"].attrs.__setitem__("seed", 1.5),
     "t/toy/base-v0, episode 1: the seed 1.5 is not an integer (a seed is never rounded)"),
    (None, lambda f: f["episode_1"].attrs.__setitem__("seed", np.uint64(2**64 - 1)),
     "episode 1: the seed 18446744073709551615 is out of range: a seed is 0 … 2^63 - 1"),
    (None, lambda f: f["episode_2"].attrs.__setitem__("seed", -3),
     "episode 2: the seed -3 is out of range"),
    (lambda m: m.update(total_episodes=10**12), None,
     "t/toy/base-v0: the metadata field total_episodes says 1000000000000, the data file "
     "holds 3 group(s)"),
    (lambda m: m.pop("dataset_id"), None,
     "t/toy/base-v0: the metadata field dataset_id is missing, not a string"),
    (lambda m: m.update(observation_space=json.dumps({"type": "Graph"})), None,
     "the metadata field observation_space is 'Graph', not a space Minari writes"),
    (lambda m: m.update(observation_space=json.dumps(
        {"type": "Box", "shape": [10**12], "low": 0, "high": 1, "dtype": "float32"})), None,
     "the metadata field observation_space has more than 16,777,216 elements"),
    (lambda m: m.update(env_spec=5), None, "the metadata field env_spec is 5, not a string"),
    (lambda m: m.update(env_spec="{"), None,
     "the metadata field env_spec is not a Gymnasium environment spec"),
    (lambda m: m.update(data_format="arrow"), None,
     "it is stored as 'arrow'; tracecheck imports Minari's hdf5 format"),
    (None, lambda f: (f["episode_0"].pop("rewards"), f["episode_0"].create_dataset(
        "rewards", shape=(10**12,), chunks=True, dtype="f8")),
     "episode 0: its arrays would take 8,000,000,000,0"),
    (None, lambda f: (f.pop("episode_1"), f.create_group("junk")),
     "episode 1: the data file has no group episode_1"),
    (None, lambda f: f["episode_0"].pop("truncations"), "episode 0: it has no truncations"),
], ids=["string-rewards", "seed-abc", "seed-1.5", "seed-2^64-1", "seed-negative",
        "10^12-episodes", "no-dataset-id", "unknown-space", "huge-space", "env-spec-5",
        "env-spec-not-json", "arrow", "huge-array", "missing-episode", "missing-key"])
def test_a_malformed_dataset_is_refused_naming_what(capsys, tmp_path, datasets, meta, h5,
                                                    message):
    """Field by field, before Minari reads it (and before a 7 TiB allocation): exit 2 with
    the dataset and the episode or metadata field, no traceback, no output."""
    dataset_id = _toy_dataset()
    assert _import(capsys, tmp_path, dataset_id)[0] == 0
    _mutate(datasets, dataset_id, meta=meta, h5=h5)
    code, err, out = _import(capsys, tmp_path / "again", dataset_id)
    assert code == 2 and message in err and "Traceback" not in err, err
    assert not out.exists()


def test_seeds_follow_their_episode_when_the_stored_id_differs(capsys, tmp_path, datasets):
    """Minari's episode is its group ``episode_N``; an ``id`` attribute that says otherwise
    does not move the seeds to other episodes."""
    dataset_id = _toy_dataset()

    def swap(f):
        f["episode_0"].attrs["id"], f["episode_2"].attrs["id"] = 2, 0

    _mutate(datasets, dataset_id, h5=swap)
    code, err, out = _import(capsys, tmp_path, dataset_id)
    assert code == 0, err
    episodes = read_run(out).episodes
    assert [(e.id, e.seed) for e in episodes] == [(0, 10), (1, 11), (2, 12)]
    assert [e.steps[-1].state["pos"] for e in episodes] == [2, 3, 2]  # episode_N's own data


def test_a_nan_observation_is_reported_at_its_episode_and_step(capsys, tmp_path, datasets):
    dataset_id = _box_dataset()

    def nan(f):
        f["episode_0/observations"][1] = np.nan

    _mutate(datasets, dataset_id, h5=nan)
    code, err, out = _import(capsys, tmp_path, dataset_id, env="tests.live.toy:Corridor")
    assert code == 2 and "t/toy/box-v0, episode 0, step 1: the observation holds NaN" in err
    assert ".part" not in err and not out.exists()


@pytest.mark.parametrize("dataset_id", ["../escape-v0", "/tmp/abs-v0", "", "x", "a//b-v0",
                                        "t/x-v0", "ns/../../up-v0", "ns/name"])
def test_a_malformed_dataset_id_is_refused_before_anything_is_written(capsys, tmp_path,
                                                                      datasets, dataset_id):
    """Minari itself makes the folders (outside MINARI_DATASETS_PATH for ../escape-v0)
    before it parses the id; ``x`` was a traceback, ``''`` 'a dataset with ID  exists'."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(cwd)
        code, _, err = run(capsys, "export", "minari", str(PAPER), "--dataset-id", dataset_id)
        assert code == 2 and f"{dataset_id!r} is not a Minari dataset id: write " \
            "(namespace/)name-vN" in " ".join(err.split()) and "Traceback" not in err
        code, _, err = run(capsys, "import", "minari", dataset_id, "--env", "highway", "-o",
                           str(tmp_path / "x.mcap"))
        assert code == 2 and "is not a Minari dataset id" in err
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["cwd"]  # nothing, anywhere


def test_an_unusable_datasets_folder_is_exit_2(capsys, tmp_path, monkeypatch):
    """Tests run as root: a folder under a regular file cannot be made by anyone."""
    plain = tmp_path / "plain"
    plain.write_text("x")
    for path, message in ((plain, "is a file, not a folder"),
                          (plain / "datasets", "cannot use the Minari datasets folder")):
        monkeypatch.setenv("MINARI_DATASETS_PATH", str(path))
        for args in (["export", "minari", str(PAPER), "--dataset-id", "t/h/x-v0"],
                     ["import", "minari", "t/h/x-v0", "--env", "highway", "-o",
                      str(tmp_path / "x.mcap")]):
            code, _, err = run(capsys, *args)
            assert code == 2 and message in err and "Traceback" not in err, err
    assert plain.read_text() == "x" and not (tmp_path / "x.mcap").exists()


def test_a_failed_export_leaves_no_half_written_dataset(capsys, tmp_path, datasets,
                                                        monkeypatch):
    """Written in a hidden folder and moved into place once complete: a failure midway
    leaves the datasets folder as it was (a namespace the user had stays)."""
    from minari.dataset._storages.hdf5_storage import HDF5Storage

    _toy_dataset("t/h/mine-v0")
    before = sorted(str(p.relative_to(datasets)) for p in datasets.rglob("*"))

    def fail(self, episodes):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(HDF5Storage, "update_episodes", fail)
    code, _, err = run(capsys, "export", "minari", str(PAPER), "--dataset-id", "t/h/new-v0")
    assert code == 2 and "cannot write the Minari dataset t/h/new-v0" in err
    assert "No space left on device" in err
    assert sorted(str(p.relative_to(datasets)) for p in datasets.rglob("*")) == before
    monkeypatch.undo()
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(datasets))
    assert run(capsys, "export", "minari", str(PAPER), "--dataset-id", "t/h/new-v0")[0] == 0
    assert {"t/h/mine-v0", "t/h/new-v0"} <= set(minari.list_local_datasets())


@pytest.mark.parametrize("name", ["data/metadata.json", "data/main_data.hdf5", "data/new.mcap",
                                  "."])
def test_an_import_never_writes_into_its_dataset(capsys, tmp_path, datasets, name):
    """The dataset's folder is the input of ``import minari``: ``-o`` inside it is refused,
    with or without --force, and the dataset stays as it was."""
    dataset_id = _toy_dataset()
    folder = datasets / dataset_id
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    target = folder / name
    for force in ([], ["--force"]):
        code, _, err = run(capsys, "import", "minari", dataset_id, "--env", TOY, "-o",
                           str(target), *force)
        err = " ".join(err.split())
        assert code == 2 and "Traceback" not in err, err
        assert f"is inside the input folder {folder}" in err or \
            f"is the input {folder}" in err, err
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before


@pytest.mark.parametrize("dataset, h5, message", [
    ("toy", lambda f: _replace(f, "episode_1/observations", np.array([100, 3, 3])),
     "t/toy/base-v0, episode 1, step 0: the observation 100 is not one of the dataset's "
     "Discrete(6) (0 … 5)"),
    ("toy", lambda f: _replace(f, "episode_2/observations", np.array([2, -1, 3])),
     "t/toy/base-v0, episode 2, step 1: the observation -1 is not one of"),
    ("toy", lambda f: _replace(f, "episode_0/observations", np.array([2.0, 3.0, 0.5])),
     "t/toy/base-v0, episode 0, step 2: the observation 0.5 is not an integer, as the "
     "dataset's Discrete(6) needs"),
    ("toy", lambda f: _replace(f, "episode_0/observations", np.array([[2], [3], [4]])),
     "t/toy/base-v0, episode 0: the observations have shape (3, 1), not (3,)"),
    ("box", lambda f: _replace(f, "episode_0/observations", np.array([[2.0], [7.5], [4.0]])),
     "t/toy/box-v0, episode 0, step 1: the observation 7.5 is out of the bounds of the "
     "dataset's Box(0.0, 5.0, (1,), float64)"),
], ids=["above", "negative", "fraction", "shape", "box-bounds"])
def test_an_observation_outside_the_observation_space_is_refused(capsys, tmp_path, datasets,
                                                                 dataset, h5, message):
    """0.5 of a Discrete(64) was cell 0, 100 an error of the adapter or a cell beyond the
    map: each is checked against the dataset's space before the adapter sees it."""
    dataset_id = _toy_dataset() if dataset == "toy" else _box_dataset()
    _mutate(datasets, dataset_id, h5=h5)
    code, err, out = _import(capsys, tmp_path, dataset_id)
    assert code == 2 and message in err and "Traceback" not in err, err
    assert not out.exists()


@pytest.fixture
def shielded(tmp_path, datasets, capsys):
    """The corridor recorded under its shield and exported: tracecheck's infos, 2 actions."""
    from tests.live.toy import SHIELD, left_leaning_table

    shield, agent = tmp_path / "corridor.mch", tmp_path / "left.npy"
    shield.write_text(SHIELD)
    np.save(agent, left_leaning_table())
    recorded = tmp_path / "toy.mcap"
    assert run(capsys, "record", "--env", TOY, "--agent", str(agent), "--shield", str(shield),
               "-n", "3", "--seed", "4", "-o", str(recorded))[0] == 0
    assert run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/toy/sh-v0",
               "--env", TOY)[0] == 0
    return "t/toy/sh-v0"


def _info(f, key, fn):
    path = f"episode_1/infos/{key}"
    _replace(f, path, fn(f[path][()]))


@pytest.mark.parametrize("h5, message", [
    (lambda f: _info(f, "allowed", lambda a: a[:2]), "t/toy/sh-v0, episode 1: its "
     "infos/allowed has shape (2, 2); tracecheck's infos have one row per observation"),
    (lambda f: _info(f, "allowed", lambda a: np.full(a.shape, 7)),
     "t/toy/sh-v0, episode 1: its infos/allowed holds int64 values, not true/false"),
    (lambda f: _info(f, "action_values", lambda a: a[:, :1]),
     "episode 1: its infos/action_values has shape"),
    (lambda f: _info(f, "preferred", lambda a: np.where(np.arange(len(a)) == 1, 9, a)),
     "t/toy/sh-v0, episode 1: its infos/preferred, step 1: 9 is not an action index (0 … 1) "
     "or -1"),
    (lambda f: _info(f, "intervened", lambda a: a[:1]), "episode 1: its infos/intervened has "
                                                        "shape (1,)"),
], ids=["allowed-short", "allowed-ints", "values-width", "preferred-range", "intervened-short"])
def test_malformed_shield_infos_are_refused_not_dropped(capsys, tmp_path, datasets, shielded,
                                                        h5, message):
    """They feed replay exactly: malformed, they were dropped without a word (the steps
    imported with no allowed actions, values or preferred action)."""
    assert _import(capsys, tmp_path, shielded)[0] == 0
    _mutate(datasets, shielded, h5=h5)
    code, err, out = _import(capsys, tmp_path / "again", shielded)
    assert code == 2 and message in err and "Traceback" not in err, err
    assert not out.exists()


@pytest.mark.parametrize("meta, h5, message", [
    (lambda m: m.update(total_steps=5), None,
     "t/toy/base-v0: the metadata field total_steps says 5, the episodes hold 6 step(s)"),
    (None, lambda f: f["episode_1"].attrs.__setitem__("total_steps", 7),
     "t/toy/base-v0, episode 1: its total_steps attribute says 7, it holds 2 step(s)"),
    (lambda m: m.update(total_episodes=2), None,
     "t/toy/base-v0: the metadata field total_episodes says 2, the data file holds 3 episode "
     "group(s) (episode_0 … episode_2)"),
], ids=["total-steps", "episode-steps", "fewer-episodes"])
def test_declared_counts_must_match_the_data(capsys, tmp_path, datasets, meta, h5, message):
    """total_episodes = 2 of 3 groups imported 2 without a word."""
    dataset_id = _toy_dataset()
    _mutate(datasets, dataset_id, meta=meta, h5=h5)
    code, err, out = _import(capsys, tmp_path, dataset_id)
    assert code == 2 and message in err and "Traceback" not in err, err
    assert not out.exists()


def test_exporting_with_another_environment_s_adapter_says_so(capsys, tmp_path, datasets):
    """It said "unknown setting 'duration' for the environment frozenlake … hint:
    --env-config key=value", an option export minari does not have."""
    code, _, err = run(capsys, "export", "minari", str(NONE), "--dataset-id", "tc/ff-v0",
                       "--env", "frozenlake")
    err = " ".join(err.split())
    assert code == 2 and f"{NONE} was recorded in highway, not frozenlake" in err, err
    assert "hint: give --env highway" in err and "--env-config" not in err
    assert not (datasets / "tc").exists()


def test_a_run_header_config_the_adapter_refuses_names_no_option_export_lacks(
        capsys, tmp_path, datasets):
    from tracecheck.episodes import EpisodeWriter

    recorded = tmp_path / "lake.mcap"
    assert run(capsys, "record", "--env", "frozenlake", "--agent",
               str(ROOT / "models" / "agents" / "frozenlake.npy"), "--shield", "none", "-n", "1",
               "-o", str(recorded))[0] == 0
    result = read_run(recorded)
    bad = tmp_path / "bad.mcap"
    with EpisodeWriter(bad, result.header.model_copy(
            update={"environment_config": {"nonsense": 1}})) as w:
        for e in result.episodes:
            w.write(e)
    code, _, err = run(capsys, "export", "minari", str(bad), "--dataset-id", "t/lake/b-v0")
    err = " ".join(err.split())
    assert code == 2 and f"{bad}: its environment_config does not fit frozenlake: unknown " \
        "setting 'nonsense'" in err and "--env-config" not in err, err


def _record(capsys, tmp_path, env: str, agent_table, name: str, n: int = 3):
    if agent_table is None:  # observations that are no index: an (untrained) PPO agent
        from stable_baselines3 import PPO

        from tests.live.toy import ByteCorridorEnv

        agent = tmp_path / f"{name}.zip"
        PPO("MlpPolicy", ByteCorridorEnv(), n_steps=8, batch_size=8, seed=0).save(agent)
    else:
        agent = tmp_path / f"{name}.npy"
        np.save(agent, agent_table)
    out = tmp_path / f"{name}.mcap"
    code, _, err = run(capsys, "record", "--env", env, "--agent", str(agent), "--shield", "none",
                       "-n", str(n), "-o", str(out))
    assert code == 0, err
    return out


def test_observations_that_do_not_fit_the_space_are_refused_not_written_as_zeros(capsys,
                                                                                  tmp_path):
    pytest.importorskip("stable_baselines3")
    recorded = _record(capsys, tmp_path, "tests.live.toy:ByteCorridor", None, "bytes")
    code, _, err = run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/b/b-v0",
                       "--env", "tests.live.toy:ByteCorridor")
    said = " ".join(err.split())
    assert code == 2 and f"{recorded}, episode 0, step 0: the observation's value" in said
    assert "is not a value of the environment's observation space Box(0, 255, (2,), uint8)" \
        in said and "floats in [0, 1] under a uint8 Box?" in said
    assert not minari.list_local_datasets()


def test_an_exported_dataset_imports_back_with_its_states_and_crashes(capsys, tmp_path):
    """The importer read states from an environment never reset (LunarLander failed, an
    adapter reading the environment got the wrong states) and took every termination for a
    crash (a goal reached came back crashed)."""
    from tests.live.toy import left_leaning_table

    table = left_leaning_table()
    table[3:, :] = (0.0, 1.0)  # from cell 3 on it walks right, to the goal
    image = "tests.live.toy:HiddenCorridor"
    recorded = _record(capsys, tmp_path, image, table, "hidden", n=8)
    original = read_run(recorded).episodes
    assert {e.end.reason for e in original} == {"crashed", "end-of-trace"}
    code, _, err = run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/i/i-v0",
                       "--env", image)
    assert code == 0, err
    back = tmp_path / "back.mcap"
    code, _, err = run(capsys, "import", "minari", "t/i/i-v0", "--env", image, "-o", str(back))
    assert code == 0, err
    again = read_run(back).episodes
    assert [[s.state for s in e.steps] for e in again] == \
        [[s.state for s in e.steps] for e in original]
    assert [e.end.reason for e in again] == [e.end.reason for e in original]


def test_a_wrapper_minari_cannot_make_again_is_refused_with_what_to_do(capsys, tmp_path):
    from tests.live.toy import left_leaning_table

    wrapped = "tests.live.toy:WrappedCorridor"
    recorded = _record(capsys, tmp_path, wrapped, left_leaning_table(), "wrapped")
    code, _, err = run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/w/w-v0",
                       "--env", wrapped)
    said = " ".join(err.split())
    assert code == 2 and "the environment is wrapped in _PlainWrapper, which does not record " \
                         "its arguments" in said
    assert "inherit gymnasium.utils.RecordConstructorArgs" in said and "Traceback" not in err


def test_a_foreign_dataset_s_states_are_converted_by_the_environment_s_shield(capsys,
                                                                               tmp_path):
    """The adapter's str elements and numpy map become B values on import as on record."""
    from tests.live.toy import LAVA_SHIELD, LavaCorridor
    from tracecheck.b.values import Elem, FuncValue

    shield = tmp_path / "lava.mch"
    shield.write_text(LAVA_SHIELD)
    dataset = _toy_dataset("t/toy/lava-v0")
    LavaCorridor.default_shield = str(shield)
    try:
        out = tmp_path / "lava.mcap"
        code, _, err = run(capsys, "import", "minari", dataset, "--env",
                           "tests.live.toy:LavaCorridor", "-o", str(out))
    finally:
        del LavaCorridor.default_shield
    assert code == 0, err
    state = read_run(out).episodes[0].steps[0].state
    assert type(state["ahead"]) is Elem and type(state["cells"]) is FuncValue
    code, out_text, err = run(capsys, "replay", str(out), "--shield", str(shield), "--json")
    assert code == 0, err


def test_spaces_that_do_not_start_at_0_go_both_ways(capsys, tmp_path):
    """Discrete(2, start=-1) actions and Discrete(6, start=10) observations: the dataset
    holds the actions and observations as the environment takes and gives them (-1, 0;
    10 … 15), and reads back to the same action names."""
    env = "tests.live.toy:OffsetCorridor"
    table, recorded, back = tmp_path / "q.npy", tmp_path / "off.mcap", tmp_path / "back.mcap"
    np.save(table, np.array([[1.0, 0.0]] * 3 + [[0.0, 1.0]] * 3))  # Right from cell 3 on
    assert run(capsys, "record", "--env", env, "--agent", str(table), "-n", "4", "-o",
               str(recorded))[0] == 0
    assert run(capsys, "export", "minari", str(recorded), "--dataset-id", "t/off/x-v0",
               "--env", env)[0] == 0
    run_ = read_run(recorded)
    dataset = minari.load_dataset("t/off/x-v0")
    assert dataset.action_space.start == -1
    for ep, data in zip(run_.episodes, dataset.iterate_episodes()):
        assert data.actions.tolist() == [{"Left": -1, "Right": 0}[s.action]
                                         for s in ep.steps[1:]]
        assert data.observations.tolist() == [10 + s.state["pos"] for s in ep.steps]
    assert run(capsys, "import", "minari", "t/off/x-v0", "--env", env, "-o", str(back))[0] == 0
    assert [[s.action for s in ep.steps] for ep in read_run(back).episodes] == \
        [[s.action for s in ep.steps] for ep in run_.episodes]
