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
from typing import Iterator, Optional

import numpy as np

from .levels import CONFIDENCE
from ..b.arrays import float_column
from ..episodes.columns import RunColumns, join, read_blocks, read_columns
from ..errors import InputError
from ..checking.crashflag import with_crash_flag
from .continuous import (INTERVALS, ContinuousSteps, continuous_summary, joined_steps,
                         read_continuous_steps)
from .continuous import interventions as continuous_interventions
from .formulas import check_environment, environment_of, naming, prepare
from .properties import Metric, Property, PropertySet

__all__ = ["RunValues", "StatsResult", "evaluate_run", "statistics", "run_statistics",
           "INTERVALS"]


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
    #: continuous actions: what the shield did at each step (None for a discrete run)
    continuous: Optional[ContinuousSteps] = None


def _values_recorded(cols: RunColumns) -> np.ndarray:
    """Per row: were the agent's action values recorded (all of them, finite)?"""
    return np.all(np.isfinite(cols.values), axis=1)


def interventions(cols: RunColumns, recorded: Optional[np.ndarray] = None) -> np.ndarray:
    """Per row: did the shield replace the agent's preferred action (the best of its
    recorded action values) by another? False at step 0 and where no values were recorded
    (``recorded``: the rows' :func:`_values_recorded`, when computed already)."""
    out = np.zeros(cols.n, dtype=bool)
    if cols.values is None or not cols.n:
        return out
    known = (_values_recorded(cols) if recorded is None else recorded) & (cols.action >= 0)
    preferred = np.argmax(np.where(np.isfinite(cols.values), cols.values, -np.inf), axis=1)
    out[known] = preferred[known] != cols.action[known]
    return out


def _recorded_choices(cols: RunColumns, recorded: Optional[np.ndarray]) -> np.ndarray:
    """Per episode: were the agent's action values recorded at its steps (``recorded``: the
    rows' :func:`_values_recorded`, None where the file has no values)?"""
    if recorded is None:
        return np.zeros(len(cols.episode_ids), dtype=bool)
    known = recorded.copy()
    known[cols.starts[:-1]] = True  # step 0 has no action to judge
    return np.logical_and.reduceat(known, cols.starts[:-1])


def _aggregate(m: Metric, values: Optional[np.ndarray], cols: RunColumns) -> np.ndarray:
    starts = cols.starts[:-1]
    lengths = np.diff(cols.starts)
    if m.aggregate == "steps":
        return (lengths - 1).astype(float)
    if m.aggregate == "return":
        return np.add.reduceat(cols.reward, starts) - cols.reward[starts]
    if m.aggregate == "interventions":
        if cols.parameters and (cols.values is None or cols.proposals):
            # continuous: the proposal was changed (a hybrid space's operation or values;
            # its every step judged by the agent's scores)
            recorded, changed = continuous_interventions(cols)
        else:
            recorded = None if cols.values is None else _values_recorded(cols)
            changed = interventions(cols, recorded)
        share = np.add.reduceat(changed, starts) / np.maximum(lengths - 1, 1)
        return np.where(_recorded_choices(cols, recorded), share, np.nan)
    v = np.asarray(values, dtype=float)
    if m.aggregate == "average":
        return np.add.reduceat(v, starts) / lengths
    if m.aggregate == "sum":
        return np.add.reduceat(v, starts)
    if m.aggregate in ("sum_between_steps", "average_between_steps"):
        last = cols.starts[1:] - 1
        total = np.add.reduceat(v, starts) - (v[starts] + v[last]) / 2.0
        if m.aggregate == "sum_between_steps":
            return total
        return np.where(lengths > 1, total / np.maximum(lengths - 1, 1), 0.0)
    if m.aggregate in ("min_between_steps", "max_between_steps"):
        return _between_extreme(v, cols, m.aggregate == "min_between_steps")
    if m.aggregate == "min":
        return np.minimum.reduceat(v, starts)
    return np.maximum.reduceat(v, starts)


