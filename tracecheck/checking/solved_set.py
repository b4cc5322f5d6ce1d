"""The allowed values of an operation's REAL parameters in one state, decided by the SMT
solver: for guards that are not linear in them (``a * a <= Limit``, ``a * s >= 1.0``).

:mod:`tracecheck.b.linear` computes the allowed set exactly when the guard is linear in the
parameters once the state is substituted. Where it is not, :func:`solved_set` translates the
guard (:mod:`.smt`) with the parameters as z3 reals and everything else fixed by the state:
each sub-formula that reads no parameter is evaluated by tracecheck's own evaluator and
enters as a constant. z3 (nonlinear real arithmetic) is then asked, within one time budget
for the whole state, shared by every question. What it guarantees:

* :meth:`SolvedSet.contains` is the evaluator's answer (floats, as the engine runs the
  guard), never the solver's;
* every point returned (:meth:`~SolvedSet.witness`, :meth:`~SolvedSet.nearest`) is a float
  point the evaluator allows: z3's model rounded to the nearest floats, else moved a few
  floats, towards an allowed point, or taken from a model whose neighbours are allowed too
  — whatever is returned was confirmed, never guessed;
* None ("nothing allowed") only where z3 proved it over the reals (unsat);
* ``undecided`` (:class:`~tracecheck.errors.UnsupportedError`) where z3 answers unknown,
  the budget is spent, or no float near its model passes the guard before any point is
  confirmed;
* :meth:`~SolvedSet.nearest` is within ``tolerance`` of the nearest allowed point over the
  reals where the solver answered every question (:attr:`Nearest.complete`); where the
  budget ran out first, it is the nearest allowed point found by then.

>>> from tracecheck.b import load_machine_text
>>> m = load_machine_text('''MACHINE Sq
... VARIABLES Limit
... INVARIANT Limit : REAL
... INITIALISATION Limit := 4.0
... OPERATIONS Go(a) = PRE a : REAL & a * a <= Limit THEN skip END
... END''')
>>> allowed = solved_set(m, "Go", {"Limit": 4.0}, timeout_s=5.0)
>>> print(allowed)
a: not linear; decided by the solver
>>> allowed.contains({"a": 1.5}), allowed.contains({"a": 2.5})
(True, False)
>>> abs(allowed.nearest({"a": 3.0})["a"] - 2.0) < 1e-5
True
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from fractions import Fraction
from itertools import product
from typing import Any, Callable, Mapping, Optional

from ..b.cache import Cache
from ..b import ast
from ..b.btypes import BOOL, INTEGER, REAL, Base, Pow, Prod, resolve_all
from ..b.linear import AllowedSet, guard_with_parameters, real_parameters
from ..b.memo import fresh
from ..b.narrow import NARROW, narrow_witness
from ..b.scope import kind_of
from ..b.typecheck import typecheck_formula
from ..b.values import Elem, FuncValue
from ..errors import InputError, TracecheckError, UnsupportedError, WellDefinednessError
from ..limits import deeply
from .encoding import ElementFunction, ElementSet, check_timeout, load_z3, nudge
from .smt import Translator

__all__ = ["SolvedSet", "Nearest", "solved_set", "check_solvable", "DEFAULT_BUDGET_S",
           "DEFAULT_TOLERANCE"]

#: per machine, a formula without parameters -> its compiled form (evaluated in the state)
_STATE_PARTS: Cache = Cache("solver: parts without parameters")

#: the solver's time for one state, all questions together (seconds)
DEFAULT_BUDGET_S = 0.5
#: how near the nearest allowed point is found, in the (scaled) units of the distance
DEFAULT_TOLERANCE = 1e-6
#: how many floats either way a rounded model's components are moved to find one allowed
NUDGES = 4
#: the most questions one bisection asks (each halves what is left)
MAX_QUESTIONS = 200
#: decimal digits of the rational approximation of an algebraic number z3 answers with
DIGITS = 40
#: how far (relative) a model's neighbours must be allowed too when rounding fails
INSIDE = 2.0 ** -20

_NO = object()  # a value the translation takes in its ordinary way


@dataclass
class _Clock:
    """The budget of one state: a deadline every question shares."""

    budget_s: float
    deadline: float
    questions: int = 0

    def left(self) -> float:
        return self.deadline - time.monotonic()


@dataclass(frozen=True)
class Nearest:
    """An allowed point near a proposal: ``point`` is allowed by the evaluator, ``distance``
    its distance from the proposal; no allowed point over the reals is nearer than
    ``lower`` (z3 proved it). ``complete``: ``distance - lower`` is within the tolerance —
    the solver answered every question; else ``why`` it stopped."""

    point: dict[str, float]
    distance: float
    lower: float
    complete: bool
    why: str = ""


@dataclass(frozen=True)
class SolvedSet:
    """The values of ``op``'s parameters its guard allows in one state, decided by z3 (see
    the module docstring for what is guaranteed); the interface of
    :class:`~tracecheck.b.linear.AllowedSet` a live shield and a replay use. ``low`` and
    ``high``: the finite box bounds (:meth:`within`), as (parameter, bound) pairs."""

    params: tuple[str, ...]
    op: str
    formula: Any = field(repr=False, compare=False)  # z3: guard, well-defined, definitions
    variables: Mapping[str, Any] = field(repr=False, compare=False)  # parameter -> z3 Real
    check: Callable[[Mapping[str, Any]], bool] = field(repr=False, compare=False)
    clock: _Clock = field(repr=False, compare=False)
    tolerance: float = DEFAULT_TOLERANCE
    low: tuple[tuple[str, float], ...] = ()
    high: tuple[tuple[str, float], ...] = ()
    memo: dict = field(default_factory=dict, repr=False, compare=False)
    floats: tuple[tuple[str, str], ...] = ()  # the float32 parameters (see within)

    intervals = None  # never a union of intervals: for the callers of AllowedSet
    separable = False  # not a union of boxes

    # -- the evaluator's answers
    def contains(self, point: Mapping[str, Any]) -> bool:
        """Whether the evaluator allows ``point`` (parameter -> number) within the bounds;
        a guard not well-defined there does not allow it."""
        values = {p: float(point[p]) for p in self.params}
        low, high = dict(self.low), dict(self.high)
        if not all(low.get(p, -math.inf) <= v <= high.get(p, math.inf)
                   for p, v in values.items()):
            return False
        return bool(self.check(values))

    def within(self, low: Mapping[str, Optional[float]],
               high: Mapping[str, Optional[float]],
               floats: Optional[Mapping[str, str]] = None) -> "SolvedSet":
        """The allowed values inside the box ``low[p] <= p <= high[p]`` (None, infinite or
        missing: unbounded that way) and, for :meth:`witness`, of the float type
        ``floats[p]`` (:mod:`tracecheck.b.narrow`); the same state's budget, shared."""
        lows, highs = dict(self.low), dict(self.high)
        for p in self.params:
            lo, hi = low.get(p), high.get(p)
            if lo is not None and not math.isnan(lo) and lo > -math.inf:
                lows[p] = max(float(lo), lows.get(p, -math.inf))
            if hi is not None and not math.isnan(hi) and hi < math.inf:
                highs[p] = min(float(hi), highs.get(p, math.inf))
        narrow = tuple((p, t) for p, t in (floats or {}).items() if t in NARROW)
        return replace(self, low=tuple(lows.items()), high=tuple(highs.items()), memo={},
                       floats=narrow)

    def bands(self) -> None:
        """Not a product of intervals: nothing a plot draws as bands."""
        return None

    # -- the solver's answers, confirmed by the evaluator
    def witness(self) -> Optional[dict[str, float]]:
        """A float point the evaluator allows; None when z3 proves nothing is allowed.
        ``undecided`` (UnsupportedError) where z3 gives no answer in the budget, or no
        float near its model passes the guard."""
        if "witness" in self.memo:
            return self.memo["witness"]
        if self.floats:  # values of the space's float type: near the float one, or none
            wide = replace(self, floats=(), memo=dict(self.memo))  # its witness its own
            found = wide.witness()
            self.memo.update((k, v) for k, v in wide.memo.items() if k != "witness")
            found = narrow_witness(self, found, dict(self.floats), None)
            self.memo["witness"] = found  # only once decided (undecided raises)
            return found
        exact = self._some_model()
        found = None
        if exact is not None:
            found = self._confirm(exact)
            if found is None:
                found = self._inside_model(exact)
            if found is None:
                shown = ", ".join(f"{p} = {float(exact[p])!r}" for p in self.params)
                raise self._undecided(
                    f"z3 finds values allowed over the reals ({shown}), but no float near "
                    "them passes the guard in the evaluator's float arithmetic")
        self.memo["witness"] = found
        return found

    def nearest(self, point: Mapping[str, Any],
                scale: Optional[Mapping[str, float]] = None) -> Optional[dict[str, float]]:
        """An allowed float point nearest ``point`` (see :meth:`nearest_result`); None
        only when z3 proves nothing is allowed."""
        found = self.nearest_result(point, scale)
        return None if found is None else found.point

    def nearest_result(self, point: Mapping[str, Any],
                       scale: Optional[Mapping[str, float]] = None) -> Optional[Nearest]:
        """The allowed float point nearest ``point`` (Euclidean, each component's difference
        divided by ``scale[p]``): ``point`` itself if the evaluator allows it; else by
        bisection on the radius r — z3 asked whether the guard allows a value within r —
        each model turned into a float point the evaluator confirms. The point returned is
        always allowed; it is within :attr:`tolerance` of the nearest over the reals where
        :attr:`Nearest.complete`. None only when z3 proves nothing is allowed; undecided
        (UnsupportedError) when no point was confirmed in the budget."""
        x, s = self._proposal(point), self._scales(scale)
        if self.contains(x):
            return Nearest(dict(x), 0.0, 0.0, True)
        start = self.witness()
        if start is None:
            return None
        best = [start, _distance(start, x, s)]

        def seen(exact: dict[str, Fraction]) -> None:
            found = self._confirm(exact, towards=best[0])
            if found is not None and _distance(found, x, s) < best[1]:
                best[:] = [found, _distance(found, x, s)]
        lo, _, why = self._bisect(x, s, best[1], seen)
        tolerance = _tolerance(self.tolerance, best[1])
        return Nearest(best[0], best[1], lo, not why and best[1] - lo <= tolerance,
                       why or ("" if best[1] - lo <= tolerance else
                               "no float near the solver's nearer points passes the guard"))

    def distance(self, point: Mapping[str, Any],
                 scale: Optional[Mapping[str, float]] = None) -> Optional[float]:
        """How far ``point`` lies from the allowed set over the reals (to its closure; 0
        inside), within :attr:`tolerance` above the exact distance (bisection on what z3
        proves); None when z3 proves nothing is allowed; undecided (UnsupportedError)
        when the budget runs out before the tolerance is reached."""
        x, s = self._proposal(point), self._scales(scale)
        if self.contains(x):
            return 0.0
        exact = self._some_model()
        if exact is None:
            return None
        lo, up, why = self._bisect(x, s, _distance(exact, x, s))
        if why:
            raise self._undecided(f"the solver could not narrow the distance of {_shown(x)} "
                                  f"to the allowed set to {self.tolerance!r} ({why}); it lies "
                                  f"between {lo!r} and {up!r}")
        return up

    def contains_exact(self, point: Mapping[str, Any]) -> bool:
        """Whether the guard allows ``point`` over the reals (z3's answer; undecided where
        it gives none)."""
        z3 = load_z3()
        x = self._proposal(point)
        verdict, _, why = self._ask([self.variables[p] == z3.RealVal(Fraction(x[p]))
                                     for p in self.params])
        if verdict == "unknown":
            raise self._undecided(f"the solver could not tell whether {_shown(x)} is "
                                  f"allowed over the reals ({why})")
        return verdict == "sat"

    def __str__(self) -> str:
        bounds = []
        low, high = dict(self.low), dict(self.high)
        for p in self.params:
            if p in low or p in high:
                bounds.append(f"{p} ∈ [{low.get(p, -math.inf)!r}, {high.get(p, math.inf)!r}]")
        shown = self.params[0] if len(self.params) == 1 else f"({', '.join(self.params)})"
        within = f" (searched within the action space: {', '.join(bounds)})" if bounds else ""
        return f"{shown}: not linear; decided by the solver{within}"

    # -- questions to z3
    def _ask(self, extra=()) -> tuple[str, Any, str]:
        """Whether the guard (within the bounds) and ``extra`` are satisfiable, in what is
        left of the budget: ("sat", model, ""), ("unsat", None, "") or ("unknown", None,
        why)."""
        z3 = load_z3()
        left = self.clock.left()
        if left <= 0:
            return "unknown", None, f"the budget of {self.clock.budget_s} s is spent"
        why = ""
        for make in (_nlsat, _general):  # nlsat first: the fastest for a few reals
            left = self.clock.left()
            if left <= 0:
                break
            solver = make(z3)
            solver.set("timeout", max(1, int(left * 1000)))
            try:
                solver.add(self.formula, *self._box(), *extra)
                verdict = solver.check()
                why = "" if verdict in (z3.sat, z3.unsat) else solver.reason_unknown()
            except z3.Z3Exception as exc:  # pragma: no cover - z3 canceled while asserting
                verdict, why = z3.unknown, str(exc)
            self.clock.questions += 1
            if verdict == z3.sat:
                return "sat", solver.model(), ""
            if verdict == z3.unsat:
                return "unsat", None, ""
            if why in ("canceled", "timeout"):
                break
        if why in ("canceled", "timeout", "") or self.clock.left() <= 0:
            why = f"the budget of {self.clock.budget_s} s ran out"
        return "unknown", None, why

    def _box(self) -> list:
        z3 = load_z3()
        return [self.variables[p] >= z3.RealVal(Fraction(v)) for p, v in self.low] + \
            [self.variables[p] <= z3.RealVal(Fraction(v)) for p, v in self.high]

    def _some_model(self) -> Optional[dict[str, Fraction]]:
        """Some allowed point over the reals (exact), None when z3 proves there is none."""
        if "model" not in self.memo:
            verdict, model, why = self._ask()
            if verdict == "unknown":
                raise self._undecided(f"the solver could not tell whether any value is "
                                      f"allowed ({why})")
            exact = None if verdict == "unsat" else self._exact(model)
            if verdict == "sat" and exact is None:
                raise self._undecided("z3's model lies beyond the floats")
            self.memo["model"] = exact
        return self.memo["model"]

    def _exact(self, model) -> Optional[dict[str, Fraction]]:
        """The model's value of each parameter as a rational (an algebraic number to
        :data:`DIGITS` digits); None when one is beyond floats."""
        z3 = load_z3()
        out = {}
        for p, v in self.variables.items():
            value = model.eval(v, model_completion=True)
            if z3.is_algebraic_value(value):
                value = value.approx(DIGITS)
            if not (z3.is_rational_value(value) or z3.is_int_value(value)):
                return None  # pragma: no cover - a real parameter's value is a number
            out[p] = Fraction(value.numerator_as_long(), value.denominator_as_long())
            if not math.isfinite(_as_float(out[p])):
                return None
        return out

    def _confirm(self, exact: Mapping[str, Fraction],
                 towards: Optional[dict[str, float]] = None) -> Optional[dict[str, float]]:
        """A float point the evaluator allows near the exact ``exact``: its nearest floats;
        else those up to :data:`NUDGES` floats away; else (given an allowed point
        ``towards``) the allowed point nearest it on the segment to that one; else None."""
        rounded = {p: _as_float(exact[p]) for p in self.params}
        if self.contains(rounded):
            return rounded
        k = len(self.params)
        signs = [s for s in product((-1, 0, 1), repeat=k) if any(s)] if k <= 4 else \
            [tuple(d if j == i else 0 for j in range(k)) for i in range(k) for d in (-1, 1)]
        for steps in range(1, NUDGES + 1):
            for sign in signs:
                moved = {p: nudge(rounded[p], d * steps) for p, d in zip(self.params, sign)}
                if self.contains(moved):
                    return moved
        if towards is None:
            return None
        return AllowedSet(self.params, (), self.contains).towards(rounded, dict(towards))

    def _inside_model(self, near: Mapping[str, Fraction]) -> Optional[dict[str, float]]:
        """A model whose neighbours a relative :data:`INSIDE` away along each axis are
        allowed too (over the reals), then confirmed: for a model on the boundary."""
        z3 = load_z3()
        shifted = []
        for p, v in self.variables.items():
            step = z3.RealVal(Fraction(INSIDE) * max(Fraction(1), abs(near[p])))
            for moved in (v + step, v - step):
                shifted.append(z3.substitute(self.formula, (v, moved)))
        verdict, model, _ = self._ask(shifted)
        exact = self._exact(model) if verdict == "sat" else None
        return None if exact is None else self._confirm(exact)

    def _ball(self, x: Mapping[str, float], s: Mapping[str, float], r: float):
        z3 = load_z3()
        terms = [(self.variables[p] - z3.RealVal(Fraction(x[p]))) ** 2
                 * z3.RealVal(1 / Fraction(s[p]) ** 2) for p in self.params]
        return z3.Sum(terms) <= z3.RealVal(Fraction(r)) ** 2

    def _bisect(self, x, s, up: float, seen: Optional[Callable] = None
                ) -> tuple[float, float, str]:
        """Narrow ``[lo, up]``, which holds the distance of ``x`` to the allowed set over
        the reals (``up``: that of a known allowed point), by asking z3 for an allowed
        value within the middle radius; ``seen(exact)`` with each model. (lo, up, why it
        stopped before the tolerance: "" when it did not)."""
        lo = 0.0
        for _ in range(MAX_QUESTIONS):
            if up - lo <= _tolerance(self.tolerance, up):
                return lo, up, ""
            r = (lo + up) / 2
            if not lo < r < up:
                return lo, up, ""  # the floats between them are spent
            verdict, model, why = self._ask([self._ball(x, s, r)])
            if verdict == "unsat":
                lo = r
                continue
            exact = self._exact(model) if verdict == "sat" else None
            if exact is None:
                return lo, up, why or "z3's model is beyond floats"
            up = max(lo, min(r, _distance(exact, x, s)))
            if seen is not None:
                seen(exact)
        return lo, up, f"{MAX_QUESTIONS} questions asked"

    def _proposal(self, point: Mapping[str, Any]) -> dict[str, float]:
        try:
            x = {p: float(point[p]) for p in self.params}
        except (KeyError, TypeError, ValueError):
            raise InputError(f"a point of {self.op} gives a number for each of its "
                             f"parameters {', '.join(self.params)}, not {dict(point)!r}"
                             ) from None
        if not all(math.isfinite(v) for v in x.values()):
            raise InputError(f"the point {_shown(x)} of {self.op} is not finite")
        return x

    def _scales(self, scale: Optional[Mapping[str, float]]) -> dict[str, float]:
        s = {p: float((scale or {}).get(p, 1.0)) for p in self.params}
        if not all(math.isfinite(v) and v > 0 for v in s.values()):
            raise InputError(f"the scale of each parameter of {self.op} must be a positive "
                             f"number, not {s}")
        return s

    def _undecided(self, what: str) -> UnsupportedError:
        return UnsupportedError(
            f"undecided for {self.op} in this state: {what}; tracecheck does not guess",
            hint="write the guard linear in its parameters once the state is known, or so "
                 "that floats can meet it (an equation such as a * a = 2.0 has no float "
                 "solution); from Python, give the solver more time per state "
                 "(ContinuousShield(solver_timeout_s=…), solved_set(timeout_s=…)); "
                 "docs/continuous.md")


