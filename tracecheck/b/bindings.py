"""Bound variables: which conjunct of a quantifier's, comprehension's or lambda's predicate
gives each variable its values, walking them, and compiling the binding forms themselves
(:class:`Binders`: quantifiers, comprehensions, lambdas, SIGMA/PI/UNION/INTER, LET).

A walk yields None for each solution and, for values where the predicate is not
well-defined, the error instead: the caller decides after seeing every value (see
:class:`Strict`), so that no answer depends on the order in which a set happens to be
walked."""

from __future__ import annotations

from typing import Any, Callable, Iterator, Optional

from ..errors import (BTypeError, EvaluationError, TracecheckError,
                      UnsupportedError, WellDefinednessError)
from ..limits import MAX_INT_BITS
from . import ast
from .ast import conjuncts, membership_of  # where they are defined
from .clock import tick
from .printer import to_b
from .strict import Strict, each
from .defined import Defined, cannot_list
from .finite import finite as _finite, members as _members
from .values import FuncValue, SymbolicSet, make_set, sort_key

__all__ = ["generators", "conjuncts", "domain", "Binders", "Strict", "membership_of"]

Env = dict
Fn = Callable[[Env], Any]


def generators(comp, node: ast.Node, ids: tuple[str, ...], pred: ast.Node):
    """Plan how to enumerate ``ids`` satisfying ``pred`` (see :meth:`Compiler.bindings`)."""
    conjs = conjuncts(pred)
    plan: list[tuple[tuple[str, ...], str, Fn]] = []
    origin: list[tuple[Optional[int], frozenset]] = []  # each step's conjunct, bound before
    bound, used = set(), set()
    while True:  # each round plans the first variable (in ids order) that can be walked now
        waiting = [n for n in ids if n not in bound]
        if not waiting:
            break
        for name in waiting:
            step = _plan_one(comp, node, conjs, name, ids, bound, used)
            if step is not None:
                gen, k = step
                plan.append(gen)
                origin.append((k, frozenset(bound)))
                bound |= set(gen[0])
                if k is not None:
                    used.add(k)
                break
        else:  # nothing walks it: its type, where that is BOOL or a set's elements
            name = waiting[0]
            problem = comp.error(
                EvaluationError, node,
                f"cannot enumerate {name} in `{comp.text(node)}`",
                hint=f"add a conjunct that bounds it to a finite set, e.g. {name} : S")
            origin.append((None, frozenset()))
            if comp.solver is not None:  # all the rest at once, by the solver's answers
                plan.append(_by_solver(comp, tuple(waiting), pred, problem))
                bound |= set(waiting)
                continue
            plan.append(_by_type(name, ids, pred, problem))
            bound.add(name)
    filters = [comp.compile(c) for k, c in enumerate(conjs) if k not in used]
    guards = [_guards(comp, conjs, ids, used, k, before) for k, before in origin]

    def walked(env: Env, depth: int) -> Any:
        """What step ``depth`` walks; None where a conjunct before its own is false (B
        reads left to right: 12 / r at r = 0 after r /= 0 is never computed); else the
        error where it cannot be computed (the walk yields it, as a filter's)."""
        try:
            return plan[depth][2](env)
        except TracecheckError as exc:
            try:
                return None if any(not g(env) for g in guards[depth]) else exc
            except TracecheckError as before:  # a conjunct before it not well-defined
                return before

    def run(env: Env, depth: int = 0) -> Iterator[Optional[TracecheckError]]:
        if depth == len(plan):
            try:
                for f in filters:
                    if not f(env):
                        return
            except TracecheckError as exc:  # not well-defined for these values
                yield exc
                return
            yield None
            return
        names, mode, _ = plan[depth]
        values = walked(env, depth)
        if isinstance(values, TracecheckError):
            yield values
            return
        for value in domain(comp, node, mode, values) if values is not None else ():
            tick()
            if len(names) == 1:
                env[names[0]] = value
            else:
                if not _unpack(names, value, env):
                    continue
            yield from run(env, depth + 1)

    if len(plan) == 1 and len(plan[0][0]) == 1 and plan[0][1] == "in":
        (name,), _, _ = plan[0]

        def run_single(env: Env) -> Iterator[Optional[TracecheckError]]:  # the common case
            values = walked(env, 0)
            if isinstance(values, TracecheckError):
                yield values
                return
            for value in domain(comp, node, "in", values) if values is not None else ():
                tick()
                env[name] = value
                try:
                    for f in filters:
                        if not f(env):
                            break
                    else:
                        yield None
                except TracecheckError as exc:  # not well-defined for this value
                    yield exc
        return run_single
    return run


