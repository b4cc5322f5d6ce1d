"""Statistical validation over recorded or imported episodes (SimB parity and beyond).

Per run: each metric aggregated per episode, then mean ± sample sd with a 95 % t interval;
the share of episodes satisfying each property with a 95 % interval (Wilson, or
Clopper–Pearson on request); SimB's hypothesis tests (normal approximation) with the exact
binomial p-value beside them; SimB's estimation check (mean within value ± ε). Two runs whose
episodes share seeds (the same scenarios, say with and without a shield) are compared pair by
pair: exact McNemar for properties, paired t and Wilcoxon signed-rank for metrics.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from ..b.typecheck import typecheck_formula
from ..b.vector import BatchFormula
from ..episodes.columns import RunColumns, read_columns
from ..errors import InputError, TracecheckError
from .properties import Metric, Property, PropertySet

__all__ = ["RunValues", "StatsResult", "evaluate_run", "statistics", "INTERVALS"]

INTERVALS = {"wilson": "wilson", "clopper-pearson": "exact"}


@dataclass
class RunValues:
    """Per-episode values of every metric and property in one run."""

    name: str
    file: str
    episodes: int
    seeds: list[Optional[int]]
    metrics: dict[str, np.ndarray] = field(default_factory=dict)
    properties: dict[str, np.ndarray] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def environment_of(path: str | Path) -> str:
    """The environment a run file's states come from (files without one: the highway)."""
    from ..episodes.reader import read_header

    return read_header(path).environment or "highway"


def _typing_scope(environment="highway", sample: Optional[dict] = None):
    """The names and constants properties are checked against: those of the environment's
    machine (the shield its adapter names), else the types of a sample state's values."""
    from ..live.adapter import EnvAdapter, get_adapter
    from ..checking.shield import load_shield

    adapter = environment if isinstance(environment, EnvAdapter) else None
    if adapter is None:
        try:
            adapter = get_adapter(environment)
        except InputError:
            if sample is None:
                raise
    if adapter is not None and adapter.default_shield is not None:
        machine = load_shield(adapter.default_shield).machine
        return machine.type_objects, dict(machine.base_env), machine.variables
    if sample is None:
        raise InputError(f"the environment {environment} names no machine to type-check "
                         "properties against")
    from ..b.typecheck import type_of_value

    return ({k: type_of_value(v) for k, v in sample.items()}, {}, tuple(sample))


def _check(node, kind: str, where: str, text: str, names, variables) -> None:
    try:
        typecheck_formula(node, names, kind=kind, source=text, file=where,
                          unknown_hint=f"the state variables are {', '.join(variables)}")
    except TracecheckError as exc:
        raise exc.located(file=where, source=text) from None


def default_properties(paths: list[str | Path]) -> str:
    """The property set of the runs' environment (the highway's when it has none)."""
    from ..live.adapter import get_adapter

    environment = environment_of(paths[0]) if paths else "highway"
    return get_adapter(environment).properties or "highway"


def prepare(pset: PropertySet, environment="highway", sample: Optional[dict] = None) -> dict:
    """Type-check every formula of ``pset`` against the environment's machine (a name or an
    adapter; ``sample``: a state to take types from where there is no machine) and prepare
    it for batch evaluation."""
    names, constants, variables = _typing_scope(environment, sample)
    formulas = {}
    for m in pset.metrics:
        if m.aggregate == "stl":
            formulas[("m", m.name)] = _Temporal("stl", m.expression, _machine(environment),
                                                f"{pset.where}: metric {m.name}")
            continue
        if m.node is not None:
            _check(m.node, "expression", f"{pset.where}: metric {m.name}", m.expression, names,
                   variables)
            formulas[("m", m.name)] = BatchFormula(m.node, constants, source=m.expression)
    for p in pset.properties:
        if p.kind in ("ltl", "stl"):
            formulas[("p", p.name)] = _Temporal(p.kind, p.predicate, _machine(environment),
                                                f"{pset.where}: property {p.name}")
            continue
        _check(p.node, "predicate", f"{pset.where}: property {p.name}", p.predicate, names,
               variables)
        formulas[("p", p.name)] = BatchFormula(p.node, constants, source=p.predicate)
    return formulas