@deeply
def solved_set(machine, op_name: str, state: Optional[Mapping[str, Any]] = None, *,
               env: Optional[dict] = None, timeout_s: float = DEFAULT_BUDGET_S,
               tolerance: float = DEFAULT_TOLERANCE) -> SolvedSet:
    """The values of ``op_name``'s REAL parameters its guard allows in ``state`` (or in an
    environment made by ``machine.env``), decided by z3 in ``timeout_s`` seconds for every
    question about this state together (the clock starts here).

    Raises :class:`UnsupportedError` naming the construct when the guard cannot be
    translated for the solver (:func:`check_solvable` says so before any state)."""
    budget = check_timeout(timeout_s, "the solver's time per state")
    clock = _Clock(budget, time.monotonic() + budget)
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance)
            and tolerance > 0):
        raise InputError(f"the tolerance must be a positive number, not {tolerance!r}")
    op = _real_operation(machine, op_name)
    local = fresh(machine.env(state or {}) if env is None else env)
    variables, formula = _translate(machine, op, local)
    guard = guard_with_parameters(machine, op_name)

    def check(point: Mapping[str, float]) -> bool:
        bound = dict(local)  # the remembered values shared: none depends on a parameter
        bound.update(point)
        try:
            return bool(guard(bound))
        except WellDefinednessError:
            return False
    return SolvedSet(tuple(op.params), op_name, formula, variables, check, clock,
                     float(tolerance))


