"""A machine's sets and constants given values: the size and elements of each deferred set,
the constants that PROPERTIES fixes (``c = value``, ``c : S`` for a deferred ``S``, ``S =
{a, b}``), checked against the PROPERTIES; the others are left to the solver
(:mod:`tracecheck.checking.constants_setup`)."""

from __future__ import annotations

from typing import Any, Optional

from ..errors import EvaluationError, ModelError, TracecheckError
from . import ast
from .bindings import conjuncts
from .evaluation import Compiler
from .parser import MachineSource
from .scope import expand, render
from .values import Elem, Interval, check_size

__all__ = ["setup_constants", "DEFAULT_SETSIZE"]

#: Elements a deferred set gets when PROPERTIES does not fix ``card(S)`` (as ProB).
DEFAULT_SETSIZE = 2


def setup_constants(src: MachineSource, properties: Optional[ast.Node]):
    """(the elements of each set, the enumerated sets, the constants' values) that
    ``properties`` (the expanded PROPERTIES) give, checked against them."""
    conjs = conjuncts(properties) if properties is not None else []
    deferred = [n for n, elems, _ in src.sets if elems is None]
    sets: dict[str, list[Elem]] = {n: [Elem(e) for e in elems] for n, elems, _ in src.sets
                                   if elems is not None}
    enumerated = frozenset(sets)
    const_names = {n for n, _ in src.constants}
    values: dict[str, Any] = {}
    named = set()  # deferred sets whose elements PROPERTIES names: S = {a, b, c}
    for name, elems in _deferred_sizes(src, conjs, deferred, const_names).items():
        sets[name] = elems
        if str(elems[0]) in const_names:
            named.add(name)
            values.update({str(e): e for e in elems})
    _name_elements(conjs, [n for n in deferred if n not in named], sets, const_names, values)
    frozen_sets = {n: tuple(e) for n, e in sets.items()}
    env = {n: frozenset(e) for n, e in frozen_sets.items()}
    for n in enumerated:
        env.update({str(e): e for e in frozen_sets[n]})
    comp = Compiler(source=src.text, file=src.file)
    _solve_equalities(conjs, const_names, values, env, comp)
    env.update(values)
    for conj in conjs:
        try:
            ok = comp.compile(conj)(dict(env))
        except EvaluationError:
            continue  # mentions a constant that has no value; it stays unset
        if not ok:
            raise ModelError(f"PROPERTIES do not hold for the values tracecheck gave the "
                             f"constants: `{render(conj, src.text)}` is false",
                             line=conj.pos.line if conj.pos else None,
                             column=conj.pos.column if conj.pos else None,
                             hint="tracecheck sets constants from `c = value` and "
                                  "`c : DeferredSet`, and deferred sets from `card(S) = n`")
    return frozen_sets, enumerated, values


def _name_elements(conjs, deferred: list[str], sets: dict[str, list[Elem]],
                   const_names: set[str], values: dict[str, Any]) -> None:
    """Constants ``c : S`` of a deferred set ``S`` take its elements' places, in order, as
    ProB names them (``EgoVehicle : Vehicles`` gives ``{EgoVehicle, Vehicles2, …}``): the
    elements of a deferred set are alike, so which one a constant is changes nothing —
    for one constant, and for several the PROPERTIES say differ pairwise (``a /= b``). A
    constant that may equal one named before it (``a : PID & b : PID``: a = b is a
    solution), one an equality fixes (other than to a constant: ``b = a`` then gives b
    a's element), and one of a set whose elements PROPERTIES names (``c /= PID2``) are
    left to the equalities and the solver, as is ``c : S`` for an enumerated set (each
    of its elements is a solution)."""
    equated = {side.id for conj in conjs if isinstance(conj, ast.Rel) and conj.op == "="
               for side, other in ((conj.left, conj.right), (conj.right, conj.left))
               if isinstance(side, ast.Name) and side.id in const_names and
               not (isinstance(other, ast.Name) and other.id in const_names)}
    differ = {frozenset((conj.left.id, conj.right.id)) for conj in conjs
              if isinstance(conj, ast.Rel) and conj.op == "/=" and
              isinstance(conj.left, ast.Name) and isinstance(conj.right, ast.Name)}
    mentioned = set().union(*(ast.free_names(conj) for conj in conjs)) if conjs else set()
    alike = {n for n in deferred if not any(str(e) in mentioned for e in sets[n])}
    taken: dict[str, list[str]] = {n: [] for n in alike}
    for conj in conjs:
        if not (isinstance(conj, ast.Rel) and conj.op == ":" and
                isinstance(conj.left, ast.Name) and conj.left.id in const_names and
                conj.left.id not in values and conj.left.id not in equated and
                isinstance(conj.right, ast.Name) and conj.right.id in alike):
            continue
        name, set_name = conj.left.id, conj.right.id
        before = taken[set_name]
        if not all(frozenset((name, other)) in differ for other in before):
            continue
        elems = sets[set_name]
        if len(before) >= len(elems):  # pairwise different: more of them than elements
            raise ModelError(f"{set_name} has only {len(elems)} element(s), too few for the "
                             f"constant {name}, which PROPERTIES says differs from "
                             f"{', '.join(before)}", line=conj.pos.line,
                             column=conj.pos.column)
        elems[len(before)] = values[name] = Elem(name)
        before.append(name)