def _guards(comp, conjs, ids, used, k: Optional[int], before: frozenset) -> list:
    """The conjuncts before conjunct ``k`` that guard its walk as B reads them, left to
    right: those that read only variables bound (``before``; those that walk one, in
    ``used``, hold by construction) — past one that relates a variable not yet bound to
    an expression of the others (``p : 0..5``, well-defined for every p where the
    expression is: it is evaluated), up to the first other one (``y / r > 0``: what it
    needs is not known yet)."""
    out = []
    for j, c in enumerate(conjs[:k or 0]):
        if ast.free_names(c) & set(ids) <= before:
            if j not in used:
                out.append(comp.compile(c))
            continue
        other = _other_side(c, ids, before)
        if other is None:
            break
        side = comp.compile(other)
        out.append(lambda env, side=side: side(env) is not None)  # True: well-defined
    return out


def _other_side(c: ast.Node, ids, before: frozenset) -> Optional[ast.Node]:
    """``E`` of ``v op E`` or ``E op v`` (a comparison or membership) for a variable ``v``
    not yet bound and ``E`` reading only bound ones; None for any other conjunct."""
    if not isinstance(c, ast.Rel) or c.op not in _RELATIONS:
        return None
    for v, e in ((c.left, c.right), (c.right, c.left)):
        if isinstance(v, ast.Name) and v.id in ids and v.id not in before and \
                ast.free_names(e) & set(ids) <= before:
            return e
    return None


_RELATIONS = frozenset({":", "/:", "<:", "<<:", "/<:", "/<<:", "=", "/=", "<", "<=", ">",
                        ">="})


def _product(comp, node: ast.Node, values: list) -> Any:
    """PI's product, refused (a limit, as ``*``) once an integer would pass the bits
    ``*`` allows — checked before each multiplication, not after a product of 10^6 bits."""
    out: Any = 1
    for v in values:
        if type(v) is int and type(out) is int and \
                out.bit_length() + v.bit_length() > MAX_INT_BITS:
            raise comp.too_large(node, "PI")
        out = out * v
    return out


def _by_type(name: str, ids: tuple[str, ...], pred: ast.Node, problem: TracecheckError):
    """A generator of ``name`` over its type, as the predicate types it with the values of
    the names it reads (found once, when first walked): ``{TRUE, FALSE}`` for BOOL, the
    elements of an enumerated or deferred set; ``problem`` (cannot enumerate) otherwise."""
    outer = sorted(ast.free_names(pred) - set(ids))
    found: list = []

    def source(env: Env):
        if not found:
            found.append(_type_domain(name, ids, pred, outer, env, problem))
        return found[0]
    return (name,), "in", source


def _by_solver(comp, names: tuple[str, ...], pred: ast.Node, problem: TracecheckError):
    """A generator of ``names`` over every solution of ``pred`` for them, with the values
    the other names have (``comp.solver``: all of them, or an error saying why not — a
    solver that cannot list every solution never gives a part of them)."""
    def source(env: Env):
        solutions = comp.solver(pred, names, env, problem)
        values = []
        for found in solutions:
            value = found[names[0]]
            for n in names[1:]:
                value = (value, found[n])
            values.append(value)
        return values
    return names, "solved", source


def _type_domain(name, ids, pred, outer, env: Env, problem: TracecheckError):
    from .btypes import BOOL, Base, resolve_all
    from .typecheck import Typer, type_of_value
    from .values import Elem

    owners = {e: k for k in outer if isinstance(env.get(k), frozenset)
              for e in env[k] if isinstance(e, Elem)}
    sets = {k: v for k, v in env.items() if isinstance(v, frozenset) and v and
            all(isinstance(e, Elem) for e in v)}
    owners.update({e: k for k, v in sets.items() for e in v})
    try:
        typer = Typer({k: type_of_value(env[k], owners) for k in outer if k in env})
        scope = typer.bound(ids)
        typer.pred(pred)
    except TracecheckError:
        raise problem from None
    kind = resolve_all(scope[name])
    if kind == BOOL:
        return frozenset({False, True})
    if isinstance(kind, Base) and kind.name in sets:
        return sets[kind.name]
    raise problem


