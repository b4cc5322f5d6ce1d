"""Substitutions, checked rather than run.

A shield's operations say what may follow an action (``VehiclesVx :| (… ≥ VehiclesVx'(Ego)
- 0.05)``); tracecheck never picks a non-deterministic outcome but decides whether a
recorded after-state is one of the allowed outcomes: the before-after predicate of the
operation (the paper's Listing 2). Deterministic substitutions can also be executed.
"""

from __future__ import annotations

from typing import Callable, Optional

from ..errors import UnsupportedError
from . import ast
from .evaluation import Compiler, Env
from .memo import MEMO_KEY, fresh
from .outcomes import Enumeration, after as _after
from .values import cardinality, finiteness, make_set

__all__ = ["written", "guard_of", "SubstCompiler", "strip_guards", "before_after"]

Check = Callable[[Env, dict], bool]


def written(s: ast.Subst) -> frozenset[str]:
    """The variables a substitution may change."""
    if isinstance(s, ast.Assign):
        return frozenset(t.id if isinstance(t, ast.Name) else t.fn.id for t in s.targets)
    if isinstance(s, (ast.BecomesIn, ast.BecomesSuchThat)):
        return frozenset(s.ids)
    if isinstance(s, (ast.Parallel, ast.Sequence, ast.Choice)):
        return frozenset().union(*(written(i) for i in s.items))
    if isinstance(s, (ast.Pre, ast.Assert)):
        return written(s.body)
    if isinstance(s, (ast.Select, ast.IfSubst)):
        out = frozenset().union(*(written(b) for _, b in s.branches))
        return out | (written(s.else_) if s.else_ is not None else frozenset())
    if isinstance(s, (ast.Any, ast.LetSubst, ast.VarSubst)):
        return written(s.body) - frozenset(s.ids)
    if isinstance(s, ast.While):
        return written(s.body)
    return frozenset()


def _and(parts: list[ast.Node]) -> Optional[ast.Node]:
    parts = [p for p in parts if p is not None]
    if not parts:
        return None
    node = parts[0]
    for p in parts[1:]:
        node = ast.And(node, p, pos=p.pos.point() if p.pos else None)
    return node


def guard_of(s: ast.Subst) -> Optional[ast.Node]:
    """The guard of a substitution as a predicate (None when it is always enabled).

    PRE and SELECT contribute their conditions (several WHEN branches: any of them),
    ANY its ``#x.(P)``, parallel parts all their guards, a sequence its first part's.
    """
    if isinstance(s, (ast.Pre, ast.Assert)):
        cond = s.guard if isinstance(s, ast.Pre) else None
        return _and([cond, guard_of(s.body)])
    if isinstance(s, (ast.Select, ast.IfSubst)):
        return _branch_guard(s)
    if isinstance(s, ast.Choice):
        options = [guard_of(i) for i in s.items]
        return None if any(o is None for o in options) else _any_of(options)
    if isinstance(s, ast.Any):
        return ast.Quant("#", s.ids, _and([s.pred, guard_of(s.body)]),
                         pos=s.pos.point() if s.pos else None)
    if isinstance(s, ast.Parallel):
        return _and([guard_of(i) for i in s.items])
    if isinstance(s, ast.Sequence):
        for later in s.items[1:]:
            inner = guard_of(later)
            if inner is not None:
                raise UnsupportedError(
                    "not supported: a guard (PRE, SELECT, ANY, a called operation's PRE) "
                    "after `;`: when the operation is enabled would depend on the state "
                    "halfway through it", line=later.pos.line if later.pos else None,
                    column=later.pos.column if later.pos else None,
                    hint="put the guard before the first `;` (or use || where the parts "
                         "are independent)")
        return guard_of(s.items[0])
    if isinstance(s, ast.LetSubst):
        inner = guard_of(s.body)
        return ast.Let(s.ids, s.pred, inner, pos=s.pos) if inner is not None else None
    if isinstance(s, (ast.VarSubst, ast.While)):
        inner = guard_of(s.body)
        if inner is not None and (isinstance(s, ast.While)
                                  or ast.free_names(inner) & frozenset(s.ids)):
            where = "a WHILE's body" if isinstance(s, ast.While) else "VAR on its locals"
            raise UnsupportedError(
                f"not supported: a guard (PRE, SELECT, ANY) inside {where}: when the "
                "operation is enabled is then known only by running it",
                line=inner.pos.line if inner.pos else None,
                column=inner.pos.column if inner.pos else None,
                hint="put the guard before the loop or the VAR")
        return inner
    return None


