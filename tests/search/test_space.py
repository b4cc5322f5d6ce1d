"""The search space (tracecheck.search.space): --param texts, the unit cube mapped onto
ranges and choices, and every range tried on the environment before any episode."""

from __future__ import annotations

import pytest

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
    with pytest.raises(InputError, match="unknown setting 'density'"):
        check_space(["density=0.5..2.0"], adapter)
    with pytest.raises(InputError, match="is_slippery does not take numbers"):
        check_space(["is_slippery=0..1"], adapter)
    with pytest.raises(InputError, match="given twice"):
        check_space(["seed=0..9", "seed=1..2"], adapter)
    with pytest.raises(InputError, match="give what the search varies"):
        check_space([], adapter)
