"""Whether a run fits a shield before it is judged by it: every action the run takes is an
operation of the shield (a misspelt one would block every such step), the states have the
variables its guards and invariant read, and recorded values of parameters are of
parameters the shield types REAL ("some value allowed" would pass a recorded 2.0 against
``a : 0..1``). Replay and diff refuse a run that does not fit, naming the first step."""

from __future__ import annotations

import numpy as np

from ..b import ast
from ..episodes.columns import RunColumns
from ..errors import InputError, closest, did_you_mean
from .shield import Shield

__all__ = ["check_actions", "check_variables", "refuse_recorded_values"]


def check_actions(shield: Shield, cols: RunColumns, rows: np.ndarray,
                  actions: np.ndarray) -> None:
    """Refuse a run that takes an action the shield has no operation for (a misspelt
    operation would otherwise block every such step), naming the first step that does."""
    ops = shield.machine.operations
    for code, name in enumerate(cols.action_names):
        if name in ops:
            continue
        which = np.flatnonzero(actions == code)
        if len(which):
            r, near = int(rows[which[0]]), closest(name, ops)
            raise InputError(f"{cols.path}: the episodes use the action {name} "
                             f"({len(which):,} step(s), the first at episode "
                             f"{int(cols.episode[r])} step {int(cols.step[r])}), which the "
                             f"shield {shield.name} has no operation for (its operations are "
                             f"{', '.join(ops) or 'none'})",
                             hint=(f"is the shield's operation {near} the action {name} "
                                   "misspelt? " if near else "check the spelling: ")
                             + "an action and its operation have one name")


def check_variables(shield: Shield, cols: RunColumns) -> None:
    """Refuse a run whose states lack a variable the shield's guards or invariant read, or
    give a variable a value of another type than the shield declares (a REAL where it says
    INTEGER: the guards would be evaluated on values the shield cannot have)."""
    have = cols.states.names() | set(shield.machine.base_env)
    machine = shield.machine
    _check_scalar_types(shield, cols)
    needed = set().union(*machine.guard_variables().values())
    if machine.invariant_node is not None:
        needed |= ast.free_names(machine.invariant_node)
    missing = sorted(n for n in needed if n not in have and n in machine.variables)
    if missing and cols.n:
        said = {n: did_you_mean(n, cols.states.names()) for n in missing}
        near = [f"{n} ({said[n]})" for n in missing if said[n]]
        raise InputError(f"{cols.path}: the states have no {', '.join(missing)}, which the "
                         f"shield {shield.name} reads (episode {int(cols.episode_ids[0])}, "
                         "step 0)", hint=f"the states name another: {'; '.join(near)}"
                         if near else None)


def refuse_recorded_values(shield: Shield, cols: RunColumns, op, which: np.ndarray) -> None:
    """A run that recorded values of an operation's parameters the shield does not type
    REAL: "some value allowed" would pass a recorded 2.0 against ``a : 0..1``, so the
    recorded values cannot be judged — an error naming the first such step."""
    recorded = [p for p in op.params if p in cols.parameters]
    for p in recorded:
        given = np.flatnonzero(np.isfinite(cols.parameters[p][which]))
        if len(given):
            r = int(which[given[0]])
            raise InputError(
                f"{cols.path}: the run records values of {op.name}'s parameter {p} "
                f"({float(cols.parameters[p][r])!r} at episode {int(cols.episode[r])} step "
                f"{int(cols.step[r])}), but the shield {shield.name} does not type it REAL "
                f"(`{p} : REAL` in the guard of {op.name}): tracecheck cannot judge the "
                "recorded values against it",
                hint="a shield for continuous actions types each parameter REAL and bounds "
                     "it with comparisons (a >= 0.0 & a <= 1.0)")


#: the declared types of the scalar columns a run's states hold, and what each column holds
_HELD = {"INTEGER": "an INTEGER", "REAL": "a REAL", "BOOL": "a BOOL"}


def _check_scalar_types(shield: Shield, cols: RunColumns) -> None:
    """Each scalar variable the shield declares INTEGER, REAL or BOOL, recorded as such."""
    states, machine = cols.states, shield.machine
    for name in machine.variables:
        declared = machine.types.get(name)
        if declared not in _HELD or not cols.n:
            continue
        if name in states.numbers:
            held = "REAL" if states.numbers[name].dtype.kind == "f" else "INTEGER"
        elif name in states.booleans:
            held = "BOOL"
        else:
            continue  # elements, sets, functions: checked where they are evaluated
        if held != declared:
            raise InputError(f"{cols.path}: the states give {name} as {_HELD[held]} (episode "
                             f"{int(cols.episode_ids[0])}, step 0), but the shield "
                             f"{shield.name} declares it {declared}: its guards cannot be "
                             "judged on values it cannot have",
                             hint="record the variable as the shield types it (the "
                                  "adapter's state()), or give a shield that types it so")
