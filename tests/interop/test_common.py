"""Finding trace files: natural order, a compact listing of large folders."""

from __future__ import annotations

import re

import pytest
from hypothesis import given, strategies as st

from tracecheck.errors import InputError
from tracecheck.interop.common import FoundFiles, expand_paths, natural_key


def by_parts(name: str) -> list:
    """The order natural_key stands for: text runs as text, digit runs by value."""
    return [int(t) if k % 2 else t for k, t in enumerate(re.split(r"(\d+)", name))]


_NAMES = st.text(alphabet="ab_.0123456789٣é", max_size=12)


@given(st.lists(_NAMES, min_size=2, max_size=8))
def test_natural_key_orders_as_the_parts_do(names):
    keys = [natural_key(n) for n in names]
    for a, ka in zip(names, keys):
        for b, kb in zip(names, keys):
            assert (ka < kb) == (by_parts(a) < by_parts(b)), (a, b)
            assert (ka == kb) == (by_parts(a) == by_parts(b)), (a, b)


def test_natural_order_of_a_folder(tmp_path):
    """``1²2``: a superscript two is a digit to ``str.isdigit`` but not to ``int``; the key
    of lists of parts raised a ValueError on it."""
    for name in ["Timed_Simulation_10.json", "Timed_Simulation_9.json",
                 "Timed_Simulation_09.json", "Timed_Simulation_100.json", "notes.txt",
                 "Timed_Simulation_².json", "Timed_Simulation_1²2.json"]:
        (tmp_path / name).write_text("{}")
    found = expand_paths([tmp_path], "*.json")
    assert [p.name for p in found] == [
        "Timed_Simulation_1²2.json", "Timed_Simulation_09.json", "Timed_Simulation_9.json",
        "Timed_Simulation_10.json", "Timed_Simulation_100.json", "Timed_Simulation_².json"]


def test_found_files_behave_as_a_list(tmp_path):
    (tmp_path / "t").mkdir()
    for k in range(3):
        (tmp_path / "t" / f"x{k}.json").write_text("{}")
    single = tmp_path / "one.json"
    single.write_text("{}")
    found = expand_paths([tmp_path / "t", single], "*.json")
    assert isinstance(found, FoundFiles)
    listed = [tmp_path / "t" / f"x{k}.json" for k in range(3)] + [single]
    assert list(found) == listed and len(found) == 4
    assert [found[k] for k in range(4)] == listed and found[-1] == single
    assert found[1:3] == listed[1:3] and found[:10] == listed
    with pytest.raises(IndexError):
        found[4]


def test_folders_without_files_and_missing_paths(tmp_path):
    with pytest.raises(InputError, match="holds no \\*.json files"):
        expand_paths([tmp_path], "*.json")
    with pytest.raises(InputError, match="no such file or folder"):
        expand_paths([tmp_path / "gone"], "*.json")
