"""Malformed Minari datasets, at random: a small valid dataset (a toy recording exported by
tracecheck, infos included) mutated field by field — metadata, episode attributes, arrays:
wrong types, huge sizes, NaN, missing keys, strings for numbers — and imported. Every input
gives exit 2 with ``error:``, or exit 0 with a run that says exactly what the dataset says
(read independently with h5py); never another exception, never a traceback."""

from __future__ import annotations

import itertools
import json
import os
import shutil

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.helpers import run
from tests.live.toy import left_leaning_table
from tracecheck.episodes.reader import read_run

minari = pytest.importorskip("minari")
h5py = pytest.importorskip("h5py")

TOY = "tests.live.toy:Corridor"
ACTIONS = ("Left", "Right")
BASE = "t/fz/base-v0"
META_KEYS = ("total_episodes", "total_steps", "dataset_id", "observation_space", "action_space",
             "env_spec", "data_format", "minari_version", "jpeg_encoding", "author",
             "tracecheck")
ARRAYS = ("observations", "actions", "rewards", "terminations", "truncations",
          "infos/allowed", "infos/preferred", "infos/action_values", "infos/deadlock")
ATTRS = ("seed", "id", "total_steps")


@pytest.fixture(scope="module")
def fuzz(tmp_path_factory):
    """(datasets folder, ids) with the base dataset exported there."""
    root = tmp_path_factory.mktemp("fuzz")
    agent = root / "left.npy"
    np.save(agent, left_leaning_table())
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root / "datasets")
    try:
        from tracecheck.cli import main

        for args in (["record", "--env", TOY, "--agent", str(agent), "--shield", "none", "-n",
                      "3", "--seed", "4", "-o", str(root / "toy.mcap")],
                     ["export", "minari", str(root / "toy.mcap"), "--dataset-id", BASE,
                      "--env", TOY]):
            with pytest.raises(SystemExit) as info:
                main(args)
            assert not info.value.code
        yield root, itertools.count()
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = old


values = st.one_of(
    st.none(), st.booleans(), st.integers(-2**70, 2**70), st.sampled_from([0, -1, 10**12]),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
    st.sampled_from(["abc", "1.5", "", '{"type": "Box"}', "[1, 2]"]),
    st.lists(st.integers(-5, 5), max_size=3))
arrays = st.one_of(
    st.sampled_from(["delete", "strings", "nan", "huge", "scalar", "shorter", "longer",
                     "floats", "negative", "group"]))
mutations = st.one_of(
    st.tuples(st.just("meta"), st.sampled_from(META_KEYS), st.one_of(st.just("delete"), values)),
    st.tuples(st.just("attr"), st.tuples(st.integers(0, 2), st.sampled_from(ATTRS)),
              st.one_of(st.just("delete"), values)),
    st.tuples(st.just("array"), st.tuples(st.integers(0, 2), st.sampled_from(ARRAYS)), arrays))


def _array(f, path, how):
    old = f.get(path)
    if old is None:
        return
    data = old[()] if isinstance(old, h5py.Dataset) else None
    del f[path]
    if how == "delete":
        return
    if how == "group":
        f.create_group(path)
        return
    if how == "huge":
        f.create_dataset(path, shape=(10**11,), chunks=True, dtype="f8")
        return
    if data is None:
        return
    data = np.asarray(data)
    made = {"strings": lambda: np.array([b"x"] * len(data)),
            "nan": lambda: np.full(data.shape, np.nan),
            "scalar": lambda: np.float64(1.0),
            "shorter": lambda: data[:-1],
            "longer": lambda: np.concatenate([data, data[-1:]]),
            "floats": lambda: data.astype(np.float64) + 0.5,
            "negative": lambda: -np.abs(data.astype(np.int64)) - 1}
    with np.errstate(invalid="ignore"):  # a float array with NaN made integers: damage meant
        made = made[how]()
    f.create_dataset(path, data=made)


def _mutate(data_dir, mutation):
    kind, where, value = mutation
    if kind == "meta":
        meta = json.loads((data_dir / "metadata.json").read_text())
        if value == "delete":
            meta.pop(where, None)
        else:
            meta[where] = value
        (data_dir / "metadata.json").write_text(json.dumps(meta))
        return
    with h5py.File(data_dir / "main_data.hdf5", "a") as f:
        episode, name = where
        group = f[f"episode_{episode}"]
        if kind == "attr":
            if value == "delete":
                group.attrs.pop(name, None)
            elif value is not None and not (isinstance(value, int) and abs(value) >= 2**64):
                try:
                    group.attrs[name] = value if not isinstance(value, list) else np.array(value)
                except (TypeError, ValueError):  # not storable in HDF5 (a NUL in a string)
                    pass
        else:
            _array(group, name, value)


def _what_the_dataset_says(data_dir, dataset_id):
    """Per episode (seed, actions, rewards, positions), read with h5py and Minari alone."""
    dataset = minari.load_dataset(dataset_id)
    with h5py.File(data_dir / "main_data.hdf5", "r") as f:
        seeds = [f[f"episode_{i}"].attrs.get("seed") for i in range(dataset.total_episodes)]
    out = []
    for seed, data in zip(seeds, dataset.iterate_episodes()):
        assert seed is None or (isinstance(seed, np.integer) and 0 <= seed < 2**63)
        out.append((None if seed is None else int(seed),
                    [ACTIONS[int(a)] for a in data.actions],
                    [float(r) for r in data.rewards], [int(o) for o in data.observations]))
    return out


@settings(max_examples=int(os.environ.get("TRACECHECK_FUZZ_EXAMPLES", 60)), deadline=None,
          suppress_health_check=list(HealthCheck))
@given(mutation=mutations)
def test_a_mutated_dataset_imports_exactly_or_is_refused(fuzz, capsys, mutation):
    root, counter = fuzz
    datasets = root / "datasets"
    dataset_id = f"t/fz/case{next(counter)}-v0"
    shutil.copytree(datasets / BASE, datasets / dataset_id)
    _mutate(datasets / dataset_id / "data", mutation)
    out = root / f"{dataset_id.replace('/', '_')}.mcap"
    code, _, err = run(capsys, "import", "minari", dataset_id, "--env", TOY, "-o", str(out))
    assert "Traceback" not in err
    if code == 2:
        assert err.startswith("error: ") and not out.exists(), err
        return
    assert code == 0, (mutation, err)
    said = _what_the_dataset_says(datasets / dataset_id / "data", dataset_id)
    got = [(e.seed, [s.action for s in e.steps[1:]], [s.reward for s in e.steps[1:]],
            [s.state["pos"] for s in e.steps]) for e in read_run(out).episodes]
    assert got == said, mutation


def test_the_intact_dataset_imports_as_recorded(fuzz, capsys):
    root, _ = fuzz
    out = root / "intact.mcap"
    assert run(capsys, "import", "minari", BASE, "--env", TOY, "-o", str(out))[0] == 0
    recorded = read_run(root / "toy.mcap").episodes
    imported = read_run(out).episodes
    assert [e.seed for e in imported] == [e.seed for e in recorded] == [4, 5, 6]
    assert [[s.state for s in e.steps] for e in imported] == \
        [[s.state for s in e.steps] for e in recorded]