def _machine(environment):
    """The machine of the environment's default shield (what LTL properties are read in)."""
    from ..checking.shield import load_shield
    from ..live.adapter import EnvAdapter, get_adapter

    adapter = environment if isinstance(environment, EnvAdapter) else get_adapter(environment)
    if adapter.default_shield is None:
        raise InputError(f"the environment {adapter.name} names no machine to read LTL "
                         "properties in")
    return load_shield(adapter.default_shield).machine


class _Temporal:
    """An LTL or STL formula over whole episodes: per episode, whether it holds (LTL; STL:
    a positive robustness) or its robustness (STL)."""

    def __init__(self, logic: str, text: str, machine, where: str) -> None:
        from ..checking.ltl import parse_ltl
        from ..checking.stl import parse_stl

        self.logic, self.machine = logic, machine
        self.formula = (parse_ltl if logic == "ltl" else parse_stl)(text, machine, where=where)

    def values(self, cols: RunColumns) -> np.ndarray:
        from ..checking.stl import episode_robustness

        return episode_robustness(self.formula, cols, self.machine)

    def holds(self, cols: RunColumns) -> np.ndarray:
        from ..checking.ltl import evaluate_ltl

        if self.logic == "stl":
            return self.values(cols) > 0
        return evaluate_ltl(self.formula, cols, self.machine)[cols.starts[:-1]]


def _aggregate(m: Metric, values: Optional[np.ndarray], cols: RunColumns) -> np.ndarray:
    starts = cols.starts[:-1]
    lengths = np.diff(cols.starts)
    if m.aggregate == "steps":
        return (lengths - 1).astype(float)
    if m.aggregate == "return":
        return np.add.reduceat(cols.reward, starts) - cols.reward[starts]
    v = np.asarray(values, dtype=float)
    if m.aggregate == "average":
        return np.add.reduceat(v, starts) / lengths
    if m.aggregate == "sum":
        return np.add.reduceat(v, starts)
    if m.aggregate == "sum_between_steps":
        last = cols.starts[1:] - 1
        return np.add.reduceat(v, starts) - (v[starts] + v[last]) / 2.0
    if m.aggregate == "min":
        return np.minimum.reduceat(v, starts)
    return np.maximum.reduceat(v, starts)


def _holds(p: Property, values: np.ndarray, cols: RunColumns) -> np.ndarray:
    v = np.asarray(values, dtype=bool)
    starts = cols.starts[:-1]
    if p.kind == "invariant":
        return np.logical_and.reduceat(v, starts)
    if p.kind == "eventually":
        return np.logical_or.reduceat(v, starts)
    return v[cols.starts[1:] - 1]


def evaluate_run(path: str | Path, pset: PropertySet, formulas: dict,
                 name: Optional[str] = None, cols: Optional[RunColumns] = None) -> RunValues:
    """Every metric and property of ``pset`` on every episode of a file (``cols``: the
    file's columns, when they were read already)."""
    cols = cols if cols is not None else read_columns(path)
    run = RunValues(name or Path(path).stem, str(path), len(cols.episode_ids), list(cols.seeds),
                    warnings=list(cols.warnings))
    if not run.episodes:
        return run
    for m in pset.metrics:
        if m.aggregate == "stl":
            run.metrics[m.name] = formulas[("m", m.name)].values(cols)
            continue
        values = formulas[("m", m.name)](cols.states) if m.node is not None else None
        run.metrics[m.name] = _aggregate(m, values, cols)
    for p in pset.properties:
        formula = formulas[("p", p.name)]
        run.properties[p.name] = formula.holds(cols) if p.kind in ("ltl", "stl") else \
            _holds(p, formula(cols.states), cols)
    return run


# ------------------------------------------------------------------ statistics


