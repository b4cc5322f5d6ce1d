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
from ..b.bindings import conjuncts
from ..b.btypes import REAL
from ..b.memo import fresh
from ..b.values import Elem, format_value
from ..errors import Disagreement, TracecheckError, UnsupportedError
from .deadline import interrupted_at
from .encoding import (ElementSet, ElementTerm, FiniteFunction, NumberSet, finite_members,
                       nudge, state_of_model)
from .free_encoding import encode_free
from .smt import Translator
from .smt_sets import EMPTY, MAX_LISTED, Nums

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
        #: f = %x.(P | E) of the predicate, f in the scope: its applications translated
        self.lambdas = {
            side.id: other for c in conjuncts(problem.node)
            if isinstance(c, ast.Rel) and c.op == "="
            for side, other in ((c.left, c.right), (c.right, c.left))
            if isinstance(side, ast.Name) and isinstance(other, ast.Lambda)
            and side.id in problem.env}

    def translate(self, node: ast.Node, env: dict) -> Any:
        if not isinstance(node, ast.Name) and not (ast.free_names(node, self.free)
                                                   & (set(self.problem.names) | env.keys())):
            value = self.problem.closed(node)
            if type(value) in (bool, int) or isinstance(value, Elem):
                return value if isinstance(value, Elem) else (
                    self.z3.BoolVal(value) if type(value) is bool else self.z3.IntVal(value))
            if type(value) is float and math.isfinite(value):
                return self.z3.RealVal(Fraction(value))
            if isinstance(value, frozenset) and not value:
                return EMPTY  # its carrier from the other side
            numbers = self._numbers(value)
            if numbers is not None:
                return numbers
        return super().translate(node, env)

    def t_Name(self, node: ast.Name, env: dict) -> Any:
        if node.id not in env and node.id in self.problem.env:  # coins = {16, 17}: x : coins
            if self.problem.env[node.id] == frozenset():
                return EMPTY
            numbers = self._numbers(self.problem.env[node.id])
            if numbers is not None:
                return numbers
        return super().t_Name(node, env)

    def _numbers(self, value: Any) -> Optional[Nums]:
        """A finite set of integers of the scope as the translator's set of numbers."""
        if isinstance(value, frozenset) and 0 < len(value) <= MAX_LISTED and all(
                type(v) is int for v in value):
            return Nums([(self.z3.BoolVal(True), self.z3.IntVal(v)) for v in sorted(value)])
        return None

    def t_Apply(self, node: ast.Apply, env: dict) -> Any:
        """``f(a)`` where a conjunct defines ``f = %x.(P | E)`` (f then in the scope): E
        with x the argument, defined where P holds there (``f(sqrt) = 100``)."""
        fn = node.fn
        lam = self.lambdas.get(fn.id) if isinstance(fn, ast.Name) and fn.id not in env \
            else None
        if lam is None or len(lam.ids) != 1 or len(node.args) != 1:
            return super().t_Apply(node, env)
        arg = self.translate(node.args[0], env)
        inner = {n: v for n, v in env.items() if n in self.problem.names}
        inner[lam.ids[0]] = arg
        self._need(self.pred(lam.pred, inner), node)
        return self.translate(lam.expr, inner)

    def closed_value(self, node: ast.Node, env: dict) -> Any:
        if ast.free_names(node) & set(env):  # a bound or chosen name: not the scope's
            raise self.fail(node, "a value that reads a variable the solver chooses")
        value = self.problem.closed(node)
        if value is None:
            raise self.fail(node, "a value that the solver's identifiers do not fix")
        return value