def _between_extreme(v: np.ndarray, cols: RunColumns, least: bool) -> np.ndarray:
    """Per episode, the least (or greatest) mean of two successive states' values; not a
    number for an episode without steps."""
    fill = np.inf if least else -np.inf
    mids = np.full(len(v), fill)
    mids[1:] = (v[:-1] + v[1:]) / 2.0
    mids[cols.starts[:-1]] = fill  # a first state has no state before it in its episode
    out = (np.minimum if least else np.maximum).reduceat(mids, cols.starts[:-1])
    return np.where(np.diff(cols.starts) > 1, out, np.nan)


def _holds(p: Property, values: np.ndarray, cols: RunColumns) -> np.ndarray:
    v = np.asarray(values, dtype=bool)
    starts = cols.starts[:-1]
    if p.kind == "invariant":
        return np.logical_and.reduceat(v, starts)
    if p.kind == "eventually":
        return np.logical_or.reduceat(v, starts)
    return v[cols.starts[1:] - 1]


def evaluate_run(path: str | Path, pset: PropertySet, formulas: dict,
                 name: Optional[str] = None, cols: Optional[RunColumns] = None, *,
                 salvage: bool = False) -> RunValues:
    """Every metric and property of ``pset`` on every episode of a file (``cols``: the
    file's columns, when they were read already; else read with ``salvage``)."""
    cols = cols if cols is not None else read_columns(path, salvage=salvage)
    run = RunValues(name or Path(path).stem, str(path), len(cols.episode_ids), list(cols.seeds),
                    warnings=list(cols.warnings))
    if not run.episodes:
        return run
    cols = with_crash_flag(cols)
    for m in pset.metrics:
        if m.aggregate == "stl":
            run.metrics[m.name] = formulas.metrics[m.name].values(cols)
            continue
        values = None
        if m.node is not None:
            with naming(f"{pset.where}: metric {m.name}"):
                values = float_column(formulas.metrics[m.name](cols.states), cols.states,
                                      f"`{m.expression}`")
        run.metrics[m.name] = _aggregate(m, values, cols)
    for p in pset.properties:
        if p.kind == "end":
            run.properties[p.name] = np.array([r == p.predicate for r in cols.reasons],
                                              dtype=bool)
            continue
        formula = formulas.properties[p.name]
        with naming(f"{pset.where}: property {p.name}"):
            run.properties[p.name] = formula.holds(cols) if p.kind in ("ltl", "stl") else \
                _holds(p, formula(cols.states), cols)
    return run


# ------------------------------------------------------------------ statistics


#: the values an episode's metric of each aggregate can take (a share, a count): its
#: interval is cut to them
RANGES = {"interventions": (0.0, 1.0), "steps": (0.0, math.inf)}


def _span_text(span: tuple[float, float]) -> str:
    return f"[{span[0]:g}, {span[1]:g}]" if math.isfinite(span[1]) else f">= {span[0]:g}"


def _metric_stats(values: np.ndarray, m: Metric) -> dict:
    from scipy import stats

    n = len(values)
    mean = float(np.mean(values))
    out = {"mean": mean, "sd": None, "ci95": None, "n": n, "method": "t"}
    if n >= 2:
        with np.errstate(invalid="ignore"):  # inf - inf: nan, noted below
            sd = float(np.std(values, ddof=1))
        half = float(stats.t.ppf(1 - (1 - CONFIDENCE) / 2, n - 1)) * sd / math.sqrt(n)
        out.update(sd=sd, ci95=[mean - half, mean + half])
        span = RANGES.get(m.aggregate)
        if span is not None and np.all(np.isfinite(out["ci95"])) and \
                (out["ci95"][0] < span[0] or out["ci95"][1] > span[1]):
            # a mean of values within the span is within it: the t-interval's normal
            # approximation reached past it (a share near 0 over few episodes), cut there
            out["ci95"] = [max(out["ci95"][0], span[0]), min(out["ci95"][1], span[1])]
            out["method"] = f"t, cut to the metric's range {_span_text(span)}"
    if m.estimate is not None:
        value, eps = m.estimate
        within = {"mean": abs(mean - value) <= eps, "minimum": mean >= value - eps,
                  "maximum": mean <= value + eps}[m.estimate_type]
        out["estimate"] = {"value": value, "epsilon": eps, "type": m.estimate_type,
                           "within": bool(within)}
    why = _nonfinite_why(values, m)
    if why:  # JSON writes these as null; the note says why (tracecheck.jsontext)
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
           else "the agent's action values were not recorded (imported traces, external "
           "scripts), so the "
           "shield's interventions cannot be told" if m.aggregate == "interventions"
           else "an episode without steps has no mean between two steps"
           if m.aggregate in ("min_between_steps", "max_between_steps")
           else "the per-episode values overflow")
    return f"not finite: of {len(values)} episodes, {what} ({why})"


