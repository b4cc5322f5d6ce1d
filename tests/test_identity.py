"""Results remembered for the very same object (tracecheck.identity)."""

import gc
import weakref

import pytest

from tracecheck.identity import ByIdentity


class _Shape:
    """A stand-in for a drawn shape (weakly referable, compared by identity)."""


def test_an_object_asked_for_again_stays_while_objects_met_once_come_and_go():
    seen = ByIdentity(4096)
    tile = _Shape()
    seen.put(tile, "tile")
    assert seen.get(tile) == "tile"  # asked again: kept with those asked again
    met_once = []
    for k in range(10 * ByIdentity.FIRST):
        shape = _Shape()
        met_once.append(weakref.ref(shape))
        assert seen.put(shape, k) == k
        del shape
    gc.collect()
    alive = sum(ref() is not None for ref in met_once)
    assert alive <= ByIdentity.FIRST  # a highway's vehicles: few held alive
    assert seen.get(tile) == "tile"


def test_an_equal_object_is_another_and_a_full_cache_forgets():
    seen = ByIdentity(2)
    a, b, c = frozenset({1}), frozenset({2}), frozenset({3})
    for key in (a, b, c):
        seen.put(key, str(key))
        assert seen.get(key) == str(key)
    assert seen.get(frozenset({3})) is None
    assert seen.get(a) is None  # the third asked again forgot the two before
    assert seen.get(c) == str(c)
    with pytest.raises(ValueError):
        ByIdentity(0)
