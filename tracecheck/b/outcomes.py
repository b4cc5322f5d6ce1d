"""Every outcome of a substitution, listed: what a sequence whose first part is not
deterministic, a ``VAR`` block and a ``WHILE`` loop are checked with (a mixin of
:class:`~tracecheck.b.substitution.SubstCompiler`, which gives ``comp`` and
``_assignment``). ANY is enumerated as its bindings are; a loop's INVARIANT is checked and
its VARIANT must decrease at each iteration, or the error names the loop."""

from __future__ import annotations

from typing import Callable

from ..errors import UnsupportedError
from . import ast
from .evaluation import Compiler, Env
from .finite import finite as _finite
from .memo import fresh

__all__ = ["Enumeration", "Outcomes", "after", "MAX_OUTCOMES", "MAX_ITERATIONS"]

Outcomes = Callable[[Env], list]

#: Outcomes of one substitution listed at most (ANY, CHOICE, :: inside a sequence).
MAX_OUTCOMES = 10_000
#: Iterations of one WHILE loop run at most.
MAX_ITERATIONS = 100_000


class Enumeration:
    """``outcomes(s)`` and its rules, one ``o_<Node>`` per substitution."""

    comp: Compiler

    def outcomes(self, s: ast.Subst) -> Outcomes:
        """``env -> [updates, …]``: every state ``s`` can reach from ``env`` (as ANY is
        enumerated; at most :data:`MAX_OUTCOMES`), each as the variables it wrote."""
        method = getattr(self, "o_" + type(s).__name__, None)
        if method is None:
            raise self.comp.error(
                UnsupportedError, s, f"not supported: listing the outcomes of "
                f"`{self.comp.text(s)}` inside a sequence, a VAR or a WHILE",
                hint="write it last in the sequence, or as x :: S")
        return method(s)

    def o_Skip(self, s: ast.Skip) -> Outcomes:
        return lambda env: [{}]

    def o_Assign(self, s: ast.Assign) -> Outcomes:
        run = self._assignment(s)
        return lambda env: [run(env)]

    def o_BecomesIn(self, s: ast.BecomesIn) -> Outcomes:
        values, ids = self.comp.compile(s.set), s.ids

        def becomes(env: Env) -> list:
            out = []
            for v in _finite(self.comp, s.set, values(env)):
                parts = []
                for _ in ids[1:]:
                    v, last = v
                    parts.append(last)
                out.append(dict(zip(ids, [v] + parts[::-1])))
            return _capped(self.comp, s, out)
        return becomes

    def o_Parallel(self, s: ast.Parallel) -> Outcomes:
        parts = [self.outcomes(i) for i in s.items]

        def parallel(env: Env) -> list:
            out: list = [{}]
            for p in parts:
                out = _capped(self.comp, s, [dict(a, **b) for a in out for b in p(env)])
            return out
        return parallel

    def o_Sequence(self, s: ast.Sequence) -> Outcomes:
        parts = [self.outcomes(i) for i in s.items]

        def sequence(env: Env) -> list:
            runs = [({}, env)]
            for p in parts:
                runs = _capped(self.comp, s, [(dict(done, **upd), after(here, upd))
                                              for done, here in runs for upd in p(here)])
            return [done for done, _ in runs]
        return sequence

    def o_Pre(self, s) -> Outcomes:
        cond = self.comp.compile(s.guard if isinstance(s, ast.Pre) else s.cond)
        body = self.outcomes(s.body)
        return lambda env: body(env) if cond(env) else []

    o_Assert = o_Pre

    def o_Select(self, s) -> Outcomes:
        first_only = isinstance(s, ast.IfSubst)
        branches = [(self.comp.compile(c), self.outcomes(b)) for c, b in s.branches]
        other = self.outcomes(s.else_) if s.else_ is not None else (
            (lambda env: [{}]) if first_only else (lambda env: []))

        def branching(env: Env) -> list:
            out, taken = [], False
            for cond, body in branches:
                if cond(env):
                    taken = True
                    out += body(env)
                    if first_only:
                        break
            return _capped(self.comp, s, out) if taken else other(env)
        return branching

    o_IfSubst = o_Select

    def o_Choice(self, s: ast.Choice) -> Outcomes:
        parts = [self.outcomes(i) for i in s.items]
        return lambda env: _capped(self.comp, s, [u for p in parts for u in p(env)])

    def o_Any(self, s: ast.Any) -> Outcomes:
        with self.comp.binding(s.ids):
            bind = self.comp.bindings(s, s.ids, s.pred)
            body = self.outcomes(s.body)

        def any_(env: Env) -> list:
            out, local = [], fresh(env)
            for problem in bind(local):
                if problem is not None:
                    raise problem
                out += body(fresh(local))
                _capped(self.comp, s, out)
            return out
        return any_

    def o_LetSubst(self, s: ast.LetSubst) -> Outcomes:
        with self.comp.binding(s.ids):
            assign = self.comp.let_values(s, s.ids, s.pred)
            body = self.outcomes(s.body)

        def let(env: Env) -> list:
            local = fresh(env)
            assign(local)
            return body(local)
        return let

    def o_VarSubst(self, s: ast.VarSubst) -> Outcomes:
        with self.comp.binding(s.ids):
            body = self.outcomes(s.body)
        ids = frozenset(s.ids)

        def var(env: Env) -> list:
            local = fresh(env)
            for i in ids:
                local.pop(i, None)  # a local has no value until the body gives it one
            return [{k: v for k, v in upd.items() if k not in ids} for upd in body(local)]
        return var

    def o_While(self, s: ast.While) -> Outcomes:
        cond, body = self.comp.compile(s.cond), self.outcomes(s.body)
        invariant, variant = self.comp.compile(s.invariant), self.comp.compile(s.variant)
        line = s.pos.line if s.pos else "?"

        def measure(env: Env, turns: int) -> int:
            v = self.comp.int_of(s.variant, variant(env))
            if v < 0:
                raise self.comp.wd(s.variant, f"the VARIANT of the WHILE loop at line {line} "
                                              f"is {v} < 0 after {turns} iteration(s)")
            return v

        def loop(env: Env) -> list:
            done_runs, runs = [], [({}, env)]
            for turns in range(MAX_ITERATIONS + 1):
                nxt = []
                for done, here in runs:
                    if invariant(here) is not True:
                        raise self.comp.wd(s.invariant, f"the INVARIANT of the WHILE loop at "
                                                        f"line {line} is false after {turns} "
                                                        "iteration(s)")
                    if cond(here) is not True:
                        done_runs.append(done)
                        continue
                    before = measure(here, turns)
                    for upd in body(here):
                        then = after(here, upd)
                        if measure(then, turns + 1) >= before:
                            raise self.comp.wd(s.variant, f"the VARIANT of the WHILE loop at "
                                                          f"line {line} does not decrease at "
                                                          f"iteration {turns + 1}")
                        nxt.append((dict(done, **upd), then))
                runs = _capped(self.comp, s, nxt)
                if not runs:
                    return _capped(self.comp, s, done_runs)
            raise self.comp.error(UnsupportedError, s,
                                  f"the WHILE loop at line {line} runs more than "
                                  f"{MAX_ITERATIONS:,} iterations (tracecheck's limit)")
        return loop


def after(env: Env, upd: dict) -> Env:
    """``env`` once ``upd`` is done (the remembered values dropped)."""
    out = fresh(env)
    out.update(upd)
    return out


def _capped(comp: Compiler, s: ast.Subst, items: list) -> list:
    if len(items) > MAX_OUTCOMES:
        raise comp.error(UnsupportedError, s, f"more than {MAX_OUTCOMES:,} possible outcomes "
                         "(tracecheck's limit on listing them)")
    return items