def _plan_one(comp, node, conjs, name, ids, bound, used):
    """(a generator of ``name`` from the conjuncts, the conjunct it uses or None) once the
    variables in ``bound`` have values; None where none can walk it yet."""
    options = []
    for k, conj in enumerate(conjs):
        if k in used:
            continue
        gen = _generator_for(comp, conj, name, ids, bound)
        if gen is not None:
            options.append((_cost(gen[1], conj), k, gen))
    best = min(options, key=lambda o: o[:2]) if options else None
    between = _interval_for(comp, node, conjs, name, ids, bound) \
        if best is None or best[0] == 2 else None  # none, or only x : INTEGER and such
    if between is not None:  # the comparisons stay filters: the range only walks
        return between, None
    if best is not None and best[0] == 2 and comp.solver is not None and \
            _infinite_set(conjs[best[1]]) and any(
                k != best[1] and name in ast.free_names(c) for k, c in enumerate(conjs)):
        return None  # x : INTEGER and more of x: the solver's answers, not INTEGER's
    # (x : INTEGER alone: as many values as the set, which no solver lists either)
    if best is not None:
        return best[2], best[1]
    return None


_HUGE_SETS = frozenset({"INTEGER", "NATURAL", "NATURAL1", "REAL", "FLOAT", "STRING", "INT",
                        "NAT", "NAT1"})


def _infinite_set(conj: ast.Node) -> bool:
    """``x : INTEGER`` (NATURAL, NATURAL1, REAL, FLOAT, STRING): an infinite built-in set;
    NAT and INT are finite (up to MAXINT), walked or refused as ever."""
    right = conj.right if isinstance(conj, ast.Rel) else None
    return isinstance(right, ast.Name) and right.id in _HUGE_SETS - {"INT", "NAT", "NAT1"}


def _cost(mode: str, conj: ast.Node) -> int:
    """Which conjunct enumerates a variable best: ``x = E`` (one value), then a set, then a
    built-in set too large to walk (``x : INTEGER & x = 3`` takes x from ``x = 3``)."""
    if mode == "eq":
        return 0
    right = conj.right if isinstance(conj, ast.Rel) else None
    return 2 if isinstance(right, ast.Name) and right.id in _HUGE_SETS else 1


def _unpack(names: tuple[str, ...], value: Any, env: Env) -> bool:
    if not isinstance(value, tuple):
        return False
    for name in reversed(names[1:]):
        if not isinstance(value, tuple):
            return False
        value, env[name] = value
    env[names[0]] = value
    return True


def domain(comp, node: ast.Node, mode: str, value: Any):
    if mode == "eq":
        return (value,)
    if mode == "solved":
        return value
    if mode == "sub":
        items = sorted(_finite(comp, node, value), key=repr)
        if len(items) > 16:
            raise comp.error(EvaluationError, node,
                             f"too many subsets to enumerate (2^{len(items)})")
        from itertools import combinations
        return [frozenset(c) for k in range(len(items) + 1) for c in combinations(items, k)]
    if isinstance(value, frozenset):
        return value
    if isinstance(value, SymbolicSet) and value.finiteness() is True:
        return _members(comp, node, value)
    if isinstance(value, SymbolicSet):
        what = "the infinite set" if value.finiteness() is False else \
            "the set, not known to be finite,"
        raise comp.error(EvaluationError, node,
                         f"cannot enumerate {what} {value.name} in `{comp.text(node)}`",
                         hint="bound the variable by a finite set")
    raise comp.type_error(node, value, "a set")


#: a comparison of the variable with a bound, as (the variable's side, the bound's side):
#: ``x > E`` is a lower bound E + 1 on the left; ``E > x`` an upper bound E - 1
#: the lower bound membership in a set of natural numbers implies (the membership stays a
#: filter: NAT's upper end MAXINT too)
_NATURALS = {"NATURAL": 0, "NAT": 0, "NATURAL1": 1, "NAT1": 1}
_LOWER = {(">", "left"): 1, (">=", "left"): 0, ("<", "right"): 1, ("<=", "right"): 0}
_UPPER = {("<", "left"): -1, ("<=", "left"): 0, (">", "right"): -1, (">=", "right"): 0}


