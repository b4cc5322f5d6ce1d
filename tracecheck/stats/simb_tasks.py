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
when it has its executions.

Every task with fewer executions than its ``EXECUTIONS`` is *not run*: a verdict on other
executions than SimB's is never given. Each execution is cut as SimB's starting and ending
conditions say, counting transitions as SimB does (:func:`spans`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..b.parser import parse_formula
from ..b.scope import EXPR, PRED, check_kind
from ..episodes.columns import episode_columns, take_episodes
from ..episodes.model import Episode
from ..errors import TracecheckError
from .estimates import evaluate_run, prepare, run_statistics
from .properties import HypothesisTest, Metric, Property, PropertySet

__all__ = ["SimbTask", "Window", "Span", "TaskOutcome", "evaluate_task", "task_columns",
           "simb_hypothesis", "window", "spans", "has_setup", "unsupported", "CUT",
           "CHECKING_TYPES", "PREDICATE_TYPES", "VALUE_TYPES", "SIMULATION_TYPES",
           "HYPOTHESIS", "ESTIMATION", "MONTE_CARLO", "SUCCESS", "FAILED", "NOT_RUN"]

SUCCESS, FAILED, NOT_RUN = "success", "failed", "not run"
HYPOTHESIS, ESTIMATION, MONTE_CARLO = "HYPOTHESIS_TEST", "ESTIMATION", "MONTE_CARLO_SIMULATION"
SIMULATION_TYPES = (HYPOTHESIS, ESTIMATION, MONTE_CARLO)
#: the end reason of an episode a script run cut at an ending condition
CUT = "time-limit"

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
    return {key: np.asarray(formulas.properties[key](states), dtype=bool) for key in named}


def has_setup(machine) -> bool:
    """Whether SimB's executions of ``machine`` start with a ``$setup_constants`` transition
    (ProB adds one when the machine has CONSTANTS or PROPERTIES)."""
    return bool(getattr(machine, "constants_declared", ())) or \
        getattr(machine, "properties_node", None) is not None


@dataclass(frozen=True)
class Span:
    """One execution as SimB cuts it, in the episode's state indices: ``first`` … ``last``
    the states its properties are judged on (first > last: none); ``end`` the execution's
    last state (what a final predicate is judged on); ``start_time`` SimB's ``startAtTime``
    in ms (None: the starting condition was never met); ``short``: the episode ended before
    the task's ending condition did."""

    first: int
    last: int
    end: int
    start_time: Optional[float]
    short: bool


def window(w: Window, episodes: Sequence[Episode], machine, seed: int = 0
           ) -> list[tuple[int, int]]:
    """Per episode, the states (first, last) its properties are judged on, as SimB cuts an
    execution; first > last where none are (see :func:`spans`)."""
    return [(s.first, s.last) for s in spans(w, episodes, machine, seed)]


def spans(w: Window, episodes: Sequence[Episode], machine, seed: int = 0, *,
          columns=None) -> list[Span]:
    """Per episode, its :class:`Span` as ProB2-UI's ``SimulationCheckingSimulator`` and
    ``SimulationPropertyChecker`` cut it.

    SimB counts transitions: T is the number done so far (0 before the first;
    ``$setup_constants`` is transition 0 when the machine has constants, c = 1, else c = 0),
    so episode state j is the destination of transition j + c. After each transition (and
    once before the first) from T = m on — m drawn from 0 … ``max_steps_before`` − 1
    (``MAX_STEPS_BEFORE_PROPERTY``; numpy's generator with ``seed``) — it tests the starting
    condition and, the first time it holds, sets ``startAtStep`` = T and ``startAtTime`` =
    the clock: T ≥ ``start_after_steps``; ``starting_predicate`` holds in the state reached
    (state T − 1 − c); ``starting_predicate_activated`` became true there; the clock is at
    least ``starting_time``; without a condition at once. Properties are judged on the
    transitions from index ``startAtStep`` on: states from T − c on — the state where a
    starting predicate first holds is not itself judged. The execution ends (once started,
    SimB's order) when T reaches ``startAtStep`` + ``steps_per_execution``, in the first
    state from the one the start was detected in on where ``ending_predicate`` holds, or
    with the last state at most ``ending_time`` ms after ``startAtTime``; else with the
    episode. ``columns``: those of ``episodes`` (:func:`task_columns`), where the caller has
    them (``episodes`` is then not read).
    """
    rng = np.random.default_rng(seed)
    c = 1 if has_setup(machine) else 0
    cols = columns if columns is not None else task_columns(episodes) if episodes else None
    values = _predicates(w, machine, cols) if cols is not None else {}
    out = []
    for i in range(0 if cols is None else len(cols.episode_ids)):
        lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
        n = hi - lo
        times = cols.time[lo:hi] * 1000.0
        least = int(rng.random() * w.max_steps_before) if w.max_steps_before > 0 else 0
        found = _start_step(w, {k: v[lo:hi] for k, v in values.items()}, times, n, c, least)
        if found is None:
            out.append(Span(n, n - 1, n - 1, None, False))
            continue
        first = max(found - c, 0)
        clock = _clock(times, found, c)
        end, short = _end(w, values.get("ending_predicate"), lo, hi, times, found, c, clock)
        out.append(Span(first, end, max(end, 0), clock, short))
    return out


def _clock(times: np.ndarray, t: int, c: int) -> float:
    """SimB's clock after ``t`` transitions: the time of the state the last one reached
    (0 before the first)."""
    return 0.0 if t == 0 else float(times[max(t - 1 - c, 0)])


def _start_step(w: Window, values: dict, times: np.ndarray, n: int, c: int, least: int
                ) -> Optional[int]:
    """The number of transitions after which SimB's starting condition first holds (from
    ``least`` on); None when it never does within the episode's n + c transitions."""
    total = n + c
    steps = np.arange(total + 1)  # T = 0 … n + c
    state = steps - 1 - c  # the state reached after T transitions (< 0: not initialised)
    ok = steps >= least
    if w.start_after_steps is not None:
        ok &= steps >= w.start_after_steps
    elif w.starting_predicate is not None:
        now = values["starting_predicate"]
        ok &= (state >= 0) & now[np.clip(state, 0, None)]
    elif w.starting_predicate_activated is not None:
        now = values["starting_predicate_activated"]
        before = np.concatenate([[True], now[:-1]])  # state 0 has no initialised predecessor
        ok &= (state >= 0) & now[np.clip(state, 0, None)] & ~before[np.clip(state, 0, None)]
    elif w.starting_time is not None:
        clocks = np.array([_clock(times, t, c) for t in steps])
        ok &= clocks >= w.starting_time
    hits = np.flatnonzero(ok)
    return int(hits[0]) if len(hits) else None


def _end(w: Window, ending: Optional[np.ndarray], lo: int, hi: int, times: np.ndarray,
         found: int, c: int, clock: float) -> tuple[int, bool]:
    """(the execution's last state, whether the episode ended before SimB's ending
    condition did) once started after ``found`` transitions."""
    last = hi - lo - 1
    if w.steps_per_execution is not None:
        end = found + w.steps_per_execution - 1 - c
        return min(end, last), end > last
    if w.ending_predicate is not None:
        since = max(found - 1 - c, 0)
        hits = np.flatnonzero(ending[lo + since:hi])
        return (since + int(hits[0]), False) if len(hits) else (last, True)
    if w.ending_time is not None:
        inside = np.flatnonzero(times <= clock + w.ending_time + 1e-6)
        end = int(inside[-1]) if len(inside) else last
        return end, end == last and times[last] < clock + w.ending_time - 1e-6
    return last, False


def _actions(episodes: Sequence[Episode]) -> list[str]:
    return sorted({s.action for ep in episodes for s in ep.steps if s.action is not None})


def task_columns(episodes: Sequence[Episode]):
    """The columns of ``episodes`` as :func:`evaluate_task` reads them: built once, they
    serve every task on the same executions (a project's tasks on one folder of traces)."""
    return episode_columns(episodes, _actions(episodes))


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
                  seed: int = 0, where: str = "the task", run_cut: bool = False,
                  columns=None) -> TaskOutcome:
    """``task`` on ``episodes`` (its first ``task.executions`` when set), judged on the
    states :func:`spans` gives, against ``machine``'s names. ``run_cut``: the episodes come
    from a run that cut them at an ending condition (end reason :data:`CUT`); one cut
    before the task's own ending condition makes the task *not run*. A formula tracecheck cannot
    read or evaluate, fewer executions than the task asks for, or a value SimB would only
    give as a sentinel give the outcome *not run* with the reason (naming ``where``), never
    an exception and never a verdict on other executions than SimB's. ``columns``: the
    executions as columns (:func:`task_columns`), where the caller keeps them for many
    tasks (``episodes`` is then not read)."""
    why = unsupported(task)
    if why:
        return TaskOutcome(NOT_RUN, reason=why)
    if columns is None:
        episodes = list(episodes)
        columns = task_columns(episodes) if episodes else None
    total = 0 if columns is None else len(columns.episode_ids)
    wanted = task.executions
    if wanted is not None and wanted < total:
        columns = take_episodes(columns, [(0, int(k)) for k in np.diff(columns.starts)[:wanted]])
        total = wanted
    n = total
    if wanted is not None and n < wanted:
        return TaskOutcome(NOT_RUN, n, reason=f"only {n} of the {wanted} executions the task "
                                              "asks for")
    if not n:
        return TaskOutcome(NOT_RUN, reason="no executions to judge")
    if task.kind == MONTE_CARLO:
        return _monte_carlo(columns, wanted)
    try:
        return _judge(task, columns, machine, seed, where, run_cut)
    except TracecheckError as exc:
        return TaskOutcome(NOT_RUN, n, reason=f"tracecheck cannot evaluate it: {exc.render()}")