def _branch_guard(s) -> Optional[ast.Node]:
    """SELECT's and IF's guard: some branch is taken and its body enabled (IF: the first
    branch whose condition holds; without ELSE, IF's is skip and SELECT's blocks)."""
    bodies = [guard_of(b) for _, b in s.branches]
    other = guard_of(s.else_) if s.else_ is not None else None
    if isinstance(s, ast.Select) and s.else_ is None:
        return _any_of([_and([c, g]) for (c, _), g in zip(s.branches, bodies)])
    if all(g is None for g in bodies) and other is None:
        return None  # an ELSE (or IF's skip) is always there to take
    options, before = [], []
    first_only = isinstance(s, ast.IfSubst)
    for (c, _), g in zip(s.branches, bodies):
        options.append(_and((before if first_only else []) + [c, g]))
        before.append(ast.Not(c, pos=c.pos.point() if c.pos else None))
    options.append(_and(before + [other]) or ast.Rel("=", ast.BoolLit(True),
                                                     ast.BoolLit(True)))
    return _any_of(options)


def _any_of(options: list[ast.Node]) -> ast.Node:
    node = options[0]
    for o in options[1:]:
        node = ast.Or(node, o, pos=o.pos.point() if o.pos else None)
    return node


class SubstCompiler(Enumeration):
    """Compiles a substitution into ``check(pre_env, post) -> bool``.

    ``pre_env`` holds constants, the variables before and any local variables; ``post``
    maps the state variables to their values after. Variables the substitution does not
    write must be unchanged; the caller checks that frame for the whole operation.
    """

    def __init__(self, comp: Compiler) -> None:
        self.comp = comp

    def unchanged(self, names: frozenset[str]) -> Check:
        names = tuple(sorted(names))
        return lambda pre, post: all(post[n] == pre[n] for n in names if n in post)

    def compile(self, s: ast.Subst) -> Check:
        method = getattr(self, "s_" + type(s).__name__, None)
        if method is None:
            raise self.comp.error(UnsupportedError, s,
                                  f"tracecheck cannot check {type(s).__name__} substitutions")
        return method(s)

    def s_Skip(self, s: ast.Skip) -> Check:
        return lambda pre, post: True

    def s_Assign(self, s: ast.Assign) -> Check:
        parts = []
        for target, value in zip(s.targets, s.values):
            val = self.comp.compile(value)
            if isinstance(target, ast.Name):
                name = target.id
                # an output (v <-- Op) is not in the state: its value is not checked
                parts.append(lambda pre, post, name=name, val=val:
                             val(pre) == post[name] if name in post else val(pre) is not None)
            else:
                name = target.fn.id
                key = self.comp.compile(ast.pair_of(target.args))

                def override(pre, post, name=name, key=key, val=val):
                    return post[name] == _override(pre[name], key(pre), val(pre))
                parts.append(override)
        return lambda pre, post: all(p(pre, post) for p in parts)

    def s_BecomesIn(self, s: ast.BecomesIn) -> Check:
        values = self.comp.compile(s.set)
        names = s.ids

        def becomes_in(pre: Env, post: dict) -> bool:
            if names[0] not in post:  # an output: any value of the set (there is one?)
                v = values(pre)
                return finiteness(v) is not True or cardinality(v) > 0
            new = post[names[0]]
            for n in names[1:]:
                new = (new, post[n])
            allowed = values(pre)
            return new in allowed
        return becomes_in

    def s_BecomesSuchThat(self, s: ast.BecomesSuchThat) -> Check:
        pred = self.comp.compile(s.pred)
        names = s.ids
        primed = [(n, n + "'", n + "$0") for n in names]

        def such_that(pre: Env, post: dict) -> bool:
            env = fresh(pre)
            for n, p1, p2 in primed:
                if n in pre:  # an INITIALISATION has no value before
                    env[p1] = env[p2] = pre[n]
                if n not in post:
                    raise self.comp.error(UnsupportedError, s, f"not supported: the output "
                                          f"{n} of `{self.comp.text(s)}` (it is no variable "
                                          "of the state, and its values are not listed)")
                env[n] = post[n]
            return bool(pred(env))
        return such_that

    def s_Parallel(self, s: ast.Parallel) -> Check:
        parts = [self.compile(i) for i in s.items]
        return lambda pre, post: all(p(pre, post) for p in parts)

    def s_Sequence(self, s: ast.Sequence) -> Check:
        head = ast.Sequence(s.items[:-1], pos=s.pos) if len(s.items) > 2 else s.items[0]
        try:
            run = self.execute(head)

            def first(env: Env) -> list:
                mid = run(env)
                return [] if mid is None else [mid]
        except UnsupportedError:  # not deterministic: every outcome, as ANY is enumerated
            first = self.outcomes(head)
        last = self.compile(s.items[-1])
        last_writes = written(s.items[-1])

        def sequence(pre: Env, post: dict) -> bool:
            for mid in first(fresh(pre)):
                untouched = {n: v for n, v in mid.items() if n not in last_writes}
                if last(_after(pre, mid), post) and all(
                        post[n] == v for n, v in untouched.items() if n in post):
                    return True
            return False
        return sequence

    def s_Pre(self, s: ast.Pre) -> Check:
        cond, body = self.comp.compile(s.guard), self.compile(s.body)
        return lambda pre, post: bool(cond(pre)) and body(pre, post)

    def s_Assert(self, s: ast.Assert) -> Check:
        cond, body = self.comp.compile(s.cond), self.compile(s.body)
        return lambda pre, post: bool(cond(pre)) and body(pre, post)

    def _branching(self, s, first_only: bool) -> Check:
        allw = written(s)
        branches = [(self.comp.compile(c), self.compile(b), self.unchanged(allw - written(b)))
                    for c, b in s.branches]
        if s.else_ is not None:
            other = (self.compile(s.else_), self.unchanged(allw - written(s.else_)))
        else:
            other = (None, self.unchanged(allw)) if first_only else None

        def branching(pre: Env, post: dict) -> bool:
            taken = False
            for cond, body, same in branches:
                if cond(pre):
                    taken = True
                    if body(pre, post) and same(pre, post):
                        return True
                    if first_only:
                        return False
            if taken or other is None:
                return False
            body, same = other
            return (body is None or body(pre, post)) and same(pre, post)
        return branching

    def s_Select(self, s: ast.Select) -> Check:
        return self._branching(s, first_only=False)

    def s_IfSubst(self, s: ast.IfSubst) -> Check:
        return self._branching(s, first_only=True)

    def s_Choice(self, s: ast.Choice) -> Check:
        allw = written(s)
        parts = [(self.compile(i), self.unchanged(allw - written(i))) for i in s.items]
        return lambda pre, post: any(p(pre, post) and u(pre, post) for p, u in parts)

    def s_Any(self, s: ast.Any) -> Check:
        with self.comp.binding(s.ids):
            bind = self.comp.bindings(s, s.ids, s.pred)
            body = self.compile(s.body)

        def any_(pre: Env, post: dict) -> bool:
            env = fresh(pre)
            for problem in bind(env):
                if problem is not None:
                    raise problem
                if body(env, post):
                    return True
            return False
        return any_

    def s_LetSubst(self, s: ast.LetSubst) -> Check:
        with self.comp.binding(s.ids):
            assign = self.comp.let_values(s, s.ids, s.pred)
            body = self.compile(s.body)

        def let(pre: Env, post: dict) -> bool:
            env = fresh(pre)
            assign(env)
            return body(env, post)
        return let

    def s_VarSubst(self, s: ast.VarSubst) -> Check:
        return self._by_outcomes(s)

    def s_While(self, s: ast.While) -> Check:
        return self._by_outcomes(s)

    def _by_outcomes(self, s: ast.Subst) -> Check:
        """Whether ``post`` is one of the outcomes of ``s`` (every one enumerated)."""
        run, names = self.outcomes(s), tuple(sorted(written(s)))

        def check(pre: Env, post: dict) -> bool:
            return any(all(post[n] == upd.get(n, pre.get(n)) for n in names if n in post)
                       for upd in run(fresh(pre)))
        return check

    def _assignment(self, s: ast.Assign) -> Callable[[Env], Optional[dict]]:
        """``x, f(a) := E, F`` run: every right side (and argument) in the state before."""
        parts = []
        for target, value in zip(s.targets, s.values):
            key = None if isinstance(target, ast.Name) else self.comp.compile(
                ast.pair_of(target.args))
            name = target.id if isinstance(target, ast.Name) else target.fn.id
            parts.append((name, key, self.comp.compile(value)))

        def assign(env: Env) -> Optional[dict]:
            out: dict = {}
            for name, key, val in parts:
                out[name] = val(env) if key is None else _override(
                    out.get(name, env[name]), key(env), val(env))
            return out
        return assign

    # -- execution of deterministic substitutions
    def execute(self, s: ast.Subst) -> Callable[[Env], Optional[dict]]:
        """``env -> updates`` for a deterministic substitution (None: guard false)."""
        if isinstance(s, ast.Skip):
            return lambda env: {}
        if isinstance(s, ast.Assign):
            return self._assignment(s)
        if isinstance(s, (ast.Parallel, ast.Sequence)):
            parts = [self.execute(i) for i in s.items]
            seq = isinstance(s, ast.Sequence)

            def run(env: Env) -> Optional[dict]:
                out: dict = {}
                local = fresh(env)
                for p in parts:
                    upd = p(local if seq else env)
                    if upd is None:
                        return None
                    out.update(upd)
                    if seq:
                        local.update(upd)
                        local.pop(MEMO_KEY, None)
                return out
            return run
        if isinstance(s, (ast.Pre, ast.Select)) and (isinstance(s, ast.Pre)
                                                      or len(s.branches) == 1):
            cond = self.comp.compile(s.guard if isinstance(s, ast.Pre) else s.branches[0][0])
            body = self.execute(s.body if isinstance(s, ast.Pre) else s.branches[0][1])
            return lambda env: body(env) if cond(env) else None
        if isinstance(s, ast.IfSubst):
            branches = [(self.comp.compile(c), self.execute(b)) for c, b in s.branches]
            other = self.execute(s.else_) if s.else_ is not None else (lambda env: {})

            def run_if(env: Env) -> Optional[dict]:
                for cond, body in branches:
                    if cond(env):
                        return body(env)
                return other(env)
            return run_if
        if isinstance(s, (ast.VarSubst, ast.While)):
            every = self.outcomes(s)

            def run_one(env: Env) -> Optional[dict]:
                found = every(env)
                if len(found) > 1:
                    raise self.comp.error(UnsupportedError, s, "not deterministic here: "
                                          f"{len(found)} possible outcomes")
                return found[0] if found else None
            return run_one
        raise self.comp.error(
            UnsupportedError, s,
            "tracecheck cannot check a sequence whose first part is not deterministic",
            hint="write the non-deterministic part last, or use || instead of ;")