def _interval_for(comp, node: ast.Node, conjs: list[ast.Node], name: str,
                  ids: tuple[str, ...], bound: set[str]):
    """A generator of ``name`` over the integers its comparisons bound (``x > 0 & x < 4``
    walks 1..3; ``x >= a & x <= b`` with a and b known), where it has both a lower and an
    upper one; None where it has not. The bounds must be integers when evaluated (a REAL
    variable is not walked: a located error says so)."""
    lows, highs = [], []
    pending = set(ids) - bound
    for conj in conjs:
        if isinstance(conj, ast.Rel) and conj.op == ":" and isinstance(conj.left, ast.Name) and conj.left.id == name and \
                isinstance(conj.right, ast.Name) and conj.right.id in _NATURALS:
            zero = ast.IntLit(_NATURALS[conj.right.id], pos=conj.pos)  # x : NATURAL: x >= 0
            lows.append((comp.compile(zero), 0, zero))
            continue
        if not isinstance(conj, ast.Rel) or conj.op not in ("<", "<=", ">", ">="):
            continue
        for side, other in (("left", conj.right), ("right", conj.left)):
            mine = conj.left if side == "left" else conj.right
            if not (isinstance(mine, ast.Name) and mine.id == name) or \
                    ast.free_names(other) & pending:
                continue
            if (conj.op, side) in _LOWER:
                lows.append((comp.compile(other), _LOWER[conj.op, side], other))
            else:
                highs.append((comp.compile(other), _UPPER[conj.op, side], other))
    if not lows or not highs:
        return None

    def end(env: Env, parts, pick) -> int:
        found = []
        for fn, shift, expr in parts:
            value = fn(env)
            if type(value) is not int:
                raise comp.error(EvaluationError, expr,
                                 f"cannot enumerate {name} in `{comp.text(node)}`: its bound "
                                 f"`{comp.text(expr)}` is not an integer",
                                 hint=f"a REAL variable is not enumerated; bound it by a "
                                      f"finite set, e.g. {name} : S")
            found.append(value + shift)
        return pick(found)

    def interval(env: Env):
        from .values import Interval

        return Interval(end(env, lows, max), end(env, highs, min))
    return (name,), "in", interval


def _names_in_pair(node: ast.Node) -> Optional[tuple[str, ...]]:
    if isinstance(node, ast.Name):
        return (node.id,)
    if isinstance(node, ast.Pair):
        left, right = _names_in_pair(node.left), _names_in_pair(node.right)
        if left and right and isinstance(node.right, ast.Name):
            return left + right
    return None


def _generator_for(comp, conj, name, ids, bound):
    if (isinstance(conj, ast.Or) and isinstance(conj.left, ast.Rel)
            and isinstance(conj.right, ast.Rel) and conj.left.op == conj.right.op == ":"
            and conj.left.left == conj.right.left):
        # x : A or x : B enumerates x over A \/ B
        union = ast.BinOp("\\/", conj.left.right, conj.right.right, pos=conj.pos)
        conj = ast.Rel(":", conj.left.left, union, pos=conj.pos)
    if not isinstance(conj, ast.Rel) or conj.op not in (":", "=", "<:"):
        return None
    names = _names_in_pair(conj.left)
    if conj.op == ":" and (not names or any(n in bound or n not in ids for n in names)):
        return _pair_side(comp, conj, name, ids, bound)
    if not names or name not in names or any(n in bound or n not in ids for n in names):
        return None
    if conj.op != ":" and len(names) != 1:
        return None
    pending = set(ids) - bound
    if ast.free_names(conj.right) & pending:
        return None
    mode = {":": "in", "=": "eq", "<:": "sub"}[conj.op]
    return names, mode, comp.compile(conj.right)


def _pair_side(comp, conj, name, ids, bound):
    """``E |-> x : R`` (or ``x |-> E : R``) with E known: x over the image of E under R
    (under its inverse)."""
    pair = conj.left
    if not isinstance(pair, ast.Pair):
        return None
    pending = set(ids) - bound
    for mine, other, side in ((pair.right, pair.left, 1), (pair.left, pair.right, 0)):
        if isinstance(mine, ast.Name) and mine.id == name and name in pending and \
                not ast.free_names(other) & pending and \
                not ast.free_names(conj.right) & pending:
            key, rel = comp.compile(other), comp.compile(conj.right)

            def image(env: Env, key=key, rel=rel, side=side):
                k = key(env)
                return frozenset(p[side] for p in _finite(comp, conj, rel(env))
                                 if isinstance(p, tuple) and p[1 - side] == k)
            return (name,), "in", image
    return None


