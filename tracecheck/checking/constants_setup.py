"""Constants the PROPERTIES fix without a plain equality (``n : 1..10 & n * n = 49``), set
up by the solver as ProB's SETUP_CONSTANTS sets them up (:mod:`.solving`: the evaluator's
walk, or z3, every solution confirmed by the evaluator).

* One solution: the constants take it.
* Several: a constant that has the same value in all of them (all of them listed) takes it;
  the others stay without a value, the solutions named in the reason — tracecheck does not
  pick one, where ProB's animator lets the user choose.
* No solution: the machine is an error (no values satisfy its PROPERTIES).
* The solver cannot tell in :data:`SETUP_S` seconds: the constants stay without a value,
  with the solver's reason.

A constant without a value is refused, with its reason, wherever a formula reads it.
"""

from __future__ import annotations

import time
from functools import reduce
from typing import Any

from ..b import ast
from ..b.ast import conjuncts, free_names
from ..b.btypes import resolve_all
from ..b.values import format_value
from ..errors import ModelError, TracecheckError, WellDefinednessError
from .solving import solve

__all__ = ["settle", "SETUP_S", "SHOWN"]

#: the solver's time for a machine's constants
SETUP_S = 5.0
#: solutions asked for (several: the reason lists them)
SHOWN = 5


def settle(machine, names: list[str], *, timeout_s: float = SETUP_S) -> None:
    """Set up ``machine``'s constants ``names`` from its PROPERTIES (see the module
    docstring): their values into ``machine.constants``, the others into
    ``machine.unset_constants`` with the reason. Constants no conjunct links are solved
    apart (``n * n = 49`` and ``k mod 5 = 3`` are two problems): a constant every
    solution gives one value takes it, however many solutions the others have."""
    node = machine.properties_node
    if node is None:
        machine.unset_constants = {n: "the machine has no PROPERTIES" for n in names}
        return
    deadline = time.monotonic() + timeout_s
    unset: dict[str, str] = {}
    for group, conjunction in _groups(node, names):
        if conjunction is None:  # every value of its type is a solution
            unset.update((n, "no conjunct of the PROPERTIES names it: every value of its "
                             "type is a solution; tracecheck does not pick one") for n in group)
            continue
        unset.update(_settle_group(machine, group, conjunction,
                                   max(0.0, deadline - time.monotonic())))
    machine.unset_constants = unset


def _groups(node, names: list[str]) -> list[tuple[list[str], Any]]:
    """The constants of ``names`` in groups that no conjunct of ``node`` links, each with
    the conjunction of its conjuncts, in their order (None for a constant no conjunct
    names)."""
    conjs = conjuncts(node)
    owner = {n: n for n in names}

    def find(n: str) -> str:
        while owner[n] != n:
            n = owner[n]
        return n
    mentions = [[n for n in names if n in free] for free in map(free_names, conjs)]
    for found in mentions:
        for other in found[1:]:
            owner[find(other)] = find(found[0])
    roots = list(dict.fromkeys(find(n) for n in names))
    out = []
    for root in roots:
        group = [n for n in names if find(n) == root]
        mine = [c for c, found in zip(conjs, mentions) if found and find(found[0]) == root]
        out.append((group, reduce(lambda a, b: ast.And(a, b, pos=b.pos), mine) if mine
                    else None))
    return out


def _settle_group(machine, names: list[str], node, timeout_s: float) -> dict[str, str]:
    """Solve ``node`` for ``names``; fix what it determines; the reasons of the others."""
    types = {n: resolve_all(machine.type_objects[n]) for n in names}
    try:
        answer = solve(node, types, dict(machine.base_env), sets=dict(machine.sets),
                       source=machine.source, file=machine.file, timeout_s=timeout_s,
                       all_solutions=True, limit=SHOWN)
    except WellDefinednessError as exc:
        raise ModelError(f"the PROPERTIES are not well-defined for the constants "
                         f"{', '.join(names)}: {exc.message}", line=exc.line,
                         column=exc.column) from None
    except TracecheckError as exc:
        return {n: f"the solver cannot set it up: {exc.message}" for n in names}
    if answer.status == "FALSE":
        raise ModelError(f"no values of the constants {', '.join(names)} satisfy the "
                         "PROPERTIES (the solver proved it; ProB finds no SETUP_CONSTANTS)",
                         line=node.pos.line if node.pos else None,
                         column=node.pos.column if node.pos else None)
    if answer.status != "TRUE":
        return {n: f"the solver cannot set it up: {answer.reason}" for n in names}
    found = answer.solutions
    fixed = {n: found[0][n] for n in names
             if answer.complete and all(s[n] == found[0][n] for s in found)}
    machine.fix_constants(fixed)
    listed = "; ".join(" & ".join(f"{n} = {format_value(s[n])}" for n in names)
                       for s in found)
    plural = "s" if len(found) > 1 else ""
    how_many = f"{len(found)} solution{plural} ({listed})" if answer.complete else \
        f"more than {len(found)} solution{plural} ({listed}; …)" if answer.more else \
        f"at least {len(found)} solution{plural} ({listed}; …), the solver cannot tell " \
        f"whether others ({answer.reason or 'not known'})"
    return {n: f"the PROPERTIES allow {how_many}; tracecheck does not pick one"
            for n in names if n not in fixed}
