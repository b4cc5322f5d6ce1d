"""SimB's validation tasks (hypothesis tests, estimations, Monte Carlo runs) on episodes.

A SIMULATION task of a ProB2-UI project names a ``CHECKING_TYPE`` and a predicate or an
expression; tracecheck maps it onto its own property set (:mod:`.properties`) and computes it
with :mod:`.estimates`, so a task gives the numbers ``tracecheck stats`` gives:

================================  ==============================================
CHECKING_TYPE                     tracecheck
================================  ==============================================
``ALL_INVARIANTS``                property of kind ``invariant``: the machine's INVARIANT
``PREDICATE_INVARIANT``           property of kind ``invariant`` (every state)
``PREDICATE_EVENTUALLY``          property of kind ``eventually`` (some state)
``PREDICATE_FINAL``               property of kind ``final`` (the last state)
``TIMING``                        the execution's duration is at most ``TIME`` ms
``AVERAGE`` / ``SUM``             metric ``average`` / ``sum`` over the states
``MINIMUM`` / ``MAXIMUM``         metric ``min`` / ``max``
``…_MEAN_BETWEEN_STEPS``          metric ``…_between_steps`` (the mean of each step's two
                                  states, then averaged, summed, least or greatest)
================================  ==============================================

A ``HYPOTHESIS_TEST`` (only predicate types) succeeds as SimB decides it (ProB2-UI's
``SimulationHypothesisChecker``): with n executions of which k satisfy the property, μ = n·p
and σ = √(n·p·(1−p)), the range r is the least i ≥ 0 whose normal coverage (with continuity
correction; ``LEFT_TAILED`` 1 − Φ(−(i+½)/σ), ``RIGHT_TAILED`` Φ((i+½)/σ), ``TWO_TAILED``
both) leaves less than the significance α outside; the test succeeds when k ≥ μ − r (left),
k ≤ μ + r (right) or |k − μ| ≤ r (two). The normal and exact binomial p-values of
tracecheck's own test are given beside it. An ``ESTIMATION`` estimates the mean of the
per-execution values (the share of executions satisfying a predicate type) and checks it
against ``DESIRED_VALUE`` ± ``EPSILON`` by ``ESTIMATION_TYPE``: ``MEAN`` within, ``MINIMUM``
at least value − ε, ``MAXIMUM`` at most value + ε. A ``MONTE_CARLO_SIMULATION`` succeeds
when every execution asked for was there.

Each execution is cut as SimB's ending and starting conditions say (:func:`window`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional, Sequence

import numpy as np

from ..b.parser import parse_formula
from ..b.scope import EXPR, PRED, check_kind
from ..episodes.columns import episode_columns
from ..episodes.model import Episode
from ..errors import TracecheckError
from .estimates import evaluate_run, prepare, run_statistics
from .properties import HypothesisTest, Metric, Property, PropertySet

__all__ = ["SimbTask", "Window", "TaskOutcome", "evaluate_task", "simb_hypothesis", "window",
           "unsupported", "CHECKING_TYPES", "PREDICATE_TYPES", "VALUE_TYPES",
           "SIMULATION_TYPES", "HYPOTHESIS", "ESTIMATION", "MONTE_CARLO", "SUCCESS", "FAILED",
           "NOT_RUN"]

SUCCESS, FAILED, NOT_RUN = "success", "failed", "not run"
HYPOTHESIS, ESTIMATION, MONTE_CARLO = "HYPOTHESIS_TEST", "ESTIMATION", "MONTE_CARLO_SIMULATION"
SIMULATION_TYPES = (HYPOTHESIS, ESTIMATION, MONTE_CARLO)

#: predicate checking types → property kinds
PREDICATE_TYPES = {"ALL_INVARIANTS": "invariant", "PREDICATE_INVARIANT": "invariant",
                   "PREDICATE_EVENTUALLY": "eventually", "PREDICATE_FINAL": "final",
                   "TIMING": "timing"}
#: value checking types → metric aggregates
VALUE_TYPES = {"AVERAGE": "average", "SUM": "sum", "MINIMUM": "min", "MAXIMUM": "max",
               "AVERAGE_MEAN_BETWEEN_STEPS": "average_between_steps",
               "SUM_MEAN_BETWEEN_STEPS": "sum_between_steps",
               "MINIMUM_MEAN_BETWEEN_STEPS": "min_between_steps",
               "MAXIMUM_MEAN_BETWEEN_STEPS": "max_between_steps"}
CHECKING_TYPES = (*PREDICATE_TYPES, *VALUE_TYPES)
TAILS = {"LEFT_TAILED": "left", "RIGHT_TAILED": "right", "TWO_TAILED": "two"}
ESTIMATION_TYPES = {"MEAN": "mean", "MINIMUM": "minimum", "MAXIMUM": "maximum"}


@dataclass(frozen=True)
class Window:
    """SimB's starting and ending conditions of one execution (times in ms)."""

    max_steps_before: int = 0
    start_after_steps: Optional[int] = None
    starting_predicate: Optional[str] = None
    starting_predicate_activated: Optional[str] = None
    starting_time: Optional[int] = None
    steps_per_execution: Optional[int] = None
    ending_predicate: Optional[str] = None
    ending_time: Optional[int] = None


