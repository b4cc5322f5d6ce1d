"""The grid worlds' maps: one object for the same map, episode after episode, and a new one
for another map."""

from __future__ import annotations

import numpy as np

from tracecheck.live.adapter import get_adapter

ADAPTER = "frozenlake"


def test_the_same_map_is_the_same_object_in_every_episode(adapter):
    """Issue 46: what is remembered for a map (its text in the file, its tiles drawn and
    encoded for Foxglove) holds in every episode only if the next episode's equal map is the
    same object; a map that differs is built again, even of the same size."""
    env = adapter.make_env(adapter.config({"is_slippery": True}))
    first = adapter.grid_map(env.unwrapped)
    env.reset(seed=1)
    again = adapter.grid_map(env.unwrapped)
    assert again is first
    other = adapter.make_env(adapter.config({"is_slippery": True, "map_name": "4x4"}))
    small = adapter.grid_map(other.unwrapped)
    assert small is not first and small[0] == 4 and first[0] == 8
    desc = env.unwrapped.desc.copy()
    desc[1, 1] = b"H" if desc[1, 1] != b"H" else b"F"
    env.unwrapped.desc = desc  # the same size, one tile changed
    changed = adapter.grid_map(env.unwrapped)
    assert changed is not first and changed[1] != first[1]
    assert (1, 1) in {k for k in first[1].map if first[1].map[k] != changed[1].map[k]}


def test_a_map_of_python_objects_is_built_again_each_time():
    """A map held as Python objects (an ``object`` array) is not known by its bytes (those
    are pointers): it is built again, never taken for the last one."""
    lake = get_adapter("frozenlake")
    env = lake.make_env(lake.config({"is_slippery": True, "map_name": "4x4"}))
    env.unwrapped.desc = np.array(env.unwrapped.desc.tolist(), dtype=object)
    one, two = lake.grid_map(env.unwrapped), lake.grid_map(env.unwrapped)
    assert one is not two and one == two
