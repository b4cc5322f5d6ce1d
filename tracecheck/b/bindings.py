"""Enumerating bound variables: which conjunct of a quantifier's, comprehension's or
lambda's predicate gives each variable its values, and walking them.

A walk yields None for each solution and, for values where the predicate is not
well-defined, the error instead: the caller decides after seeing every value (see
:class:`tracecheck.b.evaluate.Strict`), so that no answer depends on the order in which a
set happens to be walked."""

from __future__ import annotations

from typing import Any, Callable, Iterator, Optional

from ..errors import EvaluationError, TracecheckError
from . import ast as A
from .finite import finite as _finite, members as _members
from .values import SymbolicSet

__all__ = ["generators", "conjuncts", "domain"]

Env = dict
Fn = Callable[[Env], Any]


def conjuncts(node: A.Node) -> list[A.Node]:
    if isinstance(node, A.And):
        return conjuncts(node.left) + conjuncts(node.right)
    return [node]




def generators(comp, node: A.Node, ids: tuple[str, ...], pred: A.Node):
    """Plan how to enumerate ``ids`` satisfying ``pred`` (see :meth:`Compiler.bindings`)."""
    conjs = conjuncts(pred)
    plan: list[tuple[tuple[str, ...], str, Fn]] = []
    bound: set[str] = set()
    used: set[int] = set()
    for name in ids:
        if name in bound:
            continue
        options = []
        for k, conj in enumerate(conjs):
            if k in used:
                continue
            gen = _generator_for(comp, conj, name, ids, bound)
            if gen is not None:
                options.append((_cost(gen[1], conj), k, gen))
        if options:
            _, k, gen = min(options, key=lambda o: o[:2])
            plan.append(gen)
            bound |= set(gen[0])
            used.add(k)
        else:
            problem = comp.error(
                EvaluationError, node,
                f"cannot enumerate {name} in `{comp.text(node)}`",
                hint=f"add a conjunct that bounds it to a finite set, e.g. {name} : S")

            def fail(env: Env, problem=problem):
                raise problem
                yield  # pragma: no cover
            return fail
    filters = [comp.compile(c) for k, c in enumerate(conjs) if k not in used]

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
        names, mode, source = plan[depth]
        for value in domain(comp, node, mode, source(env)):
            if len(names) == 1:
                env[names[0]] = value
            else:
                if not _unpack(names, value, env):
                    continue
            yield from run(env, depth + 1)

    if len(plan) == 1 and len(plan[0][0]) == 1 and plan[0][1] == "in":
        (name,), _, source = plan[0]

        def run_single(env: Env) -> Iterator[Optional[TracecheckError]]:
            for value in domain(comp, node, "in", source(env)):
                env[name] = value
                try:
                    for f in filters:
                        if not f(env):
                            break
                    else:
                        yield None
                except TracecheckError as exc:  # not well-defined for this value
                    yield exc
        run_single.simple = (name, source, filters)  # type: ignore[attr-defined]
        return run_single
    return run


_HUGE_SETS = frozenset({"INTEGER", "NATURAL", "NATURAL1", "REAL", "FLOAT", "STRING", "INT",
                        "NAT", "NAT1"})


def _cost(mode: str, conj: A.Node) -> int:
    """Which conjunct enumerates a variable best: ``x = E`` (one value), then a set, then a
    built-in set too large to walk (``x : INTEGER & x = 3`` takes x from ``x = 3``)."""
    if mode == "eq":
        return 0
    right = conj.right if isinstance(conj, A.Rel) else None
    return 2 if isinstance(right, A.Name) and right.id in _HUGE_SETS else 1


def _unpack(names: tuple[str, ...], value: Any, env: Env) -> bool:
    if not isinstance(value, tuple):
        return False
    for name in reversed(names[1:]):
        if not isinstance(value, tuple):
            return False
        value, env[name] = value
    env[names[0]] = value
    return True


def domain(comp, node: A.Node, mode: str, value: Any):
    if mode == "eq":
        return (value,)
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
        raise comp.error(EvaluationError, node,
                         f"cannot enumerate the infinite set {value.name} in "
                         f"`{comp.text(node)}`",
                         hint="bound the variable by a finite set")
    raise comp.type_error(node, value, "a set")


def _names_in_pair(node: A.Node) -> Optional[tuple[str, ...]]:
    if isinstance(node, A.Name):
        return (node.id,)
    if isinstance(node, A.Pair):
        left, right = _names_in_pair(node.left), _names_in_pair(node.right)
        if left and right and isinstance(node.right, A.Name):
            return left + right
    return None


def _generator_for(comp, conj, name, ids, bound):
    if (isinstance(conj, A.Or) and isinstance(conj.left, A.Rel) and isinstance(conj.right, A.Rel)
            and conj.left.op == conj.right.op == ":" and conj.left.left == conj.right.left):
        # x : A or x : B enumerates x over A \/ B
        union = A.BinOp("\\/", conj.left.right, conj.right.right, pos=conj.pos)
        conj = A.Rel(":", conj.left.left, union, pos=conj.pos)
    if not isinstance(conj, A.Rel) or conj.op not in (":", "=", "<:"):
        return None
    names = _names_in_pair(conj.left)
    if not names or name not in names or any(n in bound or n not in ids for n in names):
        return None
    if conj.op != ":" and len(names) != 1:
        return None
    pending = set(ids) - bound
    if A.free_names(conj.right) & pending:
        return None
    mode = {":": "in", "=": "eq", "<:": "sub"}[conj.op]
    return names, mode, comp.compile(conj.right)
