"""Obligations over every state, decided by an SMT solver (z3) on the translation of
:mod:`.smt`: deadlock freedom, implications, well-defined guards (:func:`prove`) and the
per-operation difference of two shields (:func:`symbolic_diff`).

Nothing here may pass wrongly:

* every formula a user gives is parsed and type-checked in the machine's scope, as
  ``eval --model`` does, before the solver sees any (:meth:`Machine.check_formula`);
* before any obligation, some state must satisfy the invariant and assumptions — if none
  does, every obligation is ``vacuous``, never ``proved``;
* a claim's own well-definedness is part of the claim (``1 / 0 = 7`` is ``not
  well-defined``), and a guard that is not well-defined in a state does not enable its
  operation there (deadlock freedom, the diff) — tracecheck's evaluator, which raises on
  such a guard, is read the same way when it confirms a counterexample;
* the symbolic diff covers every operation of either shield.

A counterexample is turned into a state and evaluated again by tracecheck's own evaluator
before it is reported; where the two disagree, that is said (the CLI raises
:class:`~tracecheck.errors.Disagreement`). What a user asks for is in :mod:`.obligations`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Callable, Optional, Union

from ..b.linear import real_parameters
from .deadline import interrupted_at
from ..errors import InputError, TracecheckError, UnsupportedError, WellDefinednessError
from ..limits import deeply
from .obligations import Given
from .encoding import (MAX_TIMEOUT_S, ElementFunction, ElementSet, ElementTerm, FiniteFunction,
                       check_timeout, load_z3,
                       state_of_model)
from .shield import Shield
from .smt import Translator

__all__ = ["prove", "symbolic_diff", "Result", "Describe", "Bounds", "unbounded_parameters",
           "check_timeout",
           "PROVED", "EQUIVALENT", "COUNTEREXAMPLE", "NOT_DEFINED", "UNKNOWN", "VACUOUS"]

PROVED, EQUIVALENT, COUNTEREXAMPLE = "proved", "equivalent", "counterexample"
NOT_DEFINED, UNKNOWN, VACUOUS = "not well-defined", "unknown", "vacuous"
ONLY_IN = "only in "  # + the shield: an operation the other shield does not have

#: How a counterexample state reads for people, in one line (None: as its variables'
#: values): an environment's :meth:`~tracecheck.live.adapter.EnvAdapter.describe`.
Describe = Callable[[dict], Optional[str]]
#: an action space's bounds of operations' REAL parameters: ``{op: ({p: low}, {p: high})}``
#: (a side without a bound left out), as the live shield and replay take them
Bounds = dict



@dataclass
class Result:
    """One obligation: proved, counterexample, not well-defined, unknown (with the solver's
    reason) or vacuous; for the diff equivalent or only in one shield."""

    obligation: str
    status: str
    reason: str = ""
    state: Optional[dict] = None  # the counterexample, as B values
    reading: str = ""
    disagreement: str = ""  # where tracecheck's evaluator does not confirm the solver
    extra: dict = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        """A counterexample, a claim that is not well-defined, an operation one shield
        lacks: what makes ``prove`` and ``diff --symbolic`` exit 1."""
        return self.status in (COUNTEREXAMPLE, NOT_DEFINED) or self.status.startswith(ONLY_IN)


def _ms(seconds: float) -> int:
    return max(1, min(int(seconds * 1000), MAX_TIMEOUT_S * 1000))


# ------------------------------------------------------------------ the solver


@dataclass
class _Context:
    """What every obligation of one run shares: the translation, the machines whose
    invariants a counterexample must satisfy, the constraints every state satisfies, how
    a counterexample reads."""

    translator: Translator
    machines: tuple
    base: list
    timeout_s: float
    describe: Optional[Describe] = None


@dataclass
class _Finding:
    """What a model of an obligation's constraints shows, and how tracecheck's evaluator
    confirms it in the state (``confirm(state)``; it may raise for a state it cannot
    evaluate)."""

    status: str
    meaning: str
    confirm: Callable[[dict], bool]


def _ask(z3, solver, seconds: float, add: Callable[[], None]) -> tuple[object, str]:
    """``add()`` the question to ``solver`` and check it, the two together within
    ``seconds`` of wall time: (verdict, why unknown).

    z3's own ``timeout`` counts only in ``check()``, but z3 already rewrites a term while it
    is asserted — for a huge term that alone took minutes and gigabytes — so a timer
    interrupts z3's context at the deadline, whatever it is doing then, and a question whose
    time went into asserting it is ``unknown (timeout)`` without a check.
    """
    deadline = time.monotonic() + seconds
    with interrupted_at(z3, seconds):
        try:
            add()
            left = deadline - time.monotonic()
            if left <= 0:
                return z3.unknown, "timeout"
            solver.set("timeout", _ms(left))
            verdict = solver.check()
            return verdict, "" if verdict in (z3.sat, z3.unsat) else _why(solver)
        except z3.Z3Exception as exc:  # z3 canceled while asserting
            return z3.unknown, "timeout" if time.monotonic() >= deadline else str(exc)


def _solve(translator: Translator, constraints: list, timeout_s: float):
    """Check ``constraints`` (with the translator's definitions) within ``timeout_s``. A
    model is then made smaller in what is left of that time (at most 1 s): as few set
    members (vehicles present) as possible, for an easier reading."""
    z3 = translator.z3
    deadline = time.monotonic() + timeout_s
    constraints = list({c.get_id(): c for c in constraints}.values())  # z3 shares equal terms
    solver = z3.Solver()
    verdict, why = _ask(z3, solver, timeout_s,
                        lambda: solver.add(*constraints, *translator.side_conditions))
    if verdict != z3.sat:
        return verdict, None, why
    model = solver.model()
    counts = [z3.Sum([z3.If(c, 1, 0) for c in v.member.values()])
              for v in translator.variables.values() if isinstance(v, ElementSet) and v.member]
    left = min(deadline - time.monotonic(), 1.0)
    if counts and left > 0.05:
        z3.set_param("warning", False)  # z3's own notes to stderr (quantifiers, below)
        opt = z3.Optimize()

        def add():
            opt.add(*constraints, *translator.side_conditions)
            opt.minimize(z3.Sum(counts))
        if _ask(z3, opt, left, add)[0] == z3.sat:
            fewer = opt.model()
            # with a quantifier (REAL parameters) z3 optimises without guarantees: the
            # smaller state is taken only where it satisfies every constraint
            if all(z3.is_true(fewer.eval(c, model_completion=True))
                   for c in (*constraints, *translator.side_conditions)):
                model = fewer
    return verdict, model, ""


def _why(solver) -> str:
    """Why the solver gave up (z3 says "canceled" for a timeout it ran into)."""
    reason = solver.reason_unknown()
    return "timeout" if reason == "canceled" else reason or "the solver gave up"


def _satisfiable(translator: Translator, parts: list[tuple[str, object]], timeout_s: float,
                 what: str) -> tuple[str, str]:
    """Whether some state satisfies every ``(label, constraint)`` of ``parts``: ``("sat",
    "")``, ``("unsat", why)`` naming the parts that contradict each other, or
    ``("unknown", the solver's reason)``."""
    z3 = translator.z3
    solver = z3.Solver()

    def add():
        solver.add(*translator.side_conditions)
        for i, (_, constraint) in enumerate(parts):
            solver.assert_and_track(constraint, z3.Bool(f"part#{i}"))
    verdict, reason = _ask(z3, solver, timeout_s, add)
    if verdict == z3.sat:
        return "sat", ""
    if verdict != z3.unsat:
        return "unknown", reason
    core = {str(m) for m in solver.unsat_core()}
    labels = [label for i, (label, _) in enumerate(parts) if f"part#{i}" in core]
    why = f"no state satisfies {what}"
    if len(labels) == 1:
        why += f" ({labels[0]} alone is unsatisfiable)"
    elif labels:
        why += f" (these contradict each other: {'; '.join(labels)})"
    return "unsat", why


def _obligation(name: str, build: Callable[[], list], ctx: _Context,
                explain: Callable[[object], _Finding], terms: list = ()) -> Result:
    """Solve ``build()``'s constraints under ``ctx.base``: unsat is proved; a model is read
    by ``explain`` and confirmed by tracecheck's evaluator."""
    translator = ctx.translator
    try:
        constraints = ctx.base + build()
    except UnsupportedError as exc:
        return Result(name, UNKNOWN, reason=exc.render())
    verdict, model, why = _solve(translator, constraints, ctx.timeout_s)
    if verdict == translator.z3.unsat:
        return Result(name, PROVED)
    if verdict != translator.z3.sat:
        return Result(name, UNKNOWN, reason=why)
    state = state_of_model(translator.z3, translator.variables, model)
    finding = explain(model)
    result = Result(name, finding.status, state=state,
                    reading=f"{finding.meaning}: {_reading(state, ctx.describe)}")
    try:
        ok_invariant = all(m.invariant(state) for m in ctx.machines)
        confirmed = ok_invariant and finding.confirm(state)
    except UnsupportedError as exc:  # the evaluator cannot decide it: not known either way
        return Result(name, UNKNOWN, state=state, reading=result.reading,
                      reason=("the solver's counterexample cannot be confirmed: tracecheck's "
                              f"evaluator does not decide it ({exc.message})"))
    except TracecheckError as exc:
        result.disagreement = f"tracecheck's evaluator cannot evaluate the state: {exc.message}"
        return result
    if not confirmed:
        holds = _holds_at(translator, model, constraints + translator.side_conditions,
                          ctx.timeout_s, terms)
        if holds is None:  # the solver did not say in time: neither a finding nor a bug
            return Result(name, UNKNOWN, state=state, reading=result.reading,
                          reason=("tracecheck's evaluator does not confirm the solver's "
                                  "counterexample, and the solver did not decide in time "
                                  "whether rounding its exact reals to floats is why "
                                  "(a longer --timeout may)"))
        if not holds:
            # the solver's exact reals, rounded to floats, moved the state across a boundary:
            # a counterexample over the reals that floats cannot show — no disagreement
            result.reason = ("over the exact reals, at a boundary: the nearest float state "
                             "does not show it (see docs/prove.md, reals and floats)")
            return result
        failing = "the invariant fails" if not ok_invariant else finding.meaning + " is false"
        result.disagreement = ("tracecheck's evaluator does not confirm the counterexample "
                               f"({failing} there): the solver and the evaluator disagree")
    return result


def _holds_at(translator: Translator, model, constraints: list,
              timeout_s: float, terms: list = ()) -> Optional[bool]:
    """Whether ``constraints`` still hold when every real of ``model`` is rounded to the
    nearest float (the state tracecheck's evaluator sees), fresh variables re-solved; None
    where the solver does not decide it within ``timeout_s``. Where rounding moves no value,
    they hold (the model itself is the answer): the solver is not asked, so that a
    disagreement is never hidden behind a question it could not answer in time."""
    z3 = translator.z3
    fixed = []
    moved = False
    for enc in [*translator.variables.values(), *terms]:  # terms: an action's values
        cells = enc.cells.values() if isinstance(enc, ElementFunction) else \
            [(None, v) for v in enc.member.values()] if isinstance(enc, ElementSet) else \
            [(None, enc.term)] if isinstance(enc, ElementTerm) else \
            [(None, enc.at(k)) for k in enc.keys] if isinstance(enc, FiniteFunction) else \
            [(None, enc)]
        for defined, value in cells:
            for var in ([defined] if defined is not None else []) + [value]:
                got = model.eval(var, model_completion=True)
                if z3.is_rational_value(got) or z3.is_algebraic_value(got):
                    algebraic = z3.is_algebraic_value(got)
                    if algebraic:
                        got = got.approx(20)
                    exact = Fraction(got.numerator_as_long(), got.denominator_as_long())
                    rounded = Fraction(float(exact))
                    moved = moved or algebraic or rounded != exact
                    got = z3.RealVal(rounded)
                fixed.append(var == got)
    if not moved:
        return True
    solver = z3.Solver()
    verdict = _ask(z3, solver, timeout_s, lambda: solver.add(*constraints, *fixed))[0]
    return True if verdict == z3.sat else False if verdict == z3.unsat else None


def _reading(state: dict, describe: Optional[Describe], limit: int = 6) -> str:
    """One line: what ``describe`` (an environment's, e.g. vehicles on the
    road) says of the state; otherwise its first variables."""
    text = describe(state) if describe is not None else None
    if text is not None:
        return text
    from ..b.values import format_value

    parts = [f"{k} = {format_value(v)}" for k, v in state.items()][:limit]
    return ", ".join(parts) + (", …" if len(state) > limit else "")


# ------------------------------------------------------------------ the evaluator's view


def _decides(machine, op: str, state: dict, bounds: Optional[Bounds] = None
             ) -> Optional[bool]:
    """Whether ``op`` is enabled in ``state`` by tracecheck's evaluator; None where its
    guard is not well-defined there — which does not enable the operation. With
    ``bounds`` (an action space's), an operation with REAL parameters is enabled where its
    guard allows a value inside them: the live shield's decision."""
    try:
        if bounds and op in bounds:
            low, high = bounds[op]
            return machine.allowed(op, state).within(low, high).witness() is not None
        return machine.is_enabled(op, state)
    except WellDefinednessError:
        return None


def _undefined(translator: Translator, model, conditions: dict) -> list[str]:
    """The names whose well-definedness condition is false in ``model``."""
    z3 = translator.z3
    return [name for name, wd in conditions.items()
            if not z3.is_true(model.eval(wd, model_completion=True))]


def _guards(ops) -> str:
    return ("the guard of " if len(ops) == 1 else "the guards of ") + ", ".join(ops)


# ------------------------------------------------------------------ prove


def machine_of(shield_or_machine):
    """The machine of a shield, or the machine itself."""
    return shield_or_machine.machine if isinstance(shield_or_machine, Shield) else \
        shield_or_machine


def _given(item: Union[str, Given], where: str) -> Given:
    return item if isinstance(item, Given) else Given(item, where)


@deeply
def prove(machine, *, deadlock_free: bool = False,
          implies: tuple[tuple[str, Union[str, Given]], ...] = (), well_defined: bool = False,
          assume: tuple[Union[str, Given], ...] = (), timeout_s: float = 10.0,
          describe: Optional[Describe] = None,
          bounds: Optional[Bounds] = None) -> list[Result]:
    """Check the obligations over every state that satisfies the invariant and ``assume``.

    Every formula is type-checked first (a mistake is an error naming its option, ``--assume``
    or ``--implies``, or the place a :class:`Given` says); an obligation whose formulas cannot
    be translated is ``unknown``, with the reason; if no state satisfies the invariant and
    assumptions, each is ``vacuous``.

    Args:
        machine: a :class:`~tracecheck.b.machine.Machine` or a shield
            (:func:`~tracecheck.checking.load_shield`).
        deadlock_free: in every state some operation is enabled.
        implies: (operation, predicate): whenever the operation is enabled, the predicate holds.
        well_defined: no guard is ill-defined in any state.
        assume: predicates the states satisfy.
        timeout_s: the solver's time per question.
        describe: how a counterexample reads (see :data:`Describe`).
        bounds: the action space's bounds of operations with REAL parameters
            (``{op: ({p: low}, {p: high})}``, an environment's: ``prove --env``): an
            operation is enabled where its guard allows an action inside them, and a claim
            ``OP(u) => P`` is about those actions. Without them every real is an action.

    Returns:
        One :class:`Result` per obligation: proved, counterexample, unknown or vacuous.

    >>> from tracecheck.b.machine import load_machine_text
    >>> m = load_machine_text("MACHINE C VARIABLES n INVARIANT n : 0..5 INITIALISATION "
    ...                       "n := 0 OPERATIONS inc = PRE n < 3 THEN n := n + 1 END END")
    >>> [r.status for r in prove(m, deadlock_free=True, assume=("n > 4",))]
    ['counterexample']
    """
    machine = machine_of(machine)
    timeout_s = check_timeout(timeout_s)
    z3 = load_z3()
    assumed = [_given(a, "--assume") for a in assume]
    claims = [(op, _given(p, "--implies")) for op, p in implies]
    for op, claim in claims:
        if op not in machine.operations:
            raise InputError(f"unknown operation {op!r} in {claim.where}; the operations of "
                             f"{machine.name} are {', '.join(machine.operations)}")
        _check_parameters(machine, op, claim)
    # every formula the user gave is checked before the solver sees any of them
    assumed = [(g, machine.check_formula(g.text, file=g.where)) for g in assumed]
    claims = [(op, g, machine.check_formula(g.text, file=g.where, **_scope(machine, op, g)))
              for op, g in claims]
    names = (["deadlock-free"] if deadlock_free else []) + \
        [_claim_name(op, g) for op, g, _ in claims] + \
        (["well-defined guards"] if well_defined else [])
    try:
        translator = Translator(machine)
        translator.bounds = dict(bounds or {})
        parts = [("the invariant", z3.And(*translator.defined(translator.invariant)))]
        for g, node in assumed:  # the invariant and assumptions are read where defined
            with translator.reading(g.where, g.text):
                parts.append((f"{g.where} {g.text!r}",
                              z3.And(*translator.defined(lambda node=node: translator.pred(node)))))
    except UnsupportedError as exc:
        return [Result(name, UNKNOWN, reason=exc.render()) for name in names]
    satisfiable, why = _satisfiable(translator, parts, timeout_s, "the invariant and assumptions")
    if satisfiable == "unsat":
        return [Result(name, VACUOUS, reason=why) for name in names]
    ctx = _Context(translator, (machine,), [c for _, c in parts], timeout_s, describe)
    results = []
    if deadlock_free:
        results.append(_deadlock_free(machine, ctx))
    for op, given, node in claims:
        results.append(_action_implication(machine, ctx, op, given, node) if given.params
                       else _implication(machine, ctx, op, given, node))
    if well_defined:
        results.append(_well_defined(machine, ctx))
    return _if_satisfiable(results, satisfiable, why, "the invariant and assumptions")


def _if_satisfiable(results: list[Result], satisfiable: str, why: str,
                    what: str) -> list[Result]:
    """Where the solver could not tell whether any state satisfies ``what``, a proof may
    be vacuous: it is ``unknown``, not ``proved`` (a counterexample shows a state)."""
    if satisfiable == "unknown":
        for r in results:
            if r.status in (PROVED, EQUIVALENT):
                r.status, r.reason = UNKNOWN, (
                    f"{r.status}, but the solver could not tell whether any state satisfies "
                    f"{what} ({why}): that may be vacuous")
    return results


def _deadlock_free(machine, ctx: _Context) -> Result:
    """Some operation is enabled in every state: a guard that is not well-defined in a
    state does not enable its operation there."""
    translator, z3 = ctx.translator, ctx.translator.z3
    wds: dict = {}

    def build():
        enabled = []
        for op in machine.operations:
            guard, wds[op] = translator.defined(lambda op=op: translator.guard(op))
            enabled.append(z3.And(wds[op], guard))
        return [z3.Not(z3.Or(enabled))]

    def explain(model) -> _Finding:
        bad = _undefined(translator, model, wds)
        note = f" ({_guards(bad)} {'is' if len(bad) == 1 else 'are'} not well-defined " \
               "there)" if bad else ""

        def confirm(state):
            decided = {op: _decides(machine, op, state, translator.bounds)
                       for op in machine.operations}
            return not any(decided.values()) and \
                [op for op, d in decided.items() if d is None] == bad
        return _Finding(COUNTEREXAMPLE, "no operation is enabled" + note, confirm)

    return _obligation("deadlock-free", build, ctx, explain)


def _implication(machine, ctx: _Context, op: str, given: Given, node) -> Result:
    """Whenever ``op`` is enabled (its guard defined and true), ``node`` is defined and
    true: a state where it is not defined is a failure of the claim, not an assumption."""
    translator, z3 = ctx.translator, ctx.translator.z3
    wd: dict = {}

    def build():
        guard, defined = translator.defined(lambda: translator.guard(op))
        with translator.reading(given.where, given.text):
            claim, wd["claim"] = translator.defined(lambda: translator.pred(node))
        return [defined, guard, z3.Not(z3.And(wd["claim"], claim))]

    def holds(state):
        return bool(machine.compile(node, source=given.text)(machine.env(state)))

    def explain(model) -> _Finding:
        if _undefined(translator, model, wd):
            def confirm(state):
                try:
                    holds(state)
                except WellDefinednessError:
                    return bool(_decides(machine, op, state, translator.bounds))
                return False
            return _Finding(NOT_DEFINED, f"{op} is enabled and {given.text} is not "
                                         "well-defined", confirm)
        return _Finding(COUNTEREXAMPLE, f"{op} is enabled and {given.text} does not hold",
                        lambda state: bool(_decides(machine, op, state, translator.bounds))
                        and not holds(state))

    return _obligation(f"{op} => {given.text}", build, ctx, explain)


def unbounded_parameters(machine) -> list[str]:
    """The REAL parameters (``OP.p``) that ``machine``'s guards do not bound on both sides
    by conjuncts of their own (``u >= -1.0 & u <= 1.0``): for them a proof without an
    action space (``prove --env``) assumes every real is an action.

    Args:
        machine: a machine or a shield.

    Returns:
        ``["PUSH.u", …]``, in the order of the operations.
    """
    from ..b.linear import parameter_range

    machine = machine_of(machine)
    out = []
    for name, op in machine.operations.items():
        if not (op.params and real_parameters(op)):
            continue
        try:
            bands = (parameter_range(machine, name) or _NO_RANGE).bands()
        except TracecheckError:
            bands = None
        for p in op.params:
            pieces = (bands or {}).get(p) or ()
            if not pieces or any(i.low is None or i.high is None for i in pieces):
                out.append(f"{name}.{p}")
    return out


class _NoRange:
    @staticmethod
    def bands():
        return None


_NO_RANGE = _NoRange()


def _claim_name(op: str, given: Given) -> str:
    return f"{op}({', '.join(given.params)}) => {given.text}" if given.params else \
        f"{op} => {given.text}"


def _check_parameters(machine, op: str, given: Given) -> None:
    """``OP(u) => P`` names each REAL parameter of ``op`` once, with a name of its own."""
    operation = machine.operations[op]
    if not given.params:
        return
    if not (operation.params and real_parameters(operation)):
        raise InputError(f"{given.where}: {op} has no REAL parameters; write '{op} => …'")
    if len(given.params) != len(operation.params):
        raise InputError(f"{given.where}: {op} has {len(operation.params)} parameter(s) "
                         f"({', '.join(operation.params)}); {op}({', '.join(given.params)}) "
                         f"names {len(given.params)}")
    taken = set(machine.variables) | set(machine.constants) | set(machine.base_env)
    clash = [n for n in given.params if n in taken]
    if clash or len(set(given.params)) != len(given.params):
        raise InputError(f"{given.where}: name the parameters of {op} apart from each other "
                         f"and from the machine's names" + (f" ({clash[0]} is one)" if clash
                                                            else ""))


def _scope(machine, op: str, given: Given) -> dict:
    """What a claim about ``op`` may name besides the machine's names: the parameters
    ``OP(u)`` names (REAL); a hint where it names a parameter without them."""
    from ..b.btypes import REAL

    params = machine.operations[op].params
    if given.params:
        return {"extra": {n: REAL for n in given.params}}
    if params:
        return {"hint": f"{op} has the parameter(s) {', '.join(params)}: write "
                        f"'{op}({', '.join(params)}) => …' to claim something of every value "
                        "its guard allows"}
    return {}


def _box(translator: Translator, op: str, values: dict) -> list:
    """The action space's bounds of ``op``'s parameters (``values``: their solver terms)."""
    z3 = translator.z3
    low, high = translator.bounds.get(op, ({}, {}))
    return [z3.RealVal(Fraction(low[p])) <= v for p, v in values.items() if p in low] + \
        [v <= z3.RealVal(Fraction(high[p])) for p, v in values.items() if p in high]


def _action_implication(machine, ctx: _Context, op: str, given: Given, node) -> Result:
    """For every state and every value of ``op``'s REAL parameters its guard allows (inside
    the action space's bounds, where given), ``node`` holds with the parameters named as
    ``given.params`` says: a counterexample is a state and an action."""
    translator, z3 = ctx.translator, ctx.translator.z3
    values = translator.parameters(op)  # OP.p: free, so the model gives the action
    named = {n: values[p] for n, p in zip(given.params, machine.operations[op].params)}
    wd: dict = {}
    action: dict = {}

    def build():
        guard, defined = translator.defined(lambda: translator.guard_at(op))
        with translator.reading(given.where, given.text):
            claim, wd["claim"] = translator.defined(lambda: translator.pred(node, named))
        return [defined, guard, *_box(translator, op, values),
                z3.Not(z3.And(wd["claim"], claim))]

    def holds(state):
        env = machine.env(state)
        env.update({n: action[p] for n, p in zip(given.params, machine.operations[op].params)})
        return bool(machine.compile(node, source=given.text)(env))

    def inside() -> bool:
        low, high = translator.bounds.get(op, ({}, {}))
        return all(low.get(p, -math.inf) <= v <= high.get(p, math.inf)
                   for p, v in action.items())

    def explain(model) -> _Finding:
        action.update({p: _real(z3, model.eval(v, model_completion=True))
                       for p, v in values.items()})
        shown = ", ".join(f"{n} = {action[p]!r}" for n, p in
                          zip(given.params, machine.operations[op].params))
        if _undefined(translator, model, wd):
            def confirm(state):
                try:
                    holds(state)
                except WellDefinednessError:
                    return inside() and machine.allows(op, state, action)
                return False
            return _Finding(NOT_DEFINED, f"{op} allows {shown} and {given.text} is not "
                                         "well-defined", confirm)
        return _Finding(COUNTEREXAMPLE, f"{op} allows {shown} and {given.text} does not hold",
                        lambda state: inside() and machine.allows(op, state, action)
                        and not holds(state))

    return _obligation(_claim_name(op, given), build, ctx, explain, terms=list(values.values()))


def _real(z3, value) -> float:
    """A solver's real as the nearest float (the action tracecheck's evaluator is given)."""
    if z3.is_algebraic_value(value):
        value = value.approx(20)
    return float(Fraction(value.numerator_as_long(), value.denominator_as_long()))


def _well_defined(machine, ctx: _Context) -> Result:
    """No guard is ill-defined in any state."""
    translator, z3 = ctx.translator, ctx.translator.z3
    wds: dict = {}

    def build():
        for op in machine.operations:
            wds[op] = translator.defined(lambda op=op: translator.guard(op))[1]
        return [z3.Not(z3.And(list(wds.values())))]

    def explain(model) -> _Finding:
        bad = _undefined(translator, model, wds)
        return _Finding(COUNTEREXAMPLE, f"{_guards(bad)} {'is' if len(bad) == 1 else 'are'} "
                                        "not well-defined",
                        lambda state: [op for op in machine.operations
                                       if _decides(machine, op, state) is None] == bad)

    return _obligation("well-defined guards", build, ctx, explain)


# ------------------------------------------------------------------ symbolic diff


@deeply
def symbolic_diff(a, b, *, timeout_s: float = 10.0, labels: Optional[tuple[str, str]] = None,
                  describe: Optional[Describe] = None) -> list[Result]:
    """Compare two shields over every state satisfying both invariants, operation by operation.

    Args:
        a: the new machine or shield.
        b: the one it is compared with.
        timeout_s: the solver's time per operation.
        labels: the two shields' names in messages (default: their machines' names).
        describe: how a state where they differ reads.

    Returns:
        Per operation of either machine a :class:`Result`: equivalent, a state where they
        decide differently (a guard not well-defined there does not enable its operation),
        unknown (a guard that cannot be translated, or the solver gives up), or ``only in`` one
        of them; vacuous where no state satisfies both invariants.

    >>> from tracecheck.b.machine import load_machine_text
    >>> def shield(bound):
    ...     return load_machine_text(f"MACHINE S VARIABLES n INVARIANT n : 0..5 INITIALISATION "
    ...                              f"n := 0 OPERATIONS inc = SELECT n < {bound} THEN skip END END")
    >>> [r.status for r in symbolic_diff(shield(3), shield(4))]
    ['counterexample']
    """
    a, b = machine_of(a), machine_of(b)
    timeout_s = check_timeout(timeout_s)
    z3 = load_z3()
    la, lb = labels or (a.name, b.name)
    if set(a.variables) != set(b.variables) or any(a.types.get(v) != b.types.get(v)
                                                   for v in a.variables):
        raise InputError(f"{la} and {lb} have different variables or types; a symbolic diff "
                         "compares shields over the same states")
    _same_sets(a, b, la, lb)
    ops = list(a.operations) + [op for op in b.operations if op not in a.operations]
    try:
        ta, tb = Translator(a), Translator(b)
        tb.share_state(ta)  # the same state for both
        parts = [(f"the invariant of {la}", z3.And(*ta.defined(ta.invariant))),
                 (f"the invariant of {lb}", z3.And(*tb.defined(tb.invariant)))]
    except UnsupportedError as exc:
        return [Result(op, UNKNOWN, reason=exc.render()) for op in ops]
    what = "both shields' invariants"
    satisfiable, why = _satisfiable(ta, parts, timeout_s, what)
    if satisfiable == "unsat":
        return [Result(op, VACUOUS, reason=why) for op in ops]
    ctx = _Context(ta, (a, b), [c for _, c in parts], timeout_s, describe)
    results = []
    for op in ops:
        if op not in b.operations or op not in a.operations:
            results.append(Result(op, ONLY_IN + (la if op in a.operations else lb)))
        else:
            results.append(_differ(a, b, tb, ctx, op, (la, lb)))
    return _if_satisfiable(results, satisfiable, why, what)


def _same_sets(a, b, la: str, lb: str) -> None:
    """Refuse shields whose sets differ: their states are not the same."""
    def shown(elems) -> str:
        return "not declared" if elems is None else "{" + ",".join(map(str, elems)) + "}"

    for name in sorted(set(a.sets) | set(b.sets)):
        ea, eb = a.sets.get(name), b.sets.get(name)
        if ea is None or eb is None or set(ea) != set(eb):
            raise InputError(f"the shields' sets differ: {name} is {shown(ea)} in {la} and "
                             f"{shown(eb)} in {lb}; diff --symbolic compares shields over the "
                             "same sets and constants",
                             hint="give both shields the same SETS (and the same sizes to "
                                  "deferred sets)")


def _differ(a, b, tb: Translator, ctx: _Context, op: str, labels: tuple[str, str]) -> Result:
    if real_parameters(a.operations[op]) and real_parameters(b.operations[op]) and \
            a.operations[op].params == b.operations[op].params:
        return _differ_actions(a, b, tb, ctx, op, labels)
    ta, z3 = ctx.translator, ctx.translator.z3
    la, lb = labels
    wds: dict = {}

    def build():
        ga, wds[la] = ta.defined(lambda: ta.guard(op))
        gb, wds[lb] = tb.defined(lambda: tb.guard(op))
        return [z3.And(wds[la], ga) != z3.And(wds[lb], gb)]

    def explain(model) -> _Finding:
        bad = _undefined(ta, model, wds)
        note = f" ({op}'s guard in {' and '.join(bad)} is not well-defined there)" if bad \
            else ""
        return _Finding(COUNTEREXAMPLE, f"{la} and {lb} decide {op} differently{note}",
                        lambda s: bool(_decides(a, op, s)) != bool(_decides(b, op, s)))

    r = _obligation(op, build, ctx, explain)
    if r.status == PROVED:
        r.status = EQUIVALENT
    elif r.state is not None and not r.disagreement and not r.reason:
        r.extra = {la: bool(_decides(a, op, r.state)), lb: bool(_decides(b, op, r.state))}
    return r


def _differ_actions(a, b, tb: Translator, ctx: _Context, op: str,
                    labels: tuple[str, str]) -> Result:
    """For an operation with REAL parameters: do the two shields allow the same actions
    in every state (∀ state, parameters: guard A ⇔ guard B)? Else a state and an action
    one allows and the other does not, confirmed by tracecheck's evaluator."""
    ta, z3 = ctx.translator, ctx.translator.z3
    la, lb = labels
    wds: dict = {}
    params = a.operations[op].params

    def build():
        ga, wds[la] = ta.defined(lambda: ta.guard_at(op))
        gb, wds[lb] = tb.defined(lambda: tb.guard_at(op))
        return [z3.And(wds[la], ga) != z3.And(wds[lb], gb)]

    found: dict = {}

    def explain(model) -> _Finding:
        point = found["action"] = {p: _nearest_float(model.eval(v, model_completion=True))
                                   for p, v in ta.parameters(op).items()}
        shown = ", ".join(f"{p} = {point[p]!r}" for p in params)
        return _Finding(COUNTEREXAMPLE, f"{la} and {lb} allow different actions of {op} "
                                        f"({shown} is allowed by one only)",
                        lambda s: a.allowed(op, s).contains(point)
                        != b.allowed(op, s).contains(point))

    r = _obligation(op, build, ctx, explain)
    if r.status == PROVED:
        r.status = EQUIVALENT
    elif r.state is not None and "action" in found and not r.disagreement and not r.reason:
        point = found["action"]  # what each shield decides for that action, there
        r.extra = {"action": point, la: a.allowed(op, r.state).contains(point),
                   lb: b.allowed(op, r.state).contains(point)}
    return r


def _nearest_float(value) -> float:
    """A solver real as the nearest float."""
    if hasattr(value, "numerator_as_long"):
        return float(Fraction(value.numerator_as_long(), value.denominator_as_long()))
    return float(value.as_decimal(20).rstrip("?"))