@dataclass(frozen=True)
class SimbTask:
    """One SimB task, its fields as ProB2-UI stores them (validated where it was read)."""

    kind: str  # one of SIMULATION_TYPES
    checking_type: Optional[str] = None
    formula: Optional[str] = None  # PREDICATE or EXPRESSION
    executions: Optional[int] = None
    window: Window = field(default_factory=Window)
    probability: Optional[float] = None
    significance: Optional[float] = None
    hypothesis_type: Optional[str] = None
    estimation_type: Optional[str] = None
    desired_value: Optional[float] = None
    epsilon: Optional[float] = None
    time: Optional[int] = None  # TIMING: the longest duration, ms

    @property
    def checks(self) -> str:
        """What the task checks, in a few words (for tables)."""
        if self.kind == MONTE_CARLO:
            return "runs the executions"
        what = self.checking_type or "?"
        if self.checking_type == "TIMING":
            return f"TIMING <= {self.time} ms"
        if self.checking_type == "ALL_INVARIANTS":
            return what
        return f"{what} {self.formula}"


@dataclass
class TaskOutcome:
    """A task's verdict: ``status`` success, failed or not run; ``result`` the numbers in a
    line; ``details`` the JSON; ``reason`` why it failed or did not run."""

    status: str
    executions: int = 0
    result: str = ""
    details: dict = field(default_factory=dict)
    reason: str = ""


