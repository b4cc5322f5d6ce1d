"""B types: base types and sets' names, ``POW``, products and type variables, written in B
notation (:func:`show`) and made equal by unification (:func:`unify`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Union

__all__ = ["Base", "Pow", "Prod", "Var", "Type", "INTEGER", "REAL", "BOOL", "STRING",
           "resolve", "resolve_all", "show", "unify", "TypeClash"]


@dataclass(frozen=True)
class Base:
    name: str  # INTEGER, REAL, BOOL, STRING, or a set's name


@dataclass(frozen=True)
class Pow:
    elem: "Type"


@dataclass(frozen=True)
class Prod:
    left: "Type"
    right: "Type"


class Var:
    """A type not known yet."""

    __slots__ = ("ref", "numeric")

    def __init__(self, numeric: bool = False) -> None:
        self.ref: Optional[Type] = None
        self.numeric = numeric


Type = Union[Base, Pow, Prod, Var]
INTEGER, REAL, BOOL, STRING = Base("INTEGER"), Base("REAL"), Base("BOOL"), Base("STRING")
_NUMERIC = (INTEGER, REAL)


def resolve(t: Type) -> Type:
    while isinstance(t, Var) and t.ref is not None:
        t = t.ref
    return t


def resolve_all(t: Type) -> Type:
    """``t`` with every type variable in it resolved (inside POW and products too)."""
    t = resolve(t)
    if isinstance(t, Pow):
        return Pow(resolve_all(t.elem))
    if isinstance(t, Prod):
        return Prod(resolve_all(t.left), resolve_all(t.right))
    return t


def show(t: Type) -> str:
    """A type in B notation, e.g. ``POW(Vehicles*REAL)``."""
    t = resolve(t)
    if isinstance(t, Base):
        return t.name
    if isinstance(t, Pow):
        return f"POW({show(t.elem)})"
    if isinstance(t, Prod):
        left = show(t.left)
        right = show(t.right)
        if isinstance(resolve(t.right), Prod):
            right = f"({right})"
        return f"{left}*{right}"
    return "?"


class TypeClash(Exception):
    """Two types that cannot be the same (raised by :func:`unify`, caught by the type checker,
    which reports a located BTypeError: never seen outside the engine)."""


def _occurs(v: Var, t: Type) -> bool:
    t = resolve(t)
    if t is v:
        return True
    if isinstance(t, Pow):
        return _occurs(v, t.elem)
    if isinstance(t, Prod):
        return _occurs(v, t.left) or _occurs(v, t.right)
    return False


def unify(a: Type, b: Type) -> None:
    """Make ``a`` and ``b`` the same type, binding type variables (else :class:`TypeClash`)."""
    a, b = resolve(a), resolve(b)
    if a is b:
        return
    if isinstance(a, Var) or isinstance(b, Var):
        v, t = (a, b) if isinstance(a, Var) else (b, a)
        if isinstance(t, Var):
            t.numeric = t.numeric or v.numeric
        elif v.numeric and t not in _NUMERIC:
            raise TypeClash
        if _occurs(v, t):
            raise TypeClash
        v.ref = t
        return
    if isinstance(a, Base) and isinstance(b, Base) and a == b:
        return
    if isinstance(a, Pow) and isinstance(b, Pow):
        unify(a.elem, b.elem)
        return
    if isinstance(a, Prod) and isinstance(b, Prod):
        unify(a.left, b.left)
        unify(a.right, b.right)
        return
    raise TypeClash