class Binders:
    """The binding forms of :class:`tracecheck.b.evaluation.Compiler` (a base class of it):
    quantifiers, comprehensions, lambdas, SIGMA/PI/UNION/INTER and LET. They use the
    compiler's ``compile``, ``binding``, ``error`` and ``wd``."""

    def c_Quant(self, node: ast.Quant) -> Fn:
        if node.op == "!":
            if not isinstance(node.body, ast.Implies):
                raise self.error(BTypeError, node,
                                 "the body of a universal quantifier must be an implication",
                                 hint="write !x.(x : S => P)")
            domain_pred, rest = node.body.left, node.body.right
            with self.binding(node.ids):
                bindings = self.bindings(node, node.ids, domain_pred)
                check = self.compile(rest)

            return _scoped(self._witnessed(node, self.quantifier(node, bindings, check),
                                           domain_pred, ast.And(domain_pred, ast.Not(rest))),
                           node.ids)
        with self.binding(node.ids):
            bindings = self.bindings(node, node.ids, node.body)
        return _scoped(self._witnessed(node, self.quantifier(node, bindings, None),
                                       node.body, node.body), node.ids)

    def _witnessed(self, node: ast.Quant, quant: Fn, walked: ast.Node,
                   witness: ast.Node) -> Fn:
        """``quant``, or — where the solver cannot list every value of its variables
        (``#x.(x : NAT1 & x mod 3 = 0)``) — the solver asked for one value of ``witness``
        (the body of ∃; P & not Q for ∀ of P => Q): one is TRUE for ∃ and FALSE for ∀,
        none the other way; defined everywhere, or the solver's error."""
        if self.solver is None:
            return quant
        ids, solver = node.ids, self.solver

        def decided(env: Env) -> bool:
            try:
                return quant(env)
            except TracecheckError as exc:
                if isinstance(exc, WellDefinednessError) or not (
                        getattr(exc, "unlisted", None) is walked
                        or isinstance(exc, EvaluationError) and cannot_list(exc)):
                    raise
                problem = getattr(exc, "asked", exc)
            found = solver(witness, ids, {k: v for k, v in env.items() if k not in ids},
                           problem, one=True)
            return bool(found) == (node.op == "#")
        return decided

    def quantifier(self, node: ast.Quant, bindings, check: Optional[Fn]) -> Fn:
        """∀ (with ``check``, the implication's right side) or ∃ (``check`` None), decided
        after every value was tried (see :class:`Strict`)."""
        ids = node.ids
        if check is None:
            return lambda env: bool(each(bindings, ids, env, lambda e: True))
        return lambda env: all(each(bindings, ids, env, check))

    def bindings(self, node: ast.Node, ids: tuple[str, ...], pred: ast.Node
                 ) -> Callable[[Env], Iterator[Optional[TracecheckError]]]:
        """A function that binds ``ids`` in ``env`` to each solution of ``pred`` in turn.

        Each variable needs a conjunct that enumerates it (``x : S``, ``x = E``,
        ``x |-> y : R`` or ``x <: S``); the other conjuncts filter.
        """
        return generators(self, node, ids, pred)

    def c_Comprehension(self, node: ast.Comprehension) -> Fn:
        with self.binding(node.ids):
            bind = self.bindings(node, node.ids, node.pred)
            if node.expr is not None:
                value = self.compile(node.expr)
            else:
                value = _tuple_of(node.ids)
        ids = node.ids
        listed = _scoped(lambda env: make_set(each(bind, ids, env, value)), ids)
        return listed if node.expr is not None else self._held(node, listed, None)

    def c_Lambda(self, node: ast.Lambda) -> Fn:
        with self.binding(node.ids):
            bind = self.bindings(node, node.ids, node.pred)
            key, value = _tuple_of(node.ids), self.compile(node.expr)
        ids = node.ids
        listed = _scoped(lambda env: FuncValue(dict(each(bind, ids, env,
                                                          lambda e: (key(e), value(e))))), ids)
        return self._held(node, listed, value)

    def _held(self, node, listed: Fn, value: Optional[Fn]) -> Fn:
        """``listed``, or where its values cannot be listed (``{x | x > 1000}``, ``%x.(x :
        INTEGER | x * x)``) the set held by its definition (:mod:`.defined`)."""
        with self.binding(node.ids):
            test = self.compile(node.pred)
            images = self._images(node) if value is None and len(node.ids) > 1 else None
        text, free = self.text(node), tuple(sorted(ast.free_names(node)))
        canon = to_b(node)  # what the set is (its text may be a DEFINITION's, shared)

        def held(env: Env) -> Any:
            try:
                return listed(env)
            except EvaluationError as exc:
                if not cannot_list(exc):
                    raise
                return Defined(node.ids, test, value, env, text,
                               lambda message: self.wd(node, message), free, exc, images,
                               canon)
        return held

    def _images(self, node: ast.Comprehension) -> Callable[[Env, Any], list]:
        """For ``{x, y | P}``: the values of y with x bound (as a binder finds them: by
        the conjuncts, or the solver's complete list), each once, in order."""
        last = node.ids[-1]
        rest = self.bindings(node, (last,), node.pred)

        def images(env: Env, arg: Any) -> list:
            found = each(rest, (last,), env, lambda e: e[last])
            return sorted(set(found), key=sort_key)
        return images

    def c_QuantExpr(self, node: ast.QuantExpr) -> Fn:
        with self.binding(node.ids):
            bind = self.bindings(node, node.ids, node.pred)
            value = self.compile(node.expr)
        op = node.op

        def quant(env: Env) -> Any:
            values = each(bind, node.ids, env, value)
            if op == "SIGMA":
                return sum(values, 0)
            if op == "PI":
                return _product(self, node, values)
            if op == "UNION":
                return frozenset().union(*values)
            if not values:
                raise self.wd(node, "INTER over no sets")
            return frozenset.intersection(*values)
        return _scoped(quant, node.ids)

    def c_Let(self, node: ast.Let) -> Fn:
        with self.binding(node.ids):
            assign = self.let_values(node, node.ids, node.pred)
            body = self.compile(node.body)

        def let(env: Env) -> Any:
            assign(env)
            return body(env)
        return _scoped(let, node.ids)

    def let_values(self, node, ids, pred) -> Callable[[Env], None]:
        """``LET x BE x = E & P IN …``: E gives x; the other conjuncts must hold."""
        eqs: dict[str, ast.Node] = {}
        rest: list[ast.Node] = []
        for conj in conjuncts(pred):
            if (isinstance(conj, ast.Rel) and conj.op == "=" and isinstance(conj.left, ast.Name)
                    and conj.left.id in ids and conj.left.id not in eqs):
                eqs[conj.left.id] = conj.right
            else:
                rest.append(conj)
        missing = [i for i in ids if i not in eqs]
        if missing:
            raise self.error(UnsupportedError, node,
                             f"LET needs an equation `{missing[0]} = …` for each variable")
        # each equation after those of the LET variables it uses (in any written order)
        ordered: list[str] = []
        while len(ordered) < len(ids):
            ready = [i for i in ids if i not in ordered
                     and not (ast.free_names(eqs[i]) & (set(ids) - set(ordered)))]
            if not ready:
                cyclic = next(i for i in ids if i not in ordered)
                raise self.error(BTypeError, eqs[cyclic],
                                 f"the LET equations define {cyclic} in terms of itself")
            ordered.extend(ready)
        checks = [(c, self.compile(c)) for c in rest]
        order = [(i, self.compile(eqs[i])) for i in ordered]

        def assign(env: Env) -> None:
            for name, fn in order:
                env[name] = fn(env)
            for c, fn in checks:
                if not fn(env):
                    raise self.wd(c, "the LET condition does not hold")
        return assign


# ------------------------------------------------------------------ helpers


_MISSING = object()


def _tuple_of(ids: tuple[str, ...]) -> Fn:
    if len(ids) == 1:
        name = ids[0]
        return lambda env: env[name]

    def pair(env: Env) -> Any:
        value = env[ids[0]]
        for i in ids[1:]:
            value = (value, env[i])
        return value
    return pair


def _scoped(fn: Fn, ids: tuple[str, ...]) -> Fn:
    """Run ``fn`` and restore whatever ``ids`` meant in ``env`` before."""
    if len(ids) == 1:
        (name,) = ids

        def scoped_one(env: Env) -> Any:
            old = env.get(name, _MISSING)
            try:
                return fn(env)
            finally:
                if old is _MISSING:
                    env.pop(name, None)
                else:
                    env[name] = old
        return scoped_one

    def scoped(env: Env) -> Any:
        saved = [env.get(i, _MISSING) for i in ids]
        try:
            return fn(env)
        finally:
            for i, old in zip(ids, saved):
                if old is _MISSING:
                    env.pop(i, None)
                else:
                    env[i] = old
    return scoped
