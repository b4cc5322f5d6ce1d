"""A B state as the solver sees it: each state variable's encoding in z3, and a model of the
solver read back as a B state.

A BOOL, INTEGER or REAL variable is one solver variable; a subset of an enumerated or
deferred set of n elements one boolean per element (:class:`ElementSet`); a function from
such a set to numbers or booleans (made a function by the invariant: ``S --> T`` or
``S +-> T``) one value per element, with one "defined" boolean for partial ones
(:class:`ElementFunction`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from ..b import ast
from ..b.btypes import BOOL, INTEGER, REAL, Base, Pow, Prod, resolve_all
from ..b.values import FuncValue
from ..errors import InputError, UnsupportedError

__all__ = ["load_z3", "ElementSet", "ElementFunction", "encode_variable", "state_of_model",
           "check_timeout", "MAX_TIMEOUT_S", "nudge"]


def load_z3():
    """The z3 module (an error saying how to install it where it is missing)."""
    try:
        import z3
    except ImportError:  # pragma: no cover - a dependency, but say so if it is missing
        raise InputError("proving needs the z3 solver: pip install z3-solver") from None
    return z3


@dataclass
class ElementSet:
    """A set of elements: for each element of its carrier, the condition that it is in."""

    carrier: str
    member: dict  # Elem -> z3 Bool


@dataclass
class ElementFunction:
    """A function from the elements of a set: per element (defined, value)."""

    carrier: str
    cells: dict  # Elem -> (z3 Bool, z3 value)


def encode_variable(z3, machine, name: str, prefix: str = "") -> Any:
    """The solver's encoding of the state variable ``name`` of ``machine`` (its solver names
    start with ``prefix``); an :class:`UnsupportedError` for a type it cannot encode."""
    t = resolve_all(machine.type_objects.get(name))
    full = prefix + name
    if t == BOOL:
        return z3.Bool(full)
    if t == REAL:
        return z3.Real(full)
    if t == INTEGER:
        return z3.Int(full)
    if isinstance(t, Pow) and isinstance(t.elem, Base) and t.elem.name in machine.sets:
        elems = machine.sets[t.elem.name]
        return ElementSet(t.elem.name, {e: z3.Bool(f"{full}[{e}]") for e in elems})
    if (isinstance(t, Pow) and isinstance(t.elem, Prod) and isinstance(t.elem.left, Base)
            and t.elem.left.name in machine.sets and t.elem.right in (REAL, INTEGER, BOOL)):
        if not _function_by_invariant(machine, name):
            raise UnsupportedError(f"cannot translate {name} to SMT: it is a relation the "
                                   "invariant does not make a function (S --> T or S +-> T)")
        make = {REAL: z3.Real, INTEGER: z3.Int, BOOL: z3.Bool}[t.elem.right]
        elems = machine.sets[t.elem.left.name]
        return ElementFunction(t.elem.left.name, {
            e: (z3.Bool(f"{full}[{e}]?"), make(f"{full}[{e}]")) for e in elems})
    raise UnsupportedError(f"cannot translate the variable {name} of type "
                           f"{machine.types.get(name)} to SMT")


def _function_by_invariant(machine, name: str) -> bool:
    from ..b.bindings import conjuncts

    inv = machine.invariant_node
    return inv is not None and any(
        isinstance(c, ast.Rel) and c.op == ":" and isinstance(c.left, ast.Name)
        and c.left.id == name and isinstance(c.right, ast.BinOp)
        and c.right.op in ("-->", "+->") for c in conjuncts(inv))


def state_of_model(z3, variables: dict[str, Any], model) -> dict:
    """The state ``model`` gives the encoded ``variables`` (name: encoding), as B values
    (reals as the nearest floats)."""
    out: dict = {}

    def num(v):
        v = model.eval(v, model_completion=True)
        if z3.is_int_value(v):
            return v.as_long()
        if z3.is_rational_value(v):
            return float(Fraction(v.numerator_as_long(), v.denominator_as_long()))
        if z3.is_algebraic_value(v):
            return float(v.approx(20).as_decimal(20).rstrip("?"))
        return bool(z3.is_true(v))

    for name, enc in variables.items():
        if isinstance(enc, ElementSet):
            out[name] = frozenset(e for e, c in enc.member.items()
                                  if z3.is_true(model.eval(c, model_completion=True)))
        elif isinstance(enc, ElementFunction):
            out[name] = FuncValue({e: num(v) for e, (d, v) in enc.cells.items()
                                   if z3.is_true(model.eval(d, model_completion=True))})
        elif z3.is_bool(enc):
            out[name] = bool(z3.is_true(model.eval(enc, model_completion=True)))
        else:
            out[name] = num(enc)
    return out


#: z3 counts its timeout in milliseconds in an unsigned 32-bit number (about 49 days).
MAX_TIMEOUT_S = 4_294_967


def check_timeout(seconds, what: str = "the timeout") -> float:
    """``seconds`` if the solver can take it as a time limit: a finite number above 0, at
    most z3's largest (:data:`MAX_TIMEOUT_S`); else an :class:`InputError` naming ``what``.

    >>> check_timeout(2)
    2.0
    """
    ok = isinstance(seconds, (int, float)) and not isinstance(seconds, bool) and \
        math.isfinite(seconds) and 0 < seconds <= MAX_TIMEOUT_S
    if not ok:
        raise InputError(f"{what} must be a finite number of seconds above 0 (at most "
                         f"{MAX_TIMEOUT_S:,}), not {seconds!r}",
                         hint="give the solver's time limit in seconds, e.g. 10")
    return float(seconds)


def nudge(x: float, steps: int) -> float:
    """``x`` moved ``steps`` floats up (down where negative): a value near a solver's model
    tried by the evaluator."""
    for _ in range(abs(steps)):
        x = math.nextafter(x, math.copysign(math.inf, steps))
    return x