def _monte_carlo(columns, wanted: Optional[int]) -> TaskOutcome:
    steps = np.diff(columns.starts) - 1
    n = len(steps)
    mean = float(np.mean(steps))
    details = {"executions": n, "wanted": wanted, "mean_steps": mean}
    return TaskOutcome(SUCCESS, n, f"{n} executions, {mean:.4g} steps on average", details)


def _judge(task: SimbTask, columns, machine, seed: int, where: str,
           run_cut: bool) -> TaskOutcome:
    evaluated, reported = _property_set(task, machine, where)
    n = len(columns.episode_ids)
    cuts = spans(task.window, (), machine, seed, columns=columns)
    cut_short = sum(1 for s, reason in zip(cuts, columns.reasons)
                    if run_cut and s.short and reason == CUT)
    if cut_short:
        return TaskOutcome(NOT_RUN, n, reason=(
            f"{cut_short} of {n} executions were cut (the run's ending "
            "condition) before this task's ending condition was reached, so SimB would judge "
            "more states: give its traces with --traces, or run its simulation alone"))
    started = np.array([s.first <= s.last for s in cuts], dtype=bool)
    between = VALUE_TYPES.get(task.checking_type, "").endswith("between_steps")
    cols = take_episodes(columns, [(max(s.first - between, 0), s.last + 1) if s.first <= s.last
                                   else (s.end, s.end + 1) for s in cuts])
    name = _field(task)
    run = evaluate_run(where, evaluated, prepare(evaluated, machine=machine), name, cols)
    if task.checking_type == "TIMING":
        firsts = columns.starts.tolist()
        duration = np.array([(float(columns.time[first + s.end]) * 1000.0 - s.start_time)
                             if s.start_time is not None else -math.inf
                             for first, s in zip(firsts, cuts)])
        run.properties[name] = duration <= task.time + 1e-6
    _unstarted(run, task, started, name)
    sentinel = _sentinel(task, run, name)
    if sentinel:
        return TaskOutcome(NOT_RUN, n, reason=sentinel)
    stats = run_statistics(run, reported)
    details = {"executions": n, "not_started": int(np.sum(~started)), **stats}
    if reported.properties:
        return _predicate_verdict(task, stats["properties"][name], details)
    return _value_verdict(task, stats["metrics"][name], details)