@deeply
def check_solvable(machine, op_name: str) -> None:
    """Before any state: raise :class:`UnsupportedError` (naming the construct and where)
    when :func:`solved_set` could not translate ``op_name``'s guard in any state. Each
    sub-formula that reads no parameter stands for its value (a fresh solver variable of
    its type), as a state's value will."""
    _translate(machine, _real_operation(machine, op_name), None)


def _real_operation(machine, op_name: str):
    op = machine.operation(op_name)
    if not real_parameters(op):
        raise UnsupportedError(f"{op_name} has no parameters typed `p : REAL` in its guard")
    return op


def _translate(machine, op, env: Optional[dict]) -> tuple[dict, Any]:
    """The parameters' solver reals and the formula of the allowed values: the guard, its
    well-definedness and the translation's definitions."""
    translator = _GuardTranslator(machine, op.params, env)
    variables = translator.parameters(op.name)
    try:
        guard, defined = translator.defined(lambda: translator.pred(op.guard, variables))
    except UnsupportedError as exc:
        raise UnsupportedError(f"the solver cannot decide {op.name}'s guard: {exc.message}",
                               file=exc.file, line=exc.line, column=exc.column,
                               source=exc.source,
                               hint="write that part without the parameters, or the guard "
                                    "linear in them (docs/continuous.md)") from None
    z3 = translator.z3
    return variables, z3.And(defined, guard, *translator.side_conditions)


