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

from fractions import Fraction
from typing import Optional, Union

from ..b.linear import real_parameters
from ..errors import InputError, UnsupportedError, WellDefinednessError
from ..limits import deeply
from .action_claims import (action_implication, check_parameters, claim_name, claim_scope,
                            unbounded_parameters)
from .confirming import (COUNTEREXAMPLE, EQUIVALENT, NOT_DEFINED, ONLY_IN, PROVED, UNKNOWN,
                         VACUOUS, Bounds, Context, Describe, Finding, Result, decides,
                         guards_text, machine_of, obligation, check_satisfiable,
                         undefined)
from .encoding import check_timeout, load_z3
from .obligations import Given
from .smt import Translator

__all__ = ["prove", "symbolic_diff", "Result", "Describe", "Bounds", "unbounded_parameters",
           "check_timeout", "machine_of",
           "PROVED", "EQUIVALENT", "COUNTEREXAMPLE", "NOT_DEFINED", "UNKNOWN", "VACUOUS"]


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
        check_parameters(machine, op, claim)
    # every formula the user gave is checked before the solver sees any of them
    assumed = [(g, machine.check_formula(g.text, file=g.where)) for g in assumed]
    claims = [(op, g, machine.check_formula(g.text, file=g.where, **claim_scope(machine, op, g)))
              for op, g in claims]
    names = (["deadlock-free"] if deadlock_free else []) + \
        [claim_name(op, g) for op, g, _ in claims] + \
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
    satisfiable, why = check_satisfiable(translator, parts, timeout_s, "the invariant and assumptions")
    if satisfiable == "unsat":
        return [Result(name, VACUOUS, reason=why) for name in names]
    ctx = Context(translator, (machine,), [c for _, c in parts], timeout_s, describe)
    results = []
    if deadlock_free:
        results.append(_deadlock_free(machine, ctx))
    for op, given, node in claims:
        results.append(action_implication(machine, ctx, op, given, node) if given.params
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


def _deadlock_free(machine, ctx: Context) -> Result:
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

    def explain(model) -> Finding:
        bad = undefined(translator, model, wds)
        note = f" ({guards_text(bad)} {'is' if len(bad) == 1 else 'are'} not well-defined " \
               "there)" if bad else ""

        def confirm(state):
            decided = {op: decides(machine, op, state, translator.bounds)
                       for op in machine.operations}
            return not any(decided.values()) and \
                [op for op, d in decided.items() if d is None] == bad
        return Finding(COUNTEREXAMPLE, "no operation is enabled" + note, confirm)

    return obligation("deadlock-free", build, ctx, explain)


def _implication(machine, ctx: Context, op: str, given: Given, node) -> Result:
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

    def explain(model) -> Finding:
        if undefined(translator, model, wd):
            def confirm(state):
                try:
                    holds(state)
                except WellDefinednessError:
                    return bool(decides(machine, op, state, translator.bounds))
                return False
            return Finding(NOT_DEFINED, f"{op} is enabled and {given.text} is not "
                                         "well-defined", confirm)
        return Finding(COUNTEREXAMPLE, f"{op} is enabled and {given.text} does not hold",
                        lambda state: bool(decides(machine, op, state, translator.bounds))
                        and not holds(state))

    return obligation(f"{op} => {given.text}", build, ctx, explain)


def _well_defined(machine, ctx: Context) -> Result:
    """No guard is ill-defined in any state."""
    translator, z3 = ctx.translator, ctx.translator.z3
    wds: dict = {}

    def build():
        for op in machine.operations:
            wds[op] = translator.defined(lambda op=op: translator.guard(op))[1]
        return [z3.Not(z3.And(list(wds.values())))]

    def explain(model) -> Finding:
        bad = undefined(translator, model, wds)
        return Finding(COUNTEREXAMPLE, f"{guards_text(bad)} {'is' if len(bad) == 1 else 'are'} "
                                        "not well-defined",
                        lambda state: [op for op in machine.operations
                                       if decides(machine, op, state) is None] == bad)

    return obligation("well-defined guards", build, ctx, explain)


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
    satisfiable, why = check_satisfiable(ta, parts, timeout_s, what)
    if satisfiable == "unsat":
        return [Result(op, VACUOUS, reason=why) for op in ops]
    ctx = Context(ta, (a, b), [c for _, c in parts], timeout_s, describe)
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


def _differ(a, b, tb: Translator, ctx: Context, op: str, labels: tuple[str, str]) -> Result:
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

    def explain(model) -> Finding:
        bad = undefined(ta, model, wds)
        note = f" ({op}'s guard in {' and '.join(bad)} is not well-defined there)" if bad \
            else ""
        return Finding(COUNTEREXAMPLE, f"{la} and {lb} decide {op} differently{note}",
                        lambda s: bool(decides(a, op, s)) != bool(decides(b, op, s)))

    r = obligation(op, build, ctx, explain)
    if r.status == PROVED:
        r.status = EQUIVALENT
    elif r.state is not None and not r.disagreement and not r.reason:
        r.extra = {la: bool(decides(a, op, r.state)), lb: bool(decides(b, op, r.state))}
    return r


def _differ_actions(a, b, tb: Translator, ctx: Context, op: str,
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

    def explain(model) -> Finding:
        point = found["action"] = {p: _nearest_float(model.eval(v, model_completion=True))
                                   for p, v in ta.parameters(op).items()}
        shown = ", ".join(f"{p} = {point[p]!r}" for p in params)
        return Finding(COUNTEREXAMPLE, f"{la} and {lb} allow different actions of {op} "
                                        f"({shown} is allowed by one only)",
                        lambda s: a.allowed(op, s).contains(point)
                        != b.allowed(op, s).contains(point))

    r = obligation(op, build, ctx, explain)
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