def _property_stats(holds: np.ndarray, p: Property, interval: str) -> dict:
    from scipy import stats

    n, k = len(holds), int(np.count_nonzero(holds))
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=CONFIDENCE,
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
    alternative = {"left": "less", "right": "greater"}.get(t.tail, "two-sided")
    exact_p = float(stats.binomtest(k, n, t.p, alternative=alternative).pvalue)
    method = "normal approximation (SimB) and exact binomial"
    if 0.0 < t.p < 1.0:
        z: Optional[float] = (k / n - t.p) / math.sqrt(t.p * (1 - t.p) / n)
        normal_p = float({"less": stats.norm.cdf(z), "greater": stats.norm.sf(z)}.get(
            alternative, 2 * stats.norm.sf(abs(z))))
    else:  # p = 0 or 1: the binomial is a point mass (σ = 0), no normal to approximate it
        z, normal_p = None, exact_p
        method = f"exact binomial (p = {t.p:g}: the normal approximation has σ = 0)"
    return {"p": t.p, "alpha": t.alpha, "tail": t.tail, "z": z,
            "normal_p_value": normal_p, "normal_rejected": normal_p < t.alpha,
            "exact_p_value": exact_p, "exact_rejected": exact_p < t.alpha,
            "method": method}


def run_statistics(run: RunValues, pset: PropertySet, interval: str = "wilson") -> dict:
    """The statistics of one run's per-episode values (what :func:`statistics` gives for
    each run): per metric its mean with a t interval and estimate check, per property its
    share with an interval and hypothesis test."""
    return {"metrics": {m.name: _metric_stats(run.metrics[m.name], m) for m in pset.metrics},
            "properties": {p.name: _property_stats(run.properties[p.name], p, interval)
                           for p in pset.properties}}


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


def _evaluate_one(path: str, pset: PropertySet, name: Optional[str],
                  environment=None, salvage: bool = False, block=None) -> RunValues:
    """One file (or one block of it), in whichever process runs it."""
    return _evaluate_blocks(path, pset, name, environment or environment_of(path),
                            read_blocks(path, salvage=salvage, block=block), salvage)[0]


def _evaluate_blocks(path: str, pset: PropertySet, name: Optional[str], environment,
                     blocks: Iterator[RunColumns], salvage: bool = False,
                     formulas: Optional[dict] = None) -> tuple[RunValues, dict, float]:
    """The values of one file from its blocks, one block in memory at a time (a run with
    continuous actions: joined, for its steps' decoded messages); the formulas are prepared
    from the first state where not given. Also the seconds spent reading the blocks."""
    from ..episodes.reader import read_header

    reading = 0.0
    runs = []
    declared = bool(read_header(path).action_parameters)  # a run of continuous actions
    while True:
        start = time.perf_counter()
        cols = next(blocks, None)
        reading += time.perf_counter() - start
        if cols is None:
            break
        if cols.parameters or declared:  # continuous: every block at once, for the steps'
            #                              messages (a block of discrete steps of it too)
            start = time.perf_counter()
            cols = join(str(path), [cols, *blocks])
            reading += time.perf_counter() - start
        if formulas is None:
            sample = cols.states.row(0) if cols.states.n else None
            formulas = prepare(pset, environment, sample)
            runs.append(RunValues(name or Path(path).stem, str(path), 0, [],
                                  warnings=list(formulas.warnings)))
        runs.append(evaluate_run(path, pset, formulas, name, cols))
        if cols.parameters or cols.proposals:  # a hybrid run whose agent never executed
            start = time.perf_counter()       # parameters still proposed some
            runs[-1].continuous = read_continuous_steps(path, cols, salvage=salvage)
            reading += time.perf_counter() - start
    return _merged(runs, name or Path(path).stem, str(path)), formulas, reading