class _NoVariables:
    """A machine seen without its variables: the translator encodes none up front (each
    is read where the guard reads it, by :class:`_GuardTranslator`)."""

    variables: tuple = ()

    def __init__(self, machine) -> None:
        self._machine = machine

    def __getattr__(self, name: str) -> Any:
        return getattr(self._machine, name)


class _GuardTranslator(Translator):
    """Translates a guard over its parameters: a sub-formula that reads neither a
    parameter nor a name bound inside the guard is its value in ``env`` (the engine's,
    as a constant), or without a state a fresh solver variable of its type."""

    def __init__(self, machine, params, env: Optional[dict]) -> None:
        super().__init__(_NoVariables(machine))
        self.machine = machine
        self.params, self.env = frozenset(params), env
        self.names: dict = {}  # free names by node
        self.made = 0  # fresh variables so far

    def translate(self, node: ast.Node, env: dict) -> Any:
        if not (ast.free_names(node, self.names) & (self.params | env.keys())):
            value = self.fixed(node)
            if value is not _NO:
                return value
        return super().translate(node, env)

    def fixed(self, node: ast.Node) -> Any:
        """The translation of a sub-formula without parameters (:data:`_NO`: translate it
        as usual); one not well-defined in the state is a fresh variable and makes the
        guard not well-defined where it is reached. Without a state, one that reads a name
        is a fresh variable of its type, one of literals alone (``1..3``) its value."""
        env = self.env
        if env is None:  # before any state: what reads a name may be any value of its type,
            if ast.free_names(node, self.names):  # a formula of literals is its value
                return self.opaque(node)
            env = {}
        machine = self.machine
        try:
            fn = machine.cached(_STATE_PARTS, node,
                                lambda: machine.compiler().compile(node))
            value = fn(env)
        except WellDefinednessError:
            made = self.opaque(node)
            if made is not _NO:
                self._need(self.z3.BoolVal(False), node)
            return made
        except TracecheckError:
            return _NO
        return self.constant_of(value, node)

    def type_of(self, node: ast.Node):
        try:
            return resolve_all(typecheck_formula(node, self.machine.type_objects,
                                                 kind=kind_of(node),
                                                 source=self.machine.source))
        except TracecheckError:
            return None

    def constant_of(self, value: Any, node: ast.Node) -> Any:
        z3 = self.z3
        if isinstance(value, (bool, int, float)):
            if isinstance(value, float) and not math.isfinite(value):
                raise self.fail(node, f"{value!r} (the value here, not finite)")
            return _scalar(z3, value)
        if isinstance(value, Elem):
            return value
        t = self.type_of(node) if isinstance(value, frozenset) else None
        if not isinstance(t, Pow):
            return _NO
        sets = self.machine.sets
        if isinstance(t.elem, Base) and t.elem.name in sets:
            return ElementSet(t.elem.name, {e: z3.BoolVal(e in value)
                                            for e in sets[t.elem.name]})
        if isinstance(t.elem, Prod) and isinstance(t.elem.left, Base) and \
                t.elem.left.name in sets and t.elem.right in (REAL, INTEGER, BOOL):
            pairs = value.map if isinstance(value, FuncValue) else dict(value)
            if len(pairs) != len(value):
                return _NO  # a relation, not a function
            zero = {REAL: 0.0, INTEGER: 0, BOOL: False}[t.elem.right]
            return ElementFunction(t.elem.left.name, {
                e: (z3.BoolVal(e in pairs), _scalar(z3, pairs.get(e, zero)))
                for e in sets[t.elem.left.name]})
        return _NO

    def opaque(self, node: ast.Node) -> Any:
        """A fresh solver variable of ``node``'s type (an element: one of its set's)."""
        z3, t = self.z3, self.type_of(node)
        self.made += 1
        name = f"#{self.made}"
        make = {REAL: z3.Real, INTEGER: z3.Int, BOOL: z3.Bool}
        if t in make:
            return make[t](name)
        sets = self.machine.sets
        if isinstance(t, Base) and sets.get(t.name):
            return sets[t.name][0]
        if isinstance(t, Pow) and isinstance(t.elem, Base) and t.elem.name in sets:
            return ElementSet(t.elem.name, {e: z3.Bool(f"{name}[{e}]")
                                            for e in sets[t.elem.name]})
        if isinstance(t, Pow) and isinstance(t.elem, Prod) and isinstance(t.elem.left, Base) \
                and t.elem.left.name in sets and t.elem.right in make:
            return ElementFunction(t.elem.left.name, {
                e: (z3.Bool(f"{name}[{e}]?"), make[t.elem.right](f"{name}[{e}]"))
                for e in sets[t.elem.left.name]})
        return _NO