def _override(old, key, value):
    """``old`` (a function, as a set of pairs or a FuncValue) with ``key`` mapped to
    ``value``: what ``f(key) := value`` leaves in ``f``."""
    new = dict(old.map if hasattr(old, "map") else old)
    new[key] = value
    return make_set(list(new.items()))


# ------------------------------------------------------------------ as predicates

TRUE = ast.Rel("=", ast.BoolLit(True), ast.BoolLit(True))


def strip_guards(s: ast.Subst) -> ast.Subst:
    """The effect of a substitution without its top-level guards (PRE/SELECT conditions):
    what replay checks as the postcondition once feasibility was checked on its own."""
    if isinstance(s, (ast.Pre, ast.Assert)):
        return strip_guards(s.body)
    if isinstance(s, ast.Select) and len(s.branches) == 1 and s.else_ is None:
        return strip_guards(s.branches[0][1])
    if isinstance(s, ast.Parallel):
        return ast.Parallel(tuple(strip_guards(i) for i in s.items), pos=s.pos)
    return s


def before_after(s: ast.Subst, variables: tuple[str, ...]) -> Optional[ast.Node]:
    """The before-after predicate of ``s`` over ``v`` (after) and ``v$0`` (before) for each
    variable, frame included; None for forms it does not cover (ANY, LET, sequences,
    function overrides), which are then checked state by state."""
    state = frozenset(variables)
    try:
        body = _ba(s, state)
    except _NoPredicate:
        return None
    return _and([body, _frame(state - written(s))]) or TRUE


