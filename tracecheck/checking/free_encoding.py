"""The solver's encoding of an identifier ``eval`` solves for that is not a number or a
boolean (:mod:`.solving_z3`): an element of a set the machine lists (one z3 constant of an
enumeration sort), a subset of such a set (a boolean per element), a function from such a
set (a value and a "defined" boolean per element), a set of integers (a z3 set), and a total function over a finite set
of integers (``vec : 1..10 --> 0..9999``, ``queens : perm(1..8)``, ``stolen : coins -->
NATURAL``: one z3 array read at the domain's members) — the domain taken from a conjunct
of the predicate that reads nothing solved for. Anything else is an
:class:`~tracecheck.errors.UnsupportedError` saying why."""

from __future__ import annotations

from typing import Any

from ..b import ast
from ..b.bindings import conjuncts
from ..b.btypes import BOOL, INTEGER, REAL, Base, Pow, Prod, show
from ..b.values import cardinality, explicit
from ..errors import TracecheckError, UnsupportedError
from .encoding import (MAX_CELLS, ElementFunction, ElementSet, ElementTerm, FiniteFunction,
                       NumberSet, element_sort)

__all__ = ["encode_free", "function_space", "TOTAL_ARROWS", "ARROWS"]

#: The arrows of a total function, and of every function (a partial one's domain is a
#: subset), as the parser spells them.
TOTAL_ARROWS = ("-->", ">->", "-->>", ">->>")
ARROWS = TOTAL_ARROWS + ("+->", ">+>", "+->>", ">+>>")
_NUMBERS = (INTEGER, REAL, BOOL)


def function_space(node: ast.Node, name: str):
    """The conjunct ``name : D arrow R`` or ``name : perm(D)`` of ``node`` as (arrow, D, R)
    — perm(D) as ``1..card(D) >->> D``, D then the range — or None."""
    for c in conjuncts(node):
        if not (isinstance(c, ast.Rel) and c.op == ":" and isinstance(c.left, ast.Name)
                and c.left.id == name):
            continue
        right = c.right
        if isinstance(right, ast.BinOp) and right.op in ARROWS:
            return right.op, right.left, right.right
        if isinstance(right, ast.Call) and right.name == "perm" and len(right.args) == 1:
            return "perm", None, right.args[0]
    return None


def encode_free(z3, problem, name: str) -> Any:
    """The encoding of the identifier ``name`` of the :mod:`.solving` ``problem``."""
    t = problem.types[name]
    if t in _NUMBERS:
        return {INTEGER: z3.Int, REAL: z3.Real, BOOL: z3.Bool}[t](name)
    sets = problem.sets
    if isinstance(t, Base) and sets.get(t.name):
        sort, consts = element_sort(z3, t.name, sets[t.name])
        return ElementTerm(t.name, z3.Const(name, sort), consts)
    if t == Pow(INTEGER):
        return NumberSet(z3.Const(name, z3.SetSort(z3.IntSort())))
    if isinstance(t, Pow) and isinstance(t.elem, Base) and sets.get(t.elem.name):
        return ElementSet(t.elem.name, {e: z3.Bool(f"{name}[{e}]") for e in sets[t.elem.name]})
    if isinstance(t, Pow) and isinstance(t.elem, Prod):
        left, right = t.elem.left, t.elem.right
        space = function_space(problem.node, name)
        if space is None:
            raise _cannot(name, t, "no conjunct makes it a function (f : D --> R)")
        arrow, dom, rng = space
        if isinstance(left, Base) and sets.get(left.name) and right in _NUMBERS:
            make = {REAL: z3.Real, INTEGER: z3.Int, BOOL: z3.Bool}[right]
            return ElementFunction(left.name, {e: (z3.Bool(f"{name}[{e}]?"),
                                                   make(f"{name}[{e}]"))
                                               for e in sets[left.name]})
        if left == INTEGER and arrow in TOTAL_ARROWS + ("perm",):
            return _over_integers(z3, problem, name, t, arrow, dom, rng, right)
        raise _cannot(name, t, "only total functions over a finite set of integers and "
                               "functions over a set of elements are")
    raise _cannot(name, t, "the solver chooses numbers, booleans, elements, and functions "
                           "and subsets of elements or over a finite set of integers")


def _over_integers(z3, problem, name, t, arrow, dom, rng, right) -> FiniteFunction:
    if arrow == "perm":
        listed = _listed(problem, rng, name, t)
        keys = tuple(range(1, len(listed) + 1))
    else:
        keys = _listed(problem, dom, name, t)
    if not keys or len(keys) > MAX_CELLS or not all(type(k) is int for k in keys):
        raise _cannot(name, t, f"its domain is not 1 to {MAX_CELLS:,} integers")
    carrier, consts = None, {}
    if right in _NUMBERS:
        sort = {REAL: z3.RealSort(), INTEGER: z3.IntSort(), BOOL: z3.BoolSort()}[right]
    elif isinstance(right, Base) and problem.sets.get(right.name):
        carrier = right.name
        sort, consts = element_sort(z3, carrier, problem.sets[carrier])
    else:
        raise _cannot(name, t, "its values are not numbers, booleans or elements")
    return FiniteFunction(tuple(sorted(keys)), z3.Array(name, z3.IntSort(), sort), carrier,
                          consts)


def _listed(problem, node: ast.Node, name: str, t) -> tuple:
    value = problem.closed(node)
    try:
        if value is None or cardinality(value) > MAX_CELLS:
            return ()
        return tuple(explicit(value))
    except TracecheckError:
        raise _cannot(name, t, "its domain is not a finite set the other conjuncts fix") \
            from None


def _cannot(name: str, t, why: str) -> UnsupportedError:
    return UnsupportedError(f"{name} is of type {show(t)}, which the solver cannot choose: "
                            f"{why}")
