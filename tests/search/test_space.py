"""The search space (tracecheck.search.space): --param texts, the unit cube mapped onto
ranges and choices, and every range tried on the environment before any episode."""

from __future__ import annotations

import pytest

from tests.helpers import ROOT
from tracecheck.errors import InputError
from tracecheck.live.adapter import load_adapter
from tracecheck.search.space import Dimension, Space, check_space, parse_param


@pytest.mark.parametrize("text,dim", [
    ("seed=0..999", Dimension("seed", 0, 999, integer=True)),
    ("density=0.5..2.0", Dimension("density", 0.5, 2.0)),
    ("lanes=2..4", Dimension("lanes", 2, 4)),
    ("slippery={True,False}", Dimension("slippery", choices=(True, False))),
    ("mode={a, b, 3}", Dimension("mode", choices=("a", "b", 3))),
])
def test_params_are_read(text, dim):
    assert parse_param(text) == dim


def test_a_setting_that_takes_integers_only_is_searched_in_integers():
    assert parse_param("lanes=2..4", frozenset({"int"})).integer
    assert not parse_param("lanes=2..4", frozenset({"int", "float"})).integer


@pytest.mark.parametrize("text,message", [
    ("seed", "write NAME=LO..HI"),
    ("=1..2", "write NAME=LO..HI"),
    ("x=2..1", "from a lower to a higher"),
    ("x=a..b", "no range LO..HI"),
    ("seed=0.5..3", "seed takes whole numbers"),
    ("seed=-1..3", "a seed is 0"),
    ("x={}", "no choices"),
    ("x={a,a}", "listed twice"),
])
def test_bad_params_say_what_to_write(text, message):
    with pytest.raises(InputError, match=message):
        parse_param(text)


def test_the_unit_cube_maps_onto_every_value():
    seed = Dimension("seed", 0, 3, integer=True)
    assert [seed.value(u) for u in (0.0, 0.24, 0.25, 0.99, 1.0)] == [0, 0, 1, 3, 3]
    choice = Dimension("c", choices=("a", "b"))
    assert [choice.value(u) for u in (0.0, 0.49, 0.5, 1.0)] == ["a", "a", "b", "b"]
    space = Space((seed, Dimension("d", 1.0, 2.0)))
    assert space.point([1.0, 0.5]) == {"seed": 3, "d": 1.5}
    assert space.describe() == {"seed": [0, 3], "d": [1.0, 2.0]}


def test_ranges_are_tried_on_the_environment_before_any_episode():
    adapter = load_adapter("frozenlake")
    space = check_space(["seed=0..99", "is_slippery={True,False}"], adapter)
    assert [d.name for d in space.dimensions] == ["seed", "is_slippery"]
    with pytest.raises(InputError, match="no setting nor reset parameter 'density'"):
        check_space(["density=0.5..2.0"], adapter)
    with pytest.raises(InputError, match="is_slippery does not take numbers"):
        check_space(["is_slippery=0..1"], adapter)
    with pytest.raises(InputError, match="given twice"):
        check_space(["seed=0..9", "seed=1..2"], adapter)
    with pytest.raises(InputError, match="give what the search varies"):
        check_space([], adapter)


def test_a_setting_whose_default_is_a_whole_number_is_searched_in_whole_numbers():
    assert parse_param("lanes=2..4", frozenset({"int", "float"}), 3).integer
    assert not parse_param("density=1..2", frozenset({"int", "float"}), 1.5).integer
    with pytest.raises(InputError, match="lanes takes whole numbers"):
        parse_param("lanes=2.5..4", frozenset({"int", "float"}), 3)
    adapter = load_adapter("tests.search.corridor:Corridor")
    (dim,) = check_space(["start=0..3"], adapter).dimensions
    assert dim.integer and [dim.value(u) for u in (0.0, 0.3, 0.99)] == [0, 1, 3]


def test_three_dots_are_no_range():
    with pytest.raises(InputError, match="no range LO..HI"):
        parse_param("seed=0...10")


def test_the_agent_and_shield_are_checked_at_every_choice():
    from tracecheck.live.agents import load_agent

    adapter = load_adapter("frozenlake")
    agent = str(ROOT / "models" / "agents" / "frozenlake.npy")
    with pytest.raises(InputError, match=r"--param map_name=\{4x4,8x8\}: at map_name='4x4': "
                                         r".*the Q-table has 64 rows; the environment has "
                                         "16 observations"):
        check_space(["map_name={4x4,8x8}"], adapter,
                    check=lambda env: load_agent(agent, adapter=adapter, env=env))
