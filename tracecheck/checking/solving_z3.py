"""The z3 half of :mod:`.solving`: the free identifiers that are integers, reals or booleans
become z3 variables (the translation of :mod:`.smt`); ``sat`` gives a model whose values
(reals rounded to floats, and their neighbours where rounding meets the predicate) the
evaluator checks again before they are a solution; ``unsat`` is FALSE; ``unknown`` says why.
z3 is imported only when the solver is asked."""

from __future__ import annotations

import math
import time
from fractions import Fraction
from itertools import product
from typing import Any, Optional

from ..b import ast
from ..b.btypes import BOOL, INTEGER, REAL
from ..b.memo import fresh
from ..b.values import Elem, format_value
from ..errors import Disagreement, TracecheckError
from .deadline import interrupted_at
from .encoding import nudge
from .smt import Translator

#: a :mod:`.solving` problem and its answer (that module imports this one)
Problem = Answer = Any

__all__ = ["Z3Solver"]

#: Floats tried on each side of a real the solver chose, where its nearest float fails.
NUDGES = 2


def _rounds(problem) -> bool:
    """Whether float rounding can meet a free identifier in the predicate: an arithmetic
    operation or a call over it where REALs are about (a REAL identifier, a real literal, a
    constant that is a float, or ``real(…)`` of an integer: ``real(x) * 0.1 =
    0.30000000000000004`` holds for x = 3 in floats and for no x over the exact reals).
    There, no solution over the exact reals does not mean none in floats. Compared as it
    is (``x > 1.0 & x < 0.5``), a float is a real."""
    free = set(problem.names)
    if not (any(t == REAL for t in problem.types.values())
            or _mentions_reals(problem.node, problem.env)):
        return False

    def walk(node) -> bool:
        if isinstance(node, (ast.BinOp, ast.Neg, ast.Call)) and \
                ast.free_names(node) & free:
            return True
        return any(walk(c) for c in ast.children(node))
    return walk(problem.node)


def _mentions_reals(node, env: dict) -> bool:
    """Whether ``node`` has a real literal, a conversion to REAL or a name whose value is a
    float."""
    if isinstance(node, ast.RealLit) or (isinstance(node, ast.Call) and node.name == "real"):
        return True
    if isinstance(node, ast.Name) and type(env.get(node.id)) is float:
        return True
    return any(_mentions_reals(c, env) for c in ast.children(node))


class _Scope:
    """What :class:`~.smt.Translator` reads of a machine: no state variables, the values of
    ``eval``'s scope as constants, the machine's sets."""

    variables: tuple = ()
    operations: dict = {}

    def __init__(self, problem: Problem) -> None:
        self.base_env, self.sets = problem.env, problem.sets
        self.file, self.source = problem.file, problem.source


class _FreeTranslator(Translator):
    """The translator over the free identifiers (solver variables, in ``env``); a
    sub-formula that reads none of them is evaluated by tracecheck's evaluator and enters as
    its value, where that is a number, a boolean or an element."""

    number_sets = True

    def __init__(self, problem: Problem) -> None:
        super().__init__(_Scope(problem))
        self.problem = problem
        self.free: dict = {}

    def translate(self, node: ast.Node, env: dict) -> Any:
        if not isinstance(node, ast.Name) and not (ast.free_names(node, self.free)
                                                   & (set(self.problem.names) | env.keys())):
            value = self.problem.closed(node)
            if type(value) in (bool, int) or isinstance(value, Elem):
                return value if isinstance(value, Elem) else (
                    self.z3.BoolVal(value) if type(value) is bool else self.z3.IntVal(value))
            if type(value) is float and math.isfinite(value):
                return self.z3.RealVal(Fraction(value))
        return super().translate(node, env)