def _metric_stats(values: np.ndarray, m: Metric) -> dict:
    from scipy import stats

    n = len(values)
    mean = float(np.mean(values))
    out = {"mean": mean, "sd": None, "ci95": None, "n": n, "method": "t"}
    if n >= 2:
        with np.errstate(invalid="ignore"):  # inf - inf: nan, noted below
            sd = float(np.std(values, ddof=1))
        half = float(stats.t.ppf(0.975, n - 1)) * sd / math.sqrt(n)
        out.update(sd=sd, ci95=[mean - half, mean + half])
    if m.estimate is not None:
        value, eps = m.estimate
        out["estimate"] = {"value": value, "epsilon": eps,
                           "within": abs(mean - value) <= eps}
    why = _nonfinite_why(values, m)
    if why:  # JSON writes these as null; the note says why (tracecheck.render.jsontext)
        for key in ("mean", "sd", "ci95"):
            numbers = np.atleast_1d(np.asarray(out[key] if out[key] is not None else [],
                                               dtype=float))
            if not np.all(np.isfinite(numbers)):
                out[f"{key}_note"] = why
    return out


def _nonfinite_why(values: np.ndarray, m: Metric) -> Optional[str]:
    """Which episode values are not finite, and where that comes from; None if all are."""
    counts = {"+inf": int(np.sum(values == np.inf)), "-inf": int(np.sum(values == -np.inf)),
              "nan": int(np.sum(np.isnan(values)))}
    if not any(counts.values()):
        return None
    what = ", ".join(f"{n} {name}" for name, n in counts.items() if n)
    why = ("the formula has no sample to judge there: +inf for X at an episode's last state "
           "or G[a,b] past its end, -inf for F[a,b] past its end" if m.aggregate == "stl"
           else "the per-episode values overflow")
    return f"not finite: of {len(values)} episodes, {what} ({why})"


def _property_stats(holds: np.ndarray, p: Property, interval: str) -> dict:
    from scipy import stats

    n, k = len(holds), int(np.count_nonzero(holds))
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95,
                                             method=INTERVALS[interval])
    out = {"holds": k, "episodes": n, "ratio": k / n, "ci95": [float(ci.low), float(ci.high)],
           "method": interval}
    if p.test is not None:
        out["test"] = _hypothesis(k, n, p)
    return out


def _hypothesis(k: int, n: int, p: Property) -> dict:
    """SimB's test (normal approximation) and the exact binomial p-value."""
    from scipy import stats

    t = p.test
    ratio = k / n
    z = (ratio - t.p) / math.sqrt(t.p * (1 - t.p) / n)
    if t.tail == "left":  # H1: the probability is below p
        normal_p, alternative = float(stats.norm.cdf(z)), "less"
    elif t.tail == "right":
        normal_p, alternative = float(stats.norm.sf(z)), "greater"
    else:
        normal_p, alternative = float(2 * stats.norm.sf(abs(z))), "two-sided"
    exact_p = float(stats.binomtest(k, n, t.p, alternative=alternative).pvalue)
    return {"p": t.p, "alpha": t.alpha, "tail": t.tail, "z": z,
            "normal_p_value": normal_p, "normal_rejected": normal_p < t.alpha,
            "exact_p_value": exact_p, "exact_rejected": exact_p < t.alpha,
            "method": "normal approximation (SimB) and exact binomial"}


def _paired(a: RunValues, b: RunValues, pset: PropertySet) -> Optional[dict]:
    from scipy import stats

    index_a = {s: i for i, s in enumerate(a.seeds) if s is not None}
    index_b = {s: i for i, s in enumerate(b.seeds) if s is not None}
    common = sorted(set(index_a) & set(index_b))
    if not common:
        return None
    ia = np.array([index_a[s] for s in common])
    ib = np.array([index_b[s] for s in common])
    result = {"runs": [a.name, b.name], "pairs": len(common), "properties": {}, "metrics": {}}
    for p in pset.properties:
        x, y = a.properties[p.name][ia], b.properties[p.name][ib]
        only_a, only_b = int(np.sum(x & ~y)), int(np.sum(~x & y))
        pv = float(stats.binomtest(only_a, only_a + only_b, 0.5).pvalue) \
            if only_a + only_b else 1.0
        result["properties"][p.name] = {
            "only_first": only_a, "only_second": only_b, "both": int(np.sum(x & y)),
            "neither": int(np.sum(~x & ~y)), "p_value": pv, "method": "exact McNemar"}
    for m in pset.metrics:
        x, y = a.metrics[m.name][ia], b.metrics[m.name][ib]
        with np.errstate(invalid="ignore"):
            diff = x - y
        entry = {"mean_difference": float(np.mean(diff)), "paired_t_p": None,
                 "wilcoxon_p": None}
        if not np.all(np.isfinite(diff)):
            entry["mean_difference_note"] = ("not finite: a pair of episodes has a value that "
                                             "is not finite (see the runs' metrics); no test")
        else:
            if len(diff) >= 2 and np.std(diff) > 0:
                entry["paired_t_p"] = float(stats.ttest_rel(x, y).pvalue)
            if np.any(diff != 0):
                entry["wilcoxon_p"] = float(stats.wilcoxon(x, y).pvalue)
        result["metrics"][m.name] = entry
    return result


