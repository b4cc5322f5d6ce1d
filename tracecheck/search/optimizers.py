"""The optimisers a search asks for points (``--optimizer``), all from established
libraries behind one ask/tell interface over the unit cube [0, 1]^d (:mod:`.space` maps a
point to parameters); lower objective values are better (closer to a violation).

* ``random``: uniform sampling (numpy's PCG64 generator) — the baseline;
* ``halton``: a scrambled Halton low-discrepancy sequence (``scipy.stats.qmc``);
* ``cmaes``: CMA-ES (the ``cma`` package, pycma), bounded to the cube;
* ``tpe``: the tree-structured Parzen estimator (optuna's ``TPESampler``);
* ``gp``: Gaussian-process Bayesian optimisation (optuna's ``GPSampler``, with PyTorch).

Others are added as an entry point of the group ``tracecheck.optimizers``: a class taking
``(dimensions: int, seed: int)`` with ``ask() -> list[float]`` and ``tell(point,
value)``. Each is seeded from the search's seed, so a search reproduces.
"""

from __future__ import annotations

import math
from typing import Callable, Protocol, Sequence

import numpy as np

from ..errors import InputError

__all__ = ["Optimizer", "make_optimizer", "OPTIMIZERS", "ENTRY_POINT_GROUP"]

ENTRY_POINT_GROUP = "tracecheck.optimizers"


class Optimizer(Protocol):
    """Asked for points of the unit cube one at a time; told each one's value."""

    def ask(self) -> list[float]: ...

    def tell(self, point: Sequence[float], value: float) -> None: ...


class UniformRandom:
    """Points drawn uniformly at random."""

    def __init__(self, dimensions: int, seed: int) -> None:
        self._rng = np.random.default_rng(seed)
        self._d = dimensions

    def ask(self) -> list[float]:
        return [float(x) for x in self._rng.random(self._d)]

    def tell(self, point: Sequence[float], value: float) -> None:
        pass


class Halton:
    """A scrambled Halton sequence: low discrepancy, no feedback."""

    def __init__(self, dimensions: int, seed: int) -> None:
        from scipy.stats import qmc

        self._engine = qmc.Halton(d=dimensions, scramble=True, seed=seed)

    def ask(self) -> list[float]:
        return [float(x) for x in self._engine.random(1)[0]]

    def tell(self, point: Sequence[float], value: float) -> None:
        pass


class Told:
    """The value an optimiser is told for an objective value: itself where finite; an
    infinite one (an STL robustness over an empty window) kept on its side of every finite
    value told so far — one below the lowest (-inf: a violation beyond any), one above the
    highest (+inf) — so that the order holds and no model sees an infinity or 1e300."""

    def __init__(self) -> None:
        self.low, self.high = math.inf, -math.inf

    def __call__(self, value: float) -> float:
        if math.isfinite(value):
            self.low, self.high = min(self.low, value), max(self.high, value)
            return float(value)
        if math.isnan(value):
            return self.high + 1.0 if math.isfinite(self.high) else 1.0
        if value < 0:
            return self.low - 1.0 if math.isfinite(self.low) else -1.0
        return self.high + 1.0 if math.isfinite(self.high) else 1.0


class CMAES:
    """pycma's CMA-ES in the unit cube, started at its centre with step size 0.3: a
    generation is asked one point at a time and told once all of its values are in. pycma
    keeps points inside the cube itself in two or more dimensions; in one (where its bound
    handling does not work) a point outside is evaluated at the nearest end of [0, 1] and
    told with its distance from it added, which keeps the search inside."""

    def __init__(self, dimensions: int, seed: int) -> None:
        cma = _need("cma", "cmaes")
        self._bounded = dimensions >= 2
        options = {"seed": seed + 1, "verbose": -9}
        if self._bounded:
            options["bounds"] = [0.0, 1.0]
        self._es = cma.CMAEvolutionStrategy([0.5] * dimensions, 0.3, options)
        self._generation: list = []  # [raw point, point asked, value or None]
        self._next = 0
        self._told = Told()

    def ask(self) -> list[float]:
        if self._next == len(self._generation):
            self._generation = [[x, [float(v) for v in np.clip(x, 0.0, 1.0)], None]
                                for x in self._es.ask()]
            self._next = 0
        self._next += 1
        return list(self._generation[self._next - 1][1])

    def tell(self, point: Sequence[float], value: float) -> None:
        asked = [float(x) for x in point]
        entry = next(e for e in self._generation if e[1] == asked and e[2] is None)
        outside = float(np.abs(np.asarray(entry[0]) - np.asarray(asked)).sum())
        entry[2] = self._told(value) + (0.0 if self._bounded else outside)
        if all(e[2] is not None for e in self._generation):
            self._es.tell([e[0] for e in self._generation], [e[2] for e in self._generation])
            self._next = len(self._generation)  # the next ask starts a generation