class Z3Solver:
    """A problem the evaluator cannot walk, asked of z3; every solution confirmed by the
    evaluator."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        translator = _FreeTranslator(problem)
        z3 = self.z3 = translator.z3
        make = {INTEGER: z3.Int, REAL: z3.Real, BOOL: z3.Bool}
        self.vars = {n: make[problem.types[n]](n) for n in problem.names}
        with translator.reading(problem.file, problem.source):
            formula, self.defined = translator.defined(
                lambda: translator.pred(problem.node, dict(self.vars)))
        self.solver = z3.Solver()
        self.side = translator.side_conditions
        self.constraints = [self.defined, formula, *self.side]

    def undefined(self) -> Optional[str]:
        """A place where the predicate has no value, as the evaluator says it: "" where the
        solver proves there is none, None where it cannot tell in the time left."""
        self.solver = self.z3.Solver()
        verdict = self.check(self.z3.Not(self.defined), *self.side)[0]
        if verdict != "sat":
            return "" if verdict == "unsat" else None
        try:
            model = self.solver.model()
        except self.z3.Z3Exception:  # interrupted at the time limit
            return None
        point = {n: self.values(model.eval(v, model_completion=True))
                 for n, v in self.vars.items()}
        try:
            self.problem.whole({**fresh(self.problem.env), **point})
        except TracecheckError as exc:
            where = " & ".join(f"{n} = {format_value(v)}" for n, v in point.items())
            self.problem.undefined_at = exc  # its place in the formula
            return f"the predicate has no value where {where}: {exc.message}"
        return ""

    def values(self, v) -> Any:
        """A value of the model as a B value (a real: the nearest float)."""
        z3 = self.z3
        if z3.is_int_value(v):
            return v.as_long()
        if z3.is_true(v) or z3.is_false(v):
            return z3.is_true(v)
        return _nearest_float(z3, v)

    def check(self, *extra) -> tuple[str, str]:
        """The solver's verdict (sat, unsat or unknown) with ``extra`` added, and why it is
        unknown; within what is left of the time limit."""
        z3, problem = self.z3, self.problem
        left = problem.deadline - time.monotonic()
        limit = f"time limit ({problem.timeout_s:g} s)"
        if left <= 0:
            return "unknown", limit
        try:
            with interrupted_at(z3, left):
                self.solver.add(*extra)
                self.solver.set("timeout", max(1, int(left * 1000)))
                verdict = self.solver.check()
        except z3.Z3Exception as exc:  # interrupted while the question was asserted
            return "unknown", limit if time.monotonic() >= problem.deadline else str(exc)
        if verdict == z3.sat:
            return "sat", ""
        if verdict == z3.unsat:
            return "unsat", ""
        why = self.solver.reason_unknown()
        return "unknown", limit if why in ("canceled", "timeout", "interrupted") else \
            f"the solver: {why}"

    def solve(self) -> Answer:
        problem, z3 = self.problem, self.z3
        solutions: list[dict] = []
        verdict, why = self.check(*self.constraints)
        while verdict == "sat" and len(solutions) < problem.limit:
            try:
                model = self.solver.model()
            except z3.Z3Exception:  # the time limit's interrupt came as the check ended
                verdict, why = "unknown", f"time limit ({problem.timeout_s:g} s)"
                break
            exact = {n: model.eval(v, model_completion=True) for n, v in self.vars.items()}
            try:
                found = self.confirmed(exact)
            except TracecheckError as exc:  # the evaluator refuses the predicate
                return problem.answer(
                    "unknown", method="solver",
                    reason=f"tracecheck's evaluator cannot check the solver's solution: "
                           f"{exc.message}")
            if found is None:
                return self.unconfirmed(exact, solutions)
            if found not in solutions:
                solutions.append(found)
            if not problem.all_solutions:
                break
            verdict, why = self.check(z3.Or([v != exact[n] for n, v in self.vars.items()]))
        if not problem.all_solutions and solutions:
            return problem.answer("TRUE", solutions=solutions, method="solver")
        if verdict == "unknown" and not solutions:
            return problem.answer("unknown", reason=why, method="solver")
        if not solutions and _rounds(problem):
            # no solution over the exact reals; the evaluator's REALs are floats, where one
            # can exist all the same (x + 1.0 = 1.0 & x > 0.0 holds for x = 1.0e-300)
            return problem.answer("unknown", method="solver",
                                  reason="no solution over the exact reals, but the REALs "
                                         "are floats, which the solver did not search")
        if not solutions:
            note = self.undefined()
            if note is None:
                return problem.answer("unknown", method="solver", reason="no solution, but "
                                      "whether the predicate has a value everywhere is not "
                                      "known within the time limit")
            return problem.answer("FALSE", method="solver", note=note)
        more = True if verdict == "sat" else (False if verdict == "unsat" else None)
        complete, note = verdict == "unsat", ""
        if complete and _rounds(problem):  # more floats next to these may solve it too
            complete, more, why = False, None, "the REALs are floats, which the solver " \
                                               "did not search one by one"
        elif complete:
            note = self.undefined()
            if note is None:  # whether a point has no value: not known
                complete, note, why = False, "", "time limit (is it defined everywhere?)"
        return problem.answer("TRUE", solutions=solutions, method="solver", complete=complete,
                              more=more, reason=why if not complete else "", note=note)

    def confirmed(self, exact: dict) -> Optional[dict]:
        """The model's values as B values the evaluator confirms: integers as they are,
        reals as their nearest floats, else up to :data:`NUDGES` floats away; None."""
        base = {n: self.values(v) for n, v in exact.items()}
        reals = [n for n in base if type(base[n]) is float]
        if any(not math.isfinite(base[n]) for n in reals):
            return None
        if self.problem.holds(base):
            return base
        steps = range(-NUDGES, NUDGES + 1)
        tries = product(steps, repeat=len(reals)) if len(reals) <= 3 else \
            ((s if i == j else 0 for j in range(len(reals))) for i in range(len(reals))
             for s in steps)
        for moves in tries:
            moved = dict(base)
            for n, k in zip(reals, moves):
                moved[n] = nudge(base[n], k)
            if self.problem.holds(moved):
                return moved
        return None

    def unconfirmed(self, exact: dict, solutions: list) -> Answer:
        shown = ", ".join(f"{n} = {v}" for n, v in exact.items())
        if not any(self.z3.is_arith(v) and not self.z3.is_int_value(v)
                   for v in exact.values()):
            raise Disagreement(f"the solver's solution {shown} is not confirmed by "
                               "tracecheck's evaluator: one of the two has a bug; please "
                               "report it", file=self.problem.file, source=self.problem.source)
        reason = (f"the solver's solution over the exact reals ({shown}) is not one in "
                  "floats, the evaluator's REALs, nor are the floats next to it")
        if solutions:
            return self.problem.answer("TRUE", solutions=solutions, method="solver",
                                       complete=False, more=None, reason=reason)
        return self.problem.answer("unknown", reason=reason, method="solver")


def _nearest_float(z3, v) -> float:
    if z3.is_algebraic_value(v):
        v = v.approx(40)
    try:
        return float(Fraction(v.numerator_as_long(), v.denominator_as_long()))
    except OverflowError:
        return math.inf