def _evaluate_one(path: str, pset: PropertySet, name: Optional[str]) -> RunValues:
    """One file, in whichever process runs it."""
    cols = read_columns(path)
    sample = cols.states.row(0) if cols.states.n else None
    return evaluate_run(path, pset, prepare(pset, environment_of(path), sample), name, cols)


class StatsResult(dict):
    """The statistics as JSON-ready data (this dict), and the per-episode values of every
    run they come from (``values``; plots use them, the JSON has no place for them)."""

    def __init__(self, data: dict, values: list[RunValues]) -> None:
        super().__init__(data)
        self.values = values


def statistics(paths: list[str | Path], pset: PropertySet, *, interval: str = "wilson",
               names: Optional[list[str]] = None,
               columns: Optional[list[RunColumns]] = None, executor: str = "local",
               ray_address: Optional[str] = None) -> StatsResult:
    """The statistics of the runs in ``paths`` (JSON-ready; see the module docstring).

    ``columns``: the runs' columns when they were read already; ``statistics_s`` in the
    result is the time spent after reading."""
    if interval not in INTERVALS:
        raise InputError(f"unknown interval method {interval!r}; the methods are "
                         f"{', '.join(INTERVALS)}")
    environments = {environment_of(p) for p in paths}
    if len(environments) > 1:
        names = ", ".join(sorted(environments))
        raise InputError(f"the runs come from different environments ({names}); "
                         "compare runs of one environment")
    environment = environments.pop() if environments else "highway"
    if executor != "local":
        from ..live.executors import map_files

        start = time.perf_counter()
        runs = map_files(_evaluate_one, [(str(p), pset, names[i] if names else None)
                                         for i, p in enumerate(paths)], executor, ray_address)
    else:
        cols = columns or [read_columns(p) for p in paths]
        sample = cols[0].states.row(0) if cols and cols[0].states.n else None
        formulas = prepare(pset, environment, sample)
        start = time.perf_counter()
        runs = [evaluate_run(p, pset, formulas, names[i] if names else None, cols[i])
                for i, p in enumerate(paths)]
    out = {"properties_set": pset.name, "interval": interval, "runs": [], "comparisons": [],
           "warnings": [w for r in runs for w in r.warnings]}
    for run in runs:
        entry = {"name": run.name, "file": run.file, "episodes": run.episodes,
                 "metrics": {}, "properties": {}}
        if run.episodes:
            entry["metrics"] = {m.name: _metric_stats(run.metrics[m.name], m)
                                for m in pset.metrics}
            entry["properties"] = {p.name: _property_stats(run.properties[p.name], p, interval)
                                   for p in pset.properties}
        else:
            entry["note"] = "no episodes: nothing to estimate"
        out["runs"].append(entry)
    for i, a in enumerate(runs):
        for b in runs[i + 1:]:
            if a.episodes and b.episodes:
                paired = _paired(a, b, pset)
                if paired is not None:
                    out["comparisons"].append(paired)
    out["statistics_s"] = round(time.perf_counter() - start, 6)
    out["descriptions"] = {**{m.name: m.description for m in pset.metrics},
                           **{p.name: p.description for p in pset.properties}}
    return StatsResult(out, runs)