def _unstarted(run, task: SimbTask, started: np.ndarray, name: str) -> None:
    """SimB's values for executions that judge no state (the starting condition never met,
    or an empty window): an invariant holds, an eventually does not, a final predicate is
    judged on the execution's last state; averages and sums are 0, least and greatest values
    none (NaN: see :func:`_sentinel`)."""
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


def _sentinel(task: SimbTask, run, name: str) -> str:
    """Why a least or greatest value cannot be estimated ("" when it can): SimB gives an
    execution with no state (no step, for the between-steps types) to take it over
    Double.MAX_VALUE as its least value and Double.MIN_VALUE (the least positive double)
    as its greatest — sentinels, not values, which tracecheck does not average."""
    if name not in run.metrics or not VALUE_TYPES[task.checking_type].startswith(("min",
                                                                                  "max")):
        return ""
    none = int(np.sum(np.isnan(run.metrics[name].astype(float))))
    if not none:
        return ""
    what = "no step" if task.checking_type.endswith("BETWEEN_STEPS") else "no state"
    least = task.checking_type.startswith("MINIMUM")
    return (f"{none} of {len(run.metrics[name])} executions judge {what} (the starting "
            "condition is never met, or their window is empty), so they have no "
            f"{'least' if least else 'greatest'} value; SimB counts "
            f"{'Double.MAX_VALUE' if least else 'Double.MIN_VALUE'} for them, a sentinel "
            "tracecheck does not average: narrow the task's starting or ending condition")


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
