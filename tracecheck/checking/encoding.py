"""A B state as the solver sees it: each state variable's encoding in z3, and a model of the
solver read back as a B state.

A BOOL, INTEGER or REAL variable is one solver variable; an element of an enumerated or
deferred set one constant of a z3 enumeration sort of exactly its elements
(:class:`ElementTerm`); a subset of such a set of n elements one boolean per element
(:class:`ElementSet`); a function from such a set to numbers or booleans (made a function by
the invariant: ``S --> T`` or ``S +-> T``) one value per element, with one "defined" boolean
for partial ones (:class:`ElementFunction`); a total function over a finite set of integers
or pairs of integers (``field : (0..7)*(0..7) --> GROUND``, the invariant's domain evaluated
from the constants) one z3 array, read only at its domain (:class:`FiniteFunction`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Optional

from ..b import ast
from ..b.btypes import BOOL, INTEGER, REAL, Base, Pow, Prod, resolve_all
from ..b.values import FuncValue
from ..errors import InputError, UnsupportedError

__all__ = ["load_z3", "NumberSet", "finite_members", "ElementSet", "ElementFunction", "ElementTerm", "FiniteFunction",
           "element_sort", "encode_variable", "state_of_model", "MAX_CELLS",
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


@dataclass
class ElementTerm:
    """An element of ``carrier`` the solver chooses: a z3 term of :func:`element_sort`
    (``consts``: each element's constant of that sort)."""

    carrier: str
    term: Any
    consts: dict  # Elem -> z3 constant


@dataclass
class NumberSet:
    """A set of integers the solver chooses (``s1 <: INTEGER``): a z3 set (an array from
    integers to booleans), finite or not; read back only where the model's set is shown to
    be exactly a finite list (:func:`finite_members`)."""

    term: Any


@dataclass
class FiniteFunction:
    """A total function over a finite set of integers (``keys`` ints) or pairs of integers
    (``keys`` 2-tuples): a z3 array read at the keys. ``carrier`` names the enumerated set
    its values are elements of, ``consts`` their constants (None, {}: numbers or booleans)."""

    keys: tuple
    array: Any
    carrier: Any = None
    consts: dict = field(default_factory=dict)

    def at(self, key) -> Any:
        """The solver's term of the value at ``key`` (an int, or a pair as a tuple)."""
        return self.array[key[0], key[1]] if isinstance(key, tuple) else self.array[key]

    def value(self, term) -> Any:
        """A term of the array's values as the translator uses it (an element's wrapped)."""
        return ElementTerm(self.carrier, term, self.consts) if self.carrier else term


#: The most cells a :class:`FiniteFunction` is encoded with (a 64×64 map).
MAX_CELLS = 4096

_SORTS: dict = {}  # (carrier, elements) -> (sort, {Elem: constant}); z3 names are global


def element_sort(z3, carrier: str, elems) -> tuple[Any, dict]:
    """The z3 enumeration sort of exactly ``elems`` (the elements of ``carrier``) and each
    element's constant — one per carrier and elements, since z3 declares a name once."""
    key = (carrier, tuple(elems))
    found = _SORTS.get(key)
    if found is None:
        sort, consts = z3.EnumSort(f"{carrier}#{len(_SORTS)}", [f"{carrier}#{len(_SORTS)}."
                                                               f"{e}" for e in elems])
        found = _SORTS[key] = (sort, dict(zip(elems, consts)))
    return found


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
    if isinstance(t, Base) and t.name in machine.sets and machine.sets[t.name]:
        sort, consts = element_sort(z3, t.name, machine.sets[t.name])
        return ElementTerm(t.name, z3.Const(full, sort), consts)
    if isinstance(t, Pow) and isinstance(t.elem, Prod) and _integer_keys(t.elem.left):
        return _finite_function(z3, machine, name, full, t.elem.right)
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


def _integer_keys(t) -> bool:
    return t == INTEGER or (isinstance(t, Prod) and t.left == INTEGER and t.right == INTEGER)


def _finite_function(z3, machine, name: str, full: str, value_type) -> FiniteFunction:
    """``name : D --> R`` of the invariant, ``D`` a finite set of integers or of pairs of
    integers evaluated from the constants: a z3 array read at ``D``'s members."""
    from ..b.bindings import conjuncts
    from ..b.values import explicit

    inv = machine.invariant_node
    space = next((c.right for c in (conjuncts(inv) if inv is not None else ())
                  if isinstance(c, ast.Rel) and c.op == ":" and isinstance(c.left, ast.Name)
                  and c.left.id == name and isinstance(c.right, ast.BinOp)
                  and c.right.op == "-->"), None)
    if space is None:
        raise UnsupportedError(f"cannot translate {name} to SMT: only a total function over "
                               f"a finite set of integers is (the invariant's `{name} : D --> R`)")
    try:
        keys = explicit(machine.compile(space.left)(dict(machine.base_env)))
    except Exception as exc:  # noqa: BLE001 - any reason: the domain is not a constant here
        raise UnsupportedError(f"cannot translate {name} to SMT: the domain of its function "
                               f"is not a finite set of the constants ({exc})") from None
    keys = tuple(sorted(keys, key=lambda k: k if isinstance(k, tuple) else (k,)))
    if not keys or len(keys) > MAX_CELLS:
        raise UnsupportedError(f"cannot translate {name} to SMT: its domain has {len(keys):,} "
                               f"members (1 to {MAX_CELLS:,} are)")
    pairs = isinstance(keys[0], tuple)
    if not all((isinstance(k, tuple) and len(k) == 2 and type(k[0]) is int and type(k[1]) is int)
               if pairs else type(k) is int for k in keys):
        raise UnsupportedError(f"cannot translate {name} to SMT: its domain is not a set of "
                               "integers or of pairs of integers")
    carrier, consts = None, {}
    if value_type in (REAL, INTEGER, BOOL):
        sort = {REAL: z3.RealSort(), INTEGER: z3.IntSort(), BOOL: z3.BoolSort()}[value_type]
    elif isinstance(value_type, Base) and machine.sets.get(value_type.name):
        carrier = value_type.name
        sort, consts = element_sort(z3, carrier, machine.sets[carrier])
    else:
        raise UnsupportedError(f"cannot translate {name} to SMT: its values are of type "
                               f"{machine.types.get(name)}")
    domain = [z3.IntSort(), z3.IntSort()] if pairs else [z3.IntSort()]
    return FiniteFunction(keys, z3.Array(full, *domain, sort), carrier, consts)


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

    def element(consts, term):
        got = model.eval(term, model_completion=True)
        for e, const in consts.items():
            if got.eq(const):
                return e
        raise UnsupportedError(f"the solver's value {got} is no element")

    for name, enc in variables.items():
        if isinstance(enc, ElementTerm):
            out[name] = element(enc.consts, enc.term)
        elif isinstance(enc, FiniteFunction):
            out[name] = FuncValue({k: element(enc.consts, enc.at(k)) if enc.carrier else
                                   num(enc.at(k)) for k in enc.keys})
        elif isinstance(enc, ElementSet):
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


def finite_members(z3, model, term) -> Optional[frozenset]:
    """The members of the set of integers ``term`` in ``model`` where it is finite: the
    integers written in the model's value are the candidates, and the solver proves that
    the set is exactly the ones that are members (None where it is not, or cannot tell)."""
    value = model.eval(term, model_completion=True)
    numbers, todo = set(), [value]
    while todo:
        t = todo.pop()
        if z3.is_int_value(t):
            numbers.add(t.as_long())
        elif z3.is_app(t) or z3.is_quantifier(t):
            todo.extend(t.children() if z3.is_app(t) else [t.body()])
    members = sorted(k for k in numbers
                     if z3.is_true(model.eval(z3.IsMember(z3.IntVal(k), value))))
    k = z3.FreshInt("k")
    check = z3.Solver()
    check.set("timeout", 2000)
    check.add(z3.IsMember(k, value) != z3.Or([k == m for m in members] or [z3.BoolVal(False)]))
    return frozenset(members) if check.check() == z3.unsat else None


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
