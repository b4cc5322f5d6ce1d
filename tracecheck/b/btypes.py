"""B types: base types and sets' names, ``POW``, products, records and type variables, written
in B notation (:func:`show`) and made equal by unification (:func:`unify`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Union

from .names import name_text

__all__ = ["Base", "Pow", "Prod", "Rec", "Var", "Type", "INTEGER", "REAL", "BOOL", "STRING",
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


@dataclass(frozen=True)
class Rec:
    """``struct(a:INTEGER,b:BOOL)``: a record type, its fields sorted by name (as ProB)."""

    fields: tuple[tuple[str, "Type"], ...]


class Var:
    """A type not known yet."""

    __slots__ = ("ref", "numeric")

    def __init__(self, numeric: bool = False) -> None:
        self.ref: Optional[Type] = None
        self.numeric = numeric


Type = Union[Base, Pow, Prod, Rec, Var]
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
    if isinstance(t, Rec):
        return Rec(tuple((n, resolve_all(f)) for n, f in t.fields))
    return t


def resolved_defaulting(typed: dict, names) -> dict:
    """The types of ``names`` in ``typed``, resolved; a number typed by nothing else (only
    compared or computed with) is an INTEGER, as in ProB."""
    for n in names:
        t = resolve(typed[n])
        if isinstance(t, Var) and t.numeric:
            t.ref = INTEGER
    return {n: resolve_all(typed[n]) for n in names}


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
    if isinstance(t, Rec):
        return "struct(" + ",".join(f"{name_text(n)}:{show(f)}" for n, f in t.fields) + ")"
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
    if isinstance(t, Rec):
        return any(_occurs(v, f) for _, f in t.fields)
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
    if isinstance(a, Rec) and isinstance(b, Rec) and [n for n, _ in a.fields] == [
            n for n, _ in b.fields]:
        for (_, fa), (_, fb) in zip(a.fields, b.fields):
            unify(fa, fb)
        return
    raise TypeClash
