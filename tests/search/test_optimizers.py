"""The optimisers behind one ask/tell interface (tracecheck.search.optimizers): points in the
unit cube, reproducible from the seed, and the guided ones do better than random on a
smooth problem."""

from __future__ import annotations

import pytest

from tracecheck.errors import InputError
from tracecheck.search.optimizers import OPTIMIZERS, make_optimizer


def _run(name: str, d: int, seed: int, n: int, f) -> list[float]:
    opt = make_optimizer(name, d, seed)
    values = []
    for _ in range(n):
        point = opt.ask()
        assert len(point) == d and all(0.0 <= x <= 1.0 for x in point)
        values.append(f(point))
        opt.tell(point, values[-1])
    return values


@pytest.mark.parametrize("name", sorted(OPTIMIZERS))
@pytest.mark.parametrize("d", [1, 3])
def test_points_stay_in_the_cube_and_a_seed_reproduces_them(name, d):
    def f(p):
        return sum((x - 0.3) ** 2 for x in p)
    assert _run(name, d, 7, 30, f) == _run(name, d, 7, 30, f)


@pytest.mark.parametrize("name", ["cmaes", "tpe", "gp"])
def test_guided_optimizers_get_closer_than_random_on_a_bowl(name):
    def f(p):
        return sum((x - 0.3) ** 2 for x in p)
    best = [min(_run(name, 2, s, 60, f)) for s in range(5)]
    rand = [min(_run("random", 2, s, 60, f)) for s in range(5)]
    assert sorted(best)[2] < sorted(rand)[2]  # medians over 5 seeds


def test_an_unknown_optimizer_is_named_with_the_known_ones():
    with pytest.raises(InputError, match="unknown optimizer 'anneal'; the optimizers are "
                                         "cmaes, gp, halton, random, tpe"):
        make_optimizer("anneal", 2, 0)


def test_a_missing_package_says_how_to_install_it(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "torch", None)  # import torch: ModuleNotFoundError
    with pytest.raises(InputError, match="--optimizer gp needs the torch package") as info:
        make_optimizer("gp", 2, 0)
    assert "tracecheck[agents]" in info.value.hint


def test_infinite_values_are_told_on_their_side_of_every_finite_one():
    from tracecheck.search.optimizers import Told

    told = Told()
    assert told(float("-inf")) == -1.0 and told(float("inf")) == 1.0
    assert [told(v) for v in (0.5, -2.0, 3.0)] == [0.5, -2.0, 3.0]
    assert told(float("-inf")) == -3.0 and told(float("inf")) == 4.0