def _nlsat(z3) -> Any:
    """A solver by z3's tactic for nonlinear real arithmetic (quantifier-free)."""
    tactic = _TACTICS.get("nlsat")
    if tactic is None:
        tactic = _TACTICS["nlsat"] = z3.Tactic("qfnra-nlsat")
    return tactic.solver()


def _general(z3) -> Any:
    """z3's own choice of solver (where nlsat gives up: integers, say)."""
    return z3.Solver()


_TACTICS: dict = {}


def _scalar(z3, value: Any) -> Any:
    if isinstance(value, bool):
        return z3.BoolVal(value)
    if isinstance(value, int):
        return z3.IntVal(value)
    return z3.RealVal(Fraction(value))


def _as_float(x: Fraction) -> float:
    try:
        return float(x)
    except OverflowError:
        return math.inf


def _distance(point: Mapping[str, Any], x: Mapping[str, float],
              s: Mapping[str, float]) -> float:
    return math.sqrt(sum(((float(point[p]) - x[p]) / s[p]) ** 2 for p in x))


def _tolerance(tolerance: float, magnitude: float) -> float:
    """The tolerance, but not below what floats of ``magnitude`` resolve."""
    return max(tolerance, 4 * math.ulp(magnitude))


def _shown(x: Mapping[str, float]) -> str:
    return "(" + ", ".join(f"{p} = {v!r}" for p, v in x.items()) + ")"