class _NoPredicate(Exception):
    pass


def _before(node: ast.Node, state: frozenset[str], keep: frozenset[str] = frozenset()) -> ast.Node:
    """``node`` with every state variable (except ``keep``) read before the step."""
    if isinstance(node, ast.Name):
        name = node.id
        base = name[:-1] if name.endswith("'") else name[:-2] if name.endswith("$0") else name
        if base in state and (base not in keep or base != name):
            return ast.Name(base + "$0", pos=node.pos)
        return node
    bound = frozenset(ast.binders(node))
    return ast.map_children(node, lambda c: _before(c, state - bound, keep - bound))


def _frame(names: frozenset[str]) -> Optional[ast.Node]:
    return _and([ast.Rel("=", ast.Name(n), ast.Name(n + "$0")) for n in sorted(names)])


def _ba(s: ast.Subst, state: frozenset[str]) -> ast.Node:  # noqa: C901
    if isinstance(s, ast.Skip):
        return TRUE
    if isinstance(s, ast.Assign):
        if not all(isinstance(t, ast.Name) for t in s.targets):
            raise _NoPredicate
        return _and([ast.Rel("=", t, _before(v, state), pos=s.pos)
                     for t, v in zip(s.targets, s.values)])
    if isinstance(s, ast.BecomesIn):
        new: ast.Node = ast.Name(s.ids[0])
        for i in s.ids[1:]:
            new = ast.Pair(new, ast.Name(i))
        return ast.Rel(":", new, _before(s.set, state), pos=s.pos)
    if isinstance(s, ast.BecomesSuchThat):
        return _before(s.pred, state, keep=frozenset(s.ids))
    if isinstance(s, ast.Parallel):
        return _and([_ba(i, state) for i in s.items]) or TRUE
    if isinstance(s, (ast.Pre, ast.Assert)):
        cond = s.guard if isinstance(s, ast.Pre) else s.cond
        return _and([_before(cond, state), _ba(s.body, state)])
    if isinstance(s, (ast.Select, ast.IfSubst, ast.Choice)):
        return _branches_ba(s, state)
    raise _NoPredicate


def _branches_ba(s, state) -> ast.Node:
    allw = written(s)
    options: list[ast.Node] = []
    if isinstance(s, ast.Choice):
        for item in s.items:
            options.append(_and([_ba(item, state), _frame(allw - written(item))]) or TRUE)
        return _or(options)
    taken: list[ast.Node] = []
    for cond, body in s.branches:
        guard = _before(cond, state)
        parts = [guard, _ba(body, state), _frame(allw - written(body))]
        if isinstance(s, ast.IfSubst):
            parts += [ast.Not(t) for t in taken]
        options.append(_and(parts))
        taken.append(guard)
    if s.else_ is not None or isinstance(s, ast.IfSubst):
        other = s.else_
        none = [ast.Not(t) for t in taken]
        rest = [_ba(other, state), _frame(allw - written(other))] if other is not None \
            else [_frame(allw)]
        options.append(_and(none + rest) or TRUE)
    return _or(options)


def _or(parts: list[ast.Node]) -> ast.Node:
    node = parts[0]
    for p in parts[1:]:
        node = ast.Or(node, p)
    return node
