"""Claims about the actions an operation with REAL parameters allows (``prove --implies
'PUSH(u) => P'``), the action space's bounds in the solver's questions, and which parameters a
proof without an action space takes as every real (:func:`unbounded_parameters`).
"""

from __future__ import annotations

import math
from fractions import Fraction

from ..b.linear import real_parameters
from ..errors import InputError, TracecheckError, WellDefinednessError
from .confirming import (COUNTEREXAMPLE, NOT_DEFINED, Context, Finding, Result, machine_of,
                         obligation, undefined)
from .obligations import Given

__all__ = ["unbounded_parameters", "claim_name", "check_parameters", "claim_scope",
           "action_implication"]


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
            found = parameter_range(machine, name)
            bands = found.bands() if found is not None else None
        except TracecheckError:  # not known to be bounded: said as unbounded (a warning)
            bands = None
        for p in op.params:
            pieces = (bands or {}).get(p) or ()
            if not pieces or any(i.low is None or i.high is None for i in pieces):
                out.append(f"{name}.{p}")
    return out


def claim_name(op: str, given: Given) -> str:
    return f"{op}({', '.join(given.params)}) => {given.text}" if given.params else \
        f"{op} => {given.text}"


def check_parameters(machine, op: str, given: Given) -> None:
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


def claim_scope(machine, op: str, given: Given) -> dict:
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


def action_implication(machine, ctx: Context, op: str, given: Given, node) -> Result:
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
        return [defined, guard, *translator.action_box(op, values),
                z3.Not(z3.And(wd["claim"], claim))]

    def holds(state):
        env = machine.env(state)
        env.update({n: action[p] for n, p in zip(given.params, machine.operations[op].params)})
        return bool(machine.compile(node, source=given.text)(env))

    def inside() -> bool:
        low, high = translator.bounds.get(op, ({}, {}))
        return all(low.get(p, -math.inf) <= v <= high.get(p, math.inf)
                   for p, v in action.items())

    def explain(model) -> Finding:
        action.update({p: _real(z3, model.eval(v, model_completion=True))
                       for p, v in values.items()})
        shown = ", ".join(f"{n} = {action[p]!r}" for n, p in
                          zip(given.params, machine.operations[op].params))
        if undefined(translator, model, wd):
            def confirm(state):
                try:
                    holds(state)
                except WellDefinednessError:
                    return inside() and machine.allows(op, state, action)
                return False
            return Finding(NOT_DEFINED, f"{op} allows {shown} and {given.text} is not "
                                         "well-defined", confirm)
        return Finding(COUNTEREXAMPLE, f"{op} allows {shown} and {given.text} does not hold",
                        lambda state: inside() and machine.allows(op, state, action)
                        and not holds(state))

    return obligation(claim_name(op, given), build, ctx, explain, terms=list(values.values()))


def _real(z3, value) -> float:
    """A solver's real as the nearest float (the action tracecheck's evaluator is given)."""
    if z3.is_algebraic_value(value):
        value = value.approx(20)
    return float(Fraction(value.numerator_as_long(), value.denominator_as_long()))