def _merged(parts: list[RunValues], name: str, file: str) -> RunValues:
    """The values of a file's blocks, one after the other."""
    run = RunValues(name, file, sum(r.episodes for r in parts),
                    [s for r in parts for s in r.seeds],
                    warnings=list(dict.fromkeys(w for r in parts for w in r.warnings)))
    done = [r for r in parts if r.episodes]
    for key in ("metrics", "properties"):
        for k in (getattr(done[0], key) if done else ()):
            getattr(run, key)[k] = np.concatenate([getattr(r, key)[k] for r in done])
    run.continuous = joined_steps([r.continuous for r in parts if r.continuous is not None])
    return run


class StatsResult(dict):
    """The statistics as JSON-ready data (this dict), and the per-episode values of every
    run they come from (``values``; plots use them, the JSON has no place for them)."""

    def __init__(self, data: dict, values: list[RunValues]) -> None:
        super().__init__(data)
        self.values = values


def statistics(paths: list[str | Path], pset: PropertySet, *, interval: str = "wilson",
               names: Optional[list[str]] = None,
               columns: Optional[list[RunColumns]] = None, executor: str = "local",
               ray_address: Optional[str] = None, adapter=None,
               salvage: bool = False, workers: int = 1) -> StatsResult:
    """The statistics of the runs in ``paths`` (JSON-ready; see the module docstring).

    ``columns``: the runs' columns when they were read already (else read with ``salvage``,
    as :func:`~tracecheck.episodes.columns.read_columns`); ``adapter``: the runs'
    environment adapter, when given by the user (``--env``; else the installed one their
    files name, if any); ``statistics_s`` in the result is the time spent after reading;
    ``workers``: with the ``local`` executor, how many processes evaluate the blocks of runs
    not read yet (the same result)."""
    if interval not in INTERVALS:
        raise InputError(f"unknown interval method {interval!r}; the methods are "
                         f"{', '.join(INTERVALS)}")
    environments = {environment_of(p) for p in paths}
    if len(environments) > 1:
        names = ", ".join(sorted(environments))
        raise InputError(f"the runs come from different environments ({names}); "
                         "compare runs of one environment")
    environment = environments.pop() if environments else None
    if adapter is not None:
        for path in paths:
            check_environment(adapter, path)
        environment = adapter
    if executor != "local" or (workers > 1 and not columns):
        from ..checking.executors import map_file_blocks

        start = time.perf_counter()
        parts = map_file_blocks(_evaluate_one, lambda i, p, block: (
            p, pset, names[i] if names else None, adapter, salvage, block),
            [str(p) for p in paths], executor, ray_address, workers)
        runs = [_merged([r for j, r in parts if j == i],
                        names[i] if names else Path(p).stem, str(p))
                for i, p in enumerate(paths)]
    else:
        start = time.perf_counter()
        runs, formulas, reading = [], None, 0.0
        for i, p in enumerate(paths):
            blocks = iter([columns[i]]) if columns else read_blocks(p, salvage=salvage)
            run, formulas, took = _evaluate_blocks(str(p), pset, names[i] if names else None,
                                                   environment, blocks, salvage, formulas)
            runs.append(run)
            reading += took
        start += reading  # the time spent reading is not the statistics'
    out = {"properties_set": pset.name, "interval": interval, "runs": [], "comparisons": [],
           "warnings": list(dict.fromkeys(w for r in runs for w in r.warnings))}
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
        if run.continuous is not None and run.episodes:
            entry["continuous"] = continuous_summary(run.continuous, interval)
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