class _OptunaStudy:
    """An optuna sampler through optuna's ask-and-tell interface."""

    name = ""

    def __init__(self, dimensions: int, seed: int) -> None:
        optuna = _need("optuna", self.name)
        optuna.logging.set_verbosity(optuna.logging.ERROR)
        self._study = optuna.create_study(direction="minimize",
                                          sampler=self.sampler(optuna, seed))
        self._space = {f"u{k}": optuna.distributions.FloatDistribution(0.0, 1.0)
                       for k in range(dimensions)}
        self._trials: dict = {}
        self._told = Told()

    def sampler(self, optuna, seed: int):
        raise NotImplementedError

    def ask(self) -> list[float]:
        trial = self._study.ask(self._space)
        point = [float(trial.params[f"u{k}"]) for k in range(len(self._space))]
        self._trials[tuple(point)] = trial
        return point

    def tell(self, point: Sequence[float], value: float) -> None:
        trial = self._trials.pop(tuple(float(x) for x in point))
        self._study.tell(trial, self._told(value))


class TPE(_OptunaStudy):
    """optuna's tree-structured Parzen estimator."""

    name = "tpe"

    def sampler(self, optuna, seed: int):
        return optuna.samplers.TPESampler(seed=seed)


class GP(_OptunaStudy):
    """optuna's Gaussian-process Bayesian optimisation (``GPSampler``: a Matérn-5/2 process
    fitted to the values so far, the next point where its expected improvement is largest;
    it needs PyTorch). Each point costs a fit that grows with the values told: it suits the
    budgets of slow episodes (hundreds), where a fit is cheaper than an episode."""

    name = "gp"

    def sampler(self, optuna, seed: int):
        _need("torch", "gp", hint="pip install 'tracecheck[agents]' (PyTorch, with the "
                                  "agents)")
        return optuna.samplers.GPSampler(seed=seed)


#: the built-in optimisers by ``--optimizer`` name
OPTIMIZERS: dict[str, Callable[[int, int], Optimizer]] = {
    "random": UniformRandom, "halton": Halton, "cmaes": CMAES, "tpe": TPE, "gp": GP}


def _need(module: str, name: str, hint: str = ""):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"--optimizer {name} needs the {module} package, which is not "
                         "installed", hint=hint or "pip install 'tracecheck[falsify]' (or pip "
                                                   f"install {module})") from None


def make_optimizer(name: str, dimensions: int, seed: int) -> Optimizer:
    """The optimiser ``name`` (built in, or an installed entry point) for a space of
    ``dimensions``, seeded with ``seed``."""
    from importlib.metadata import entry_points

    factory = OPTIMIZERS.get(name)
    if factory is None:
        found = [e for e in entry_points(group=ENTRY_POINT_GROUP) if e.name == name]
        if not found:
            names = sorted({*OPTIMIZERS, *(e.name for e in entry_points(
                group=ENTRY_POINT_GROUP))})
            raise InputError(f"unknown optimizer {name!r}; the optimizers are "
                             f"{', '.join(names)}",
                             hint="--optimizer random|halton|cmaes|tpe|gp, or install a "
                                  f"package that adds one to the entry points {ENTRY_POINT_GROUP}")
        factory = found[0].load()
    return factory(dimensions, seed)