class Z3Solver:
    """A problem the evaluator cannot walk, asked of z3; every solution confirmed by the
    evaluator."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        translator = _FreeTranslator(problem)
        z3 = self.z3 = translator.z3
        self.vars = {n: encode_free(z3, problem, n) for n in problem.names}
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
        try:
            point = self.read(model)
        except UnsupportedError:
            return None
        point.update({n: self.values(v) for n, v in point.items() if self.z3.is_expr(v)})
        try:
            self.problem.whole({**fresh(self.problem.env), **point})
        except TracecheckError as exc:
            where = " & ".join(f"{n} = {format_value(v)}" for n, v in point.items())
            self.problem.undefined_at = exc  # its place in the formula
            return f"the predicate has no value where {where}: {exc.message}"
        return None  # the solver's point is one the evaluator takes: not shown either way

    def read(self, model) -> dict:
        """The model's value of each identifier: a z3 value for a number or a boolean, the
        B value of anything else."""
        z3 = self.z3
        if model is None:
            raise UnsupportedError("the solver's sets of integers are not finite sets it "
                                   "can list")
        out = state_of_model(z3, {n: e for n, e in self.vars.items()
                                  if not (z3.is_expr(e) or isinstance(e, NumberSet))}, model)
        for n, e in self.vars.items():
            if isinstance(e, NumberSet):
                members = finite_members(z3, model, e.term)
                if members is None:
                    raise UnsupportedError(f"the solver's value of {n} is not a finite set "
                                           "it can list")
                out[n] = members
        out.update({n: model.eval(v, model_completion=True) for n, v in self.vars.items()
                    if z3.is_expr(v)})
        return out

    def finite_model(self, model) -> Any:
        """Another model, where each set of integers the solver chooses holds only the
        numbers of ``model`` and of the predicate, and a few numbers above them, that are
        members in ``model`` (None where there is none such, or not within the time
        limit)."""
        z3 = self.z3
        numbers: set = set()
        seen: set = set()
        todo = [model.eval(d(), model_completion=True) for d in model.decls()
                if d.arity() == 0] + list(self.constraints)
        while todo:
            t = todo.pop()
            if t.get_id() in seen:
                continue
            seen.add(t.get_id())
            if z3.is_int_value(t):
                numbers.add(t.as_long())
            elif z3.is_app(t) or z3.is_quantifier(t):
                todo.extend(t.children() if z3.is_app(t) else [t.body()])
        sets = [e for e in self.vars.values() if isinstance(e, NumberSet)]
        top = max(numbers, default=0)  # numbers no formula names: one per way of being in
        numbers.update(range(top + 1, top + 1 + 2 ** min(len(sets), 4)))  # the sets or not
        self.solver.push()
        try:
            for enc in sets:
                if isinstance(enc, NumberSet):
                    members = [k for k in sorted(numbers) if z3.is_true(
                        model.eval(z3.IsMember(z3.IntVal(k), enc.term), model_completion=True))]
                    listed = z3.EmptySet(z3.IntSort())
                    for k in members:
                        listed = z3.SetAdd(listed, z3.IntVal(k))
                    self.solver.add(enc.term == listed)
            if self.check()[0] != "sat":
                return None
            return self.solver.model()
        finally:
            self.solver.pop()

    def other(self, model) -> Any:
        """That some identifier has another value than in ``model``."""
        z3 = self.z3

        def now(t):
            return model.eval(t, model_completion=True)
        parts = []
        for enc in self.vars.values():
            if z3.is_expr(enc):
                parts.append(enc != now(enc))
            elif isinstance(enc, ElementTerm):
                parts.append(enc.term != now(enc.term))
            elif isinstance(enc, NumberSet):
                parts.append(enc.term != now(enc.term))
            elif isinstance(enc, FiniteFunction):
                parts += [enc.at(k) != now(enc.at(k)) for k in enc.keys]
            elif isinstance(enc, ElementSet):
                parts += [c != now(c) for c in enc.member.values()]
            else:  # ElementFunction: where defined, and the value there
                for d, v in enc.cells.values():
                    parts.append(d != now(d))
                    if z3.is_true(now(d)):
                        parts.append(v != now(v))
        return z3.Or(parts)

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
            try:
                exact = self.read(model)
            except UnsupportedError:  # a set of integers that is not a finite list:
                model = self.finite_model(model)  # its members among the numbers about
            try:
                exact = self.read(model) if model is not None else self.read(None)
            except UnsupportedError as exc:
                return problem.answer("TRUE" if solutions else "unknown", method="solver",
                                      solutions=solutions, complete=False, more=None,
                                      reason=exc.message)
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
            verdict, why = self.check(self.other(model))
        if not problem.all_solutions and solutions:
            note = self.undefined() if problem.everywhere else ""
            if note is None:
                return problem.answer("unknown", method="solver", reason="a solution, but "
                                      "whether the predicate has a value everywhere is not "
                                      "known within the time limit")
            return problem.answer("TRUE", solutions=solutions, method="solver", note=note)
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
        base = {n: self.values(v) if self.z3.is_expr(v) else v for n, v in exact.items()}
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
        z3 = self.z3
        shown = ", ".join(f"{n} = {v if z3.is_expr(v) else format_value(v)}"
                          for n, v in exact.items())
        if not any(z3.is_expr(v) and z3.is_arith(v) and not z3.is_int_value(v)
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