def simb_hypothesis(k: int, n: int, p: float, alpha: float, tail: str) -> dict:
    """SimB's verdict on ``k`` of ``n`` executions for probability ``p``, significance
    ``alpha`` and ``tail`` (left, right, two): see the module docstring.

    >>> simb_hypothesis(93, 100, 0.95, 0.05, "left")["success"]
    True
    >>> simb_hypothesis(90, 100, 0.95, 0.05, "left")["success"]
    False
    """
    from scipy.stats import norm

    mu, sigma = n * p, math.sqrt(n * p * (1 - p))
    i = np.arange(n + 1, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (i + 0.5) / sigma if sigma > 0 else np.full(n + 1, np.inf)
    if tail == "left":
        coverage = 1.0 - norm.cdf(-z)
    elif tail == "right":
        coverage = norm.cdf(z)
    else:
        coverage = norm.cdf(z) - norm.cdf(-z)
    inside = np.flatnonzero(1.0 - coverage < alpha)
    r = int(inside[0]) if len(inside) else 0
    success = {"left": k >= mu - r, "right": k <= mu + r,
               "two": mu - r <= k <= mu + r}[tail]
    return {"successes": k, "executions": n, "mu": mu, "sigma": sigma, "range": r,
            "success": bool(success)}


def _node(text: str, kind: str, where: str):
    node = parse_formula(text, file=where)
    what = "predicate" if kind == PRED else "expression"
    check_kind(node, kind, source=text, context=f"the {what}")
    return node


def _predicates(window: Window, machine, cols) -> dict:
    """Per row of ``cols``, the value of each starting or ending predicate of ``window``."""
    named = {key: text for key in ("starting_predicate", "starting_predicate_activated",
                                   "ending_predicate")
             if (text := getattr(window, key)) is not None}
    if not named:
        return {}
    pset = PropertySet("window", (), tuple(
        Property(key, text, _node(text, PRED, key.upper()), "invariant")
        for key, text in named.items()))
    formulas = prepare(pset, machine=machine)
    from ..checking.crashflag import with_crash_flag

    states = with_crash_flag(cols).states
    return {key: np.asarray(formulas[("p", key)](states), dtype=bool) for key in named}


def window(w: Window, episodes: Sequence[Episode], machine, seed: int = 0
           ) -> list[tuple[int, int]]:
    """Per episode, the states (first, last) its properties are judged on, as SimB cuts an
    execution; first > last where the starting condition is never reached.

    Start: from a random step in 0 … ``max_steps_before`` − 1 (SimB's
    ``MAX_STEPS_BEFORE_PROPERTY``; numpy's generator with ``seed``) on, the first state with
    at least ``start_after_steps`` steps, at ``starting_time``, where ``starting_predicate``
    holds, or where ``starting_predicate_activated`` becomes true; the first one without a
    starting condition. End (counted from the start, SimB's order): ``steps_per_execution``
    steps, the first state where ``ending_predicate`` holds, the last state at most
    ``ending_time`` ms after the start; else the episode's last state.
    """
    rng = np.random.default_rng(seed)
    cols = episode_columns(episodes, _actions(episodes)) if episodes else None
    values = _predicates(w, machine, cols) if cols is not None else {}
    out = []
    for i in range(len(episodes)):
        lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
        times = cols.time[lo:hi] * 1000.0
        least = int(rng.random() * w.max_steps_before) if w.max_steps_before > 0 else 0
        start = _start(w, values, lo, hi, times, least)
        last = hi - lo - 1
        if start > last:
            out.append((start, last))
            continue
        end = last
        if w.steps_per_execution is not None:
            end = min(last, start + w.steps_per_execution)
        elif w.ending_predicate is not None:
            hits = np.flatnonzero(values["ending_predicate"][lo + start:hi])
            end = start + int(hits[0]) if len(hits) else last
        elif w.ending_time is not None:
            inside = np.flatnonzero(times <= times[start] + w.ending_time + 1e-6)
            end = int(inside[-1])
        out.append((start, end))
    return out


def _start(w: Window, values: dict, lo: int, hi: int, times: np.ndarray, least: int) -> int:
    """The first state (index in its episode) from ``least`` on where the starting condition
    holds; the episode's length when it never does."""
    n = hi - lo
    ok = np.ones(n, dtype=bool)
    if w.start_after_steps is not None:
        ok &= np.arange(n) >= w.start_after_steps
    elif w.starting_predicate is not None:
        ok &= values["starting_predicate"][lo:hi]
    elif w.starting_predicate_activated is not None:
        now = values["starting_predicate_activated"][lo:hi]
        ok &= now & np.concatenate([[False], ~now[:-1]])
    elif w.starting_time is not None:
        ok &= times >= w.starting_time
    ok[:least] = False
    hits = np.flatnonzero(ok)
    return int(hits[0]) if len(hits) else n


def _actions(episodes: Sequence[Episode]) -> list[str]:
    return sorted({s.action for ep in episodes for s in ep.steps if s.action is not None})


def _property_set(task: SimbTask, machine, where: str) -> tuple[PropertySet, PropertySet]:
    """(what tracecheck evaluates, what its statistics report) for ``task``: the same set,
    except that TIMING is computed here, not evaluated. Messages name ``where``."""
    name = _field(task)
    kind = PREDICATE_TYPES.get(task.checking_type)
    if kind is not None:
        test = None
        if task.kind == HYPOTHESIS:
            test = HypothesisTest(task.probability, task.significance,
                                  TAILS[task.hypothesis_type])
        if kind == "timing":
            prop = Property(name, f"duration <= {task.time} ms", None, "end", test=test)
            return PropertySet(name, file=where), PropertySet(name, (), (prop,), where)
        if task.checking_type == "ALL_INVARIANTS":
            node, text = machine.invariant_node, "the machine's INVARIANT"
            if node is None:
                node, text = _node("TRUE = TRUE", PRED, "INVARIANT"), "TRUE = TRUE"
        else:
            node, text = _node(task.formula, PRED, "PREDICATE"), task.formula
        prop = Property(name, text, node, kind, test=test)
        return (PropertySet(name, (), (prop,), where),) * 2
    aggregate = VALUE_TYPES[task.checking_type]
    estimate = None
    if task.kind == ESTIMATION:
        estimate = (task.desired_value, task.epsilon)
    metric = Metric(name, aggregate, task.formula, _node(task.formula, EXPR, "EXPRESSION"),
                    estimate=estimate,
                    estimate_type=ESTIMATION_TYPES.get(task.estimation_type, "mean"))
    return (PropertySet(name, (metric,), (), where),) * 2


def _field(task: SimbTask) -> str:
    """The name of the one metric or property a task becomes: the field it comes from."""
    return {"TIMING": "TIME", "ALL_INVARIANTS": "INVARIANT"}.get(
        task.checking_type, "PREDICATE" if task.checking_type in PREDICATE_TYPES
        else "EXPRESSION")


def unsupported(task: SimbTask) -> Optional[str]:
    """Why tracecheck cannot run ``task`` as it is written (None: it can)."""
    if task.kind not in SIMULATION_TYPES:
        return f"the simulation type {task.kind} is not one tracecheck runs " \
               f"({', '.join(SIMULATION_TYPES)})"
    if task.kind == MONTE_CARLO:
        return None
    if task.checking_type not in CHECKING_TYPES:
        return f"the checking type {task.checking_type} is not one tracecheck knows " \
               f"({', '.join(CHECKING_TYPES)})"
    if task.kind == HYPOTHESIS and task.checking_type in VALUE_TYPES:
        return f"a hypothesis test of a value ({task.checking_type}): SimB tests only " \
               "predicates"
    if task.kind == HYPOTHESIS and task.hypothesis_type not in TAILS:
        return f"the hypothesis checking type {task.hypothesis_type} is not one of " \
               f"{', '.join(TAILS)}"
    if task.kind == ESTIMATION and task.estimation_type not in ESTIMATION_TYPES:
        return f"the estimation type {task.estimation_type} is not one of " \
               f"{', '.join(ESTIMATION_TYPES)}"
    return None


def evaluate_task(task: SimbTask, episodes: Sequence[Episode], machine, *,
                  seed: int = 0, where: str = "the task") -> TaskOutcome:
    """``task`` on ``episodes`` (its first ``task.executions`` when set), judged on the
    states :func:`window` gives, against ``machine``'s names. A formula tracecheck cannot
    read or evaluate gives the outcome *not run* with the reason (naming ``where``), never
    an exception."""
    why = unsupported(task)
    if why:
        return TaskOutcome(NOT_RUN, reason=why)
    episodes = list(episodes)
    wanted = task.executions
    if wanted is not None:
        episodes = episodes[:wanted]
    n = len(episodes)
    if task.kind == MONTE_CARLO:
        return _monte_carlo(episodes, wanted)
    if not n:
        return TaskOutcome(NOT_RUN, reason="no executions to judge")
    try:
        return _judge(task, episodes, machine, seed, where)
    except TracecheckError as exc:
        return TaskOutcome(NOT_RUN, n, reason=f"tracecheck cannot evaluate it: {exc.render()}")


def _monte_carlo(episodes: list[Episode], wanted: Optional[int]) -> TaskOutcome:
    n = len(episodes)
    steps = [len(ep.steps) - 1 for ep in episodes]
    mean = float(np.mean(steps)) if steps else 0.0
    details = {"executions": n, "wanted": wanted, "mean_steps": mean}
    result = f"{n} executions, {mean:.4g} steps on average"
    if wanted is not None and n < wanted:
        return TaskOutcome(FAILED, n, result, details, f"only {n} of {wanted} executions")
    if not n:
        return TaskOutcome(NOT_RUN, 0, result, details, "no executions")
    return TaskOutcome(SUCCESS, n, result, details)


def _judge(task: SimbTask, episodes: list[Episode], machine, seed: int, where: str
           ) -> TaskOutcome:
    evaluated, reported = _property_set(task, machine, where)
    spans = window(task.window, episodes, machine, seed)
    started = np.array([a <= b for a, b in spans], dtype=bool)
    cut = [replace(ep, steps=ep.steps[a:b + 1] if a <= b else ep.steps[-1:])
           for ep, (a, b) in zip(episodes, spans)]
    cols = episode_columns(cut, _actions(cut))
    name = _field(task)
    run = evaluate_run(where, evaluated, prepare(evaluated, machine=machine), name, cols)
    if task.checking_type == "TIMING":
        duration = np.array([(ep.steps[-1].time - ep.steps[0].time) * 1000.0 for ep in cut])
        run.properties[name] = (duration <= task.time + 1e-6) | ~started
    _unstarted(run, task, started, name)
    stats = run_statistics(run, reported)
    details = {"executions": len(episodes), "not_started": int(np.sum(~started)), **stats}
    if reported.properties:
        return _predicate_verdict(task, stats["properties"][name], details)
    return _value_verdict(task, stats["metrics"][name], details)


def _unstarted(run, task: SimbTask, started: np.ndarray, name: str) -> None:
    """SimB's values for executions that never reached the starting condition: an
    invariant holds, an eventually does not, a final predicate is judged on the last state;
    averages and sums are 0, least and greatest values none."""
    if started.all():
        return
    if name in run.properties:
        kind = PREDICATE_TYPES[task.checking_type]
        if kind == "invariant":
            run.properties[name] = run.properties[name] | ~started
        elif kind == "eventually":
            run.properties[name] = run.properties[name] & started
    if name in run.metrics:
        values = run.metrics[name].astype(float)
        empty = 0.0 if VALUE_TYPES[task.checking_type].startswith(("average", "sum")) \
            else np.nan
        values[~started] = empty
        run.metrics[name] = values


def _predicate_verdict(task: SimbTask, stats: dict, details: dict) -> TaskOutcome:
    k, n, ratio = stats["holds"], stats["episodes"], stats["ratio"]
    if task.kind == HYPOTHESIS:
        simb = simb_hypothesis(k, n, task.probability, task.significance,
                               TAILS[task.hypothesis_type])
        details["simb"] = simb
        t = stats["test"]
        result = (f"{k}/{n} hold ({ratio:.3f}); p={task.probability:g}, "
                  f"α={task.significance:g}: {'accepted' if simb['success'] else 'rejected'} "
                  f"(normal p-value {t['normal_p_value']:.3g}, exact {t['exact_p_value']:.3g})")
        reason = "" if simb["success"] else (
            f"{k} of {n} executions satisfy it, outside SimB's acceptance range "
            f"(μ = {simb['mu']:g}, range {simb['range']})")
        return TaskOutcome(SUCCESS if simb["success"] else FAILED, n, result, details, reason)
    ok = _within(ratio, task)
    result = (f"{k}/{n} hold: estimate {ratio:.4g} (95% CI {stats['ci95'][0]:.3g}–"
              f"{stats['ci95'][1]:.3g}); {_wanted(task)}")
    return TaskOutcome(SUCCESS if ok else FAILED, n, result, details,
                       "" if ok else f"the estimate {ratio:.4g} is not {_wanted(task)}")


def _value_verdict(task: SimbTask, stats: dict, details: dict) -> TaskOutcome:
    mean, n = stats["mean"], stats["n"]
    ci = stats["ci95"]
    interval = f" (95% CI {ci[0]:.4g}–{ci[1]:.4g})" if ci and all(map(math.isfinite, ci)) \
        else ""
    result = f"estimate {mean:.4g}{interval}; {_wanted(task)}"
    if task.kind != ESTIMATION:
        return TaskOutcome(SUCCESS, n, result, details)
    ok = bool(stats["estimate"]["within"])
    return TaskOutcome(SUCCESS if ok else FAILED, n, result, details,
                       "" if ok else f"the estimate {mean:.4g} is not {_wanted(task)}")


def _wanted(task: SimbTask) -> str:
    v, e = task.desired_value, task.epsilon
    return {"MEAN": f"within {v:g} ± {e:g}", "MINIMUM": f"at least {v - e:g}",
            "MAXIMUM": f"at most {v + e:g}"}[task.estimation_type]


def _within(value: float, task: SimbTask) -> bool:
    v, e = task.desired_value, task.epsilon
    return bool({"MEAN": abs(value - v) <= e, "MINIMUM": value >= v - e,
                 "MAXIMUM": value <= v + e}[task.estimation_type])
