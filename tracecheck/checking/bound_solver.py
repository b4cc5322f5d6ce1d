"""Bound variables of ``tracecheck eval``'s comprehensions and quantifiers that nothing in
their predicate walks, listed by the solver (:mod:`.solving`) — only where it lists them all.
"""

from __future__ import annotations

import time
from typing import Optional

from ..b import ast
from ..b.btypes import show
from ..errors import TracecheckError, WellDefinednessError

__all__ = ["bound_solver", "BOUND_LIMIT", "BOUND_SECONDS"]


#: A comprehension or quantifier solved for its bound variables lists at most this many
#: solutions (more: refused, as a set too large to build) …
BOUND_LIMIT = 10_000
#: … within at most this many seconds (an infinite set, {x | x > 1000}, is refused then,
#: not at the end of the whole search's limit)
BOUND_SECONDS = 2.0


def bound_solver(names: dict, sets: dict, *, source: Optional[str] = None,
                 file: Optional[str] = None, timeout_s: float = 10.0,
                 deadline: Optional[float] = None):
    """The hook of :attr:`tracecheck.b.evaluation.Compiler.solver` for ``tracecheck eval``:
    bound variables that nothing in a comprehension's or quantifier's predicate walks
    (``{x | x*x = 100}``, ``#x.(x > 2 & x < y)``) take every solution of the predicate for
    them — only where the solver finds them all (FALSE: none; a complete list), else the
    evaluator's own refusal with the solver's reason. ``names``: the types of the names in
    scope (a machine's); the values of the others (outer bound variables) are typed from
    ``env``. Each call has ``timeout_s``, or what is left until ``deadline`` (a search
    that holds this one)."""
    from ..b.btypes import Var, resolved_defaulting
    from ..b.typecheck import type_of_value, typecheck_formula

    owners = {e: k for k, elems in sets.items() for e in elems}

    def solver(pred: ast.Node, ids: tuple[str, ...], env: dict, problem,
               one: bool = False) -> list[dict]:
        from .solving import solve  # only where a bound variable needs it (eval's start-up)

        typed = dict(names)
        for k in ast.free_names(pred) - set(ids) - set(typed):
            if k in env:
                typed[k] = type_of_value(env[k], owners)
        typed.update({n: Var() for n in ids})
        try:
            typecheck_formula(pred, typed, kind="predicate", source=source, file=file)
        except TracecheckError:
            raise problem from None
        types = resolved_defaulting(typed, ids)
        if any("?" in show(t) for t in types.values()):
            raise problem
        answer = solve(pred, types, env, sets=sets, source=source, file=file,
                       timeout_s=min(BOUND_SECONDS, timeout_s if deadline is None else
                                     max(0.05, deadline - time.monotonic())),
                       all_solutions=not one, limit=BOUND_LIMIT, inner=bound_solver,
                       everywhere=one)
        if answer.note:  # a value of the variables where the predicate has none
            raise WellDefinednessError(answer.note, file=problem.file, source=problem.source,
                                       line=problem.line, column=problem.column)
        if answer.status == "FALSE":
            return []
        if answer.status == "TRUE" and (answer.complete or one):
            return answer.solutions[:1] if one else answer.solutions
        why = answer.reason or (f"more than {BOUND_LIMIT:,} solutions" if answer.more
                                else "not every solution found")
        wanted = "does not find a value or show there is none" if one else \
            "does not list every value"
        error = type(problem)(f"{problem.message}: the solver {wanted} ({why})",
                              file=problem.file, source=problem.source, line=problem.line,
                              column=problem.column, hint=problem.hint)
        error.unlisted = pred  # type: ignore[attr-defined] - which binder could not be listed
        error.asked = problem  # type: ignore[attr-defined] - the refusal before the solver
        raise error from None
    return solver