def _deferred_sizes(src: MachineSource, conjs, deferred: list[str],
                    const_names: set[str]) -> dict[str, list[Elem]]:
    """The elements of each deferred set, from what fixes its size as in ProB: ``card(S) = n``
    or ``S = {c1, …, cn}`` (distinct constants, which become its elements) in PROPERTIES, or
    ``scope_S == n`` / ``a..b`` in DEFINITIONS; else :data:`DEFAULT_SETSIZE` elements
    ``S1 … Sn``. Sources that disagree are an error (no values satisfy the PROPERTIES)."""
    found: dict[str, dict[str, tuple[int, Optional[ast.Node]]]] = {n: {} for n in deferred}
    members: dict[str, list[str]] = {}
    for conj in conjs:
        size = _card_equation(conj, deferred)
        if size is not None:
            found[size[0]].setdefault(f"card({size[0]}) = {size[1]}", (size[1], conj))
        listed = _enumeration(conj, deferred, const_names)
        if listed is not None:
            name, consts = listed
            members.setdefault(name, consts)
            found[name].setdefault(f"{name} = {{{', '.join(consts)}}}", (len(consts), conj))
    for name in deferred:
        scope = _scope(src, name)
        if scope is not None:
            found[name][f"scope_{name} in DEFINITIONS"] = (scope, None)
    out = {}
    for name in deferred:
        sizes = set(n for n, _ in found[name].values())
        if len(sizes) > 1:
            (one, (n1, _)), (two, (n2, _)) = list(found[name].items())[:2]
            pos = next((node.pos for _, node in found[name].values() if node is not None), None)
            raise ModelError(f"the deferred set {name} has {n1} element(s) by {one} but {n2} "
                             f"by {two}: no values satisfy the PROPERTIES (as in ProB)",
                             line=pos.line if pos else None,
                             column=pos.column if pos else None,
                             hint="give the set one size")
        size = sizes.pop() if sizes else DEFAULT_SETSIZE
        check_size(size, name)
        if size < 1:
            raise ModelError(f"the deferred set {name} would have {size} elements; a deferred "
                             "set is not empty")
        out[name] = ([Elem(c) for c in members[name]] if name in members
                     else [Elem(f"{name}{i}") for i in range(1, size + 1)])
    return out


def _scope(src: MachineSource, name: str) -> Optional[int]:
    """The size ``DEFINITIONS scope_S == n`` or ``scope_S == a..b`` gives S (ProB's
    convention: ``a..b`` has b - a + 1 elements), None without one."""
    d = src.definitions.get(f"scope_{name}")
    if d is None:
        return None
    line = d.line or None
    body = d.body if d.kind == "formula" and not d.params else None
    try:
        value = Compiler(source=src.text, file=src.file).compile(
            expand(body, src.definitions))({}) if body is not None else None
    except TracecheckError:
        value = None
    if isinstance(value, bool) or not isinstance(value, (int, Interval)):
        raise ModelError(f"scope_{name} sets the size of the deferred set {name}: write "
                         f"scope_{name} == n or scope_{name} == a..b with integers",
                         line=line)
    return value if isinstance(value, int) else value.card()


def _enumeration(conj: ast.Node, deferred: list[str], const_names: set[str]):
    """(S, [c1, …, cn]) for ``S = {c1, …, cn}`` with distinct constants, else None."""
    if not (isinstance(conj, ast.Rel) and conj.op == "="):
        return None
    for a, b in ((conj.left, conj.right), (conj.right, conj.left)):
        if (isinstance(a, ast.Name) and a.id in deferred and isinstance(b, ast.SetExt)
                and all(isinstance(e, ast.Name) and e.id in const_names for e in b.items)):
            names = [e.id for e in b.items]
            if len(set(names)) == len(names):
                return a.id, names
    return None


def _card_equation(conj: ast.Node, deferred: list[str]):
    if not (isinstance(conj, ast.Rel) and conj.op == "="):
        return None
    for a, b in ((conj.left, conj.right), (conj.right, conj.left)):
        if (isinstance(a, ast.Call) and a.name == "card" and isinstance(a.args[0], ast.Name)
                and a.args[0].id in deferred and isinstance(b, ast.IntLit)):
            return a.args[0].id, b.value
    return None


def _solve_equalities(conjs, const_names, values, env, comp) -> None:
    pending = True
    while pending:
        pending = False
        for conj in conjs:
            if not (isinstance(conj, ast.Rel) and conj.op == "="):
                continue
            for a, b in ((conj.left, conj.right), (conj.right, conj.left)):
                if (isinstance(a, ast.Name) and a.id in const_names and a.id not in values
                        and all(n in values or n in env or n in _GLOBAL_NAMES
                                for n in ast.free_names(b))):
                    values[a.id] = comp.compile(b)({**env, **values})
                    pending = True
                    break


_GLOBAL_NAMES = frozenset({"BOOL", "INTEGER", "NATURAL", "NATURAL1", "INT", "NAT", "NAT1",
                           "REAL", "FLOAT", "STRING", "MAXINT", "MININT"})

