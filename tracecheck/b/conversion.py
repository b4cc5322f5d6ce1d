"""Python and numpy values to B values, by the machine's types: the one state conversion.

Whatever gives tracecheck a state from Python code — an adapter's ``state()`` under
``record``, ``train``, re-simulation, ``import minari``, or :class:`ShieldWrapper` in a
user's own loop — goes through :func:`convert_state`. It takes, for a variable of type

==================  =====================================================================
INTEGER             ``int`` or a numpy integer (not a float: ``int(x)``)
REAL                ``float`` or a numpy float (exactly: a float32 is the float it is);
                    an ``int`` is the same real
BOOL                ``bool`` or ``numpy.bool_``
STRING              ``str``
an enumerated or    a ``str`` naming one of its elements (``"Lava"``), or
deferred set        :class:`~tracecheck.b.values.Elem`
a set ``POW(T)``    ``set``/``frozenset`` (or a list) of values of ``T``; a 1-D numpy
                    array of numbers or booleans
a function or       ``dict`` (key ↦ value, each converted by its type); a ``set`` of pairs;
relation            a ``list``/``tuple`` where the type is a sequence (``seq(T)``, indices
                    from 1); a numpy array where the invariant gives the index set
                    (``grid : 0..6 --> CELL`` for a 1-D array of 7, ``m : (0..6)*(0..6)
                    --> INTEGER`` for a 7×7 array, ``s : seq(REAL)``)
a pair ``A*B``      a 2-``tuple`` (or list)
a record            ``dict`` of its fields
==================  =====================================================================

Values already in B's representation (:mod:`.values`) are taken as they are (numpy
values inside them converted). A value that is none of these is an :class:`InputError`
that names where it came from (``state() of the adapter lava``), the variable, the type the
machine declares and the value given, with a hint for that case. Without a machine (a
variable it does not declare, ``record --shield none`` for an environment without a
shield) only what is unambiguous is converted: numpy scalars, a ``dict`` as a function, a
``set`` as a set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional

from ..errors import InputError, TracecheckError, printable
from ..identity import ByIdentity
from .btypes import INTEGER, Base, Pow, Prod, Rec, Type, Var, resolve_all, show
from .values import Elem, FuncValue, Record

__all__ = ["StateTypes", "convert_state", "convert_value", "native_state", "unknown_elements"]

#: the Python types that already are B values of a type (the fast path of every step)
_SCALAR_KINDS = {"INTEGER": frozenset({int}), "REAL": frozenset({float}),
                 "BOOL": frozenset({bool}), "STRING": frozenset({str})}
_CONTAINERS = frozenset({frozenset, FuncValue})


@dataclass(frozen=True)
class StateTypes:
    """What converting a machine's states needs: each variable's type, each set's elements
    by name, and the index sets the invariant gives functions (for numpy arrays).

    Build it with :meth:`of`."""

    machine: str
    types: Mapping[str, Type]
    elements: Mapping[str, Mapping[str, Elem]]
    #: variable -> its index set as one sorted tuple per array axis (``((0, 1, …, 6),)``,
    #: ``((0..6), (0..6))``); ``None`` for a sequence (indices 1..n, any n)
    indices: Mapping[str, Optional[tuple[tuple[Any, ...], ...]]] = field(default_factory=dict)
    #: variable -> the Python types its values already have when they need no conversion
    kinds: Mapping[str, frozenset] = field(default_factory=dict)

    @classmethod
    def of(cls, machine) -> "StateTypes":
        """The conversion of ``machine``'s variables (a :class:`~tracecheck.b.machine.Machine`).

        Args:
            machine: a loaded machine.

        Returns:
            Its :class:`StateTypes` (cached on the machine by the caller).

        >>> from tracecheck.b.machine import load_machine_text
        >>> m = load_machine_text("MACHINE M SETS C={Ice,Lava} VARIABLES a INVARIANT a : C "
        ...                       "INITIALISATION a := Ice END")
        >>> StateTypes.of(m).types["a"]
        Base(name='C')
        """
        types = {v: resolve_all(machine.type_objects[v]) for v in machine.variables
                 if v in machine.type_objects}
        types = {v: t for v, t in types.items() if _known(t)}
        elements = {name: {str(e): e for e in elems} for name, elems in machine.sets.items()}
        kinds = {v: _kinds(t) for v, t in types.items()}
        return cls(machine.name, types, elements, _index_sets(machine, types), kinds)


def _known(t: Type) -> bool:
    if isinstance(t, Var):
        return False
    if isinstance(t, Pow):
        return _known(t.elem)
    if isinstance(t, Prod):
        return _known(t.left) and _known(t.right)
    if isinstance(t, Rec):
        return all(_known(f) for _, f in t.fields)
    return True


def _kinds(t: Type) -> frozenset:
    if isinstance(t, Base):
        return _SCALAR_KINDS.get(t.name, frozenset({Elem}))
    if isinstance(t, Pow):
        return _CONTAINERS
    if isinstance(t, Prod):
        return frozenset({tuple})
    return frozenset({Record})


def _index_sets(machine, types: Mapping[str, Type]) -> dict:
    """The index sets the invariant's typing conjuncts give functions: ``v : D --> R``
    (any function arrow) with ``D`` a finite set of integers or a product of two, and
    ``v : seq(R)`` (1..n)."""
    from . import ast
    from .bindings import conjuncts

    out: dict = {}
    if machine.invariant_node is None:
        return out
    arrows = {"-->", "+->", ">->", ">+>", "-->>", "+->>", ">->>"}
    for conj in conjuncts(machine.invariant_node):
        if not (isinstance(conj, ast.Rel) and conj.op == ":" and isinstance(conj.left, ast.Name)):
            continue
        name, space = conj.left.id, conj.right
        if name not in types or name in out:
            continue
        if isinstance(space, ast.Call) and space.name in ("seq", "seq1", "iseq", "iseq1"):
            out[name] = None
        elif isinstance(space, ast.BinOp) and space.op in arrows:
            axes = _axes(machine, space.left)
            if axes is not None:
                out[name] = axes
    return out


def _axes(machine, node) -> Optional[tuple[tuple[Any, ...], ...]]:
    """``node``'s value as array axes: a finite set of integers (one axis) or the product
    of two (two axes); None when it is neither or cannot be evaluated here."""
    from .values import explicit

    try:
        value = machine.compile(node)(dict(machine.base_env))
        members = explicit(value)
    except (TracecheckError, TypeError, RecursionError):
        return None
    if members and all(type(m) is int for m in members):
        return (tuple(sorted(members)),)
    if members and all(type(m) is tuple and type(m[0]) is int and type(m[1]) is int
                       for m in members):
        rows = tuple(sorted({m[0] for m in members}))
        cols = tuple(sorted({m[1] for m in members}))
        if len(rows) * len(cols) == len(members):
            return (rows, cols)
    return None


def unknown_elements(value: Any, owners: dict) -> set[str]:
    """The names of the elements in ``value`` that no set of the machine holds (``owners``:
    element -> its set)."""
    if isinstance(value, Elem):
        return set() if value in owners else {str(value)}
    if isinstance(value, tuple):
        return unknown_elements(value[0], owners) | unknown_elements(value[1], owners)
    if isinstance(value, frozenset):
        out: set[str] = set()
        for item in value:
            out |= unknown_elements(item, owners)
        return out
    return set()


# ------------------------------------------------------------------ the conversion


def convert_state(state: Mapping[str, Any], types: Optional[StateTypes] = None, *,
                  where: str = "the state") -> Mapping[str, Any]:
    """``state`` with each value made the B value it stands for (see the module's table).

    Args:
        state: ``{variable: value}`` from Python code (an adapter's ``state()``).
        types: the machine's :class:`StateTypes` (None: convert only what needs no type).
        where: where the state came from, for messages (``state() of the adapter lava``).

    Returns:
        The state in B values; ``state`` itself when nothing needed converting.

    Raises:
        InputError: naming ``where``, the variable, the type and the value.

    >>> from tracecheck.b.machine import load_machine_text
    >>> m = load_machine_text("MACHINE M SETS C={Ice,Lava} VARIABLES a, g "
    ...     "INVARIANT a : C & g : 0..1 --> C INITIALISATION a := Ice || g := {0|->Ice,1|->Ice} END")
    >>> state = convert_state({"a": "Lava", "g": {0: "Ice", 1: "Lava"}}, StateTypes.of(m))
    >>> state["a"], state["g"].map
    (Elem('Lava'), {0: Elem('Ice'), 1: Elem('Lava')})
    """
    out = None
    kinds = types.kinds if types is not None else {}
    for name, value in state.items():
        kind = type(value)
        ok = kinds.get(name)
        if ok is not None and kind in ok and (kind is not tuple or len(value) == 2):
            if kind is float and not math.isfinite(value):
                raise _not_finite(name, value, where)
            if kind in _CONTAINERS or kind is tuple:
                converted = _native(value, name, types.types[name], where)
            else:
                continue
        elif ok is not None:
            converted = _Convert(types, name, where).value(value, types.types[name], ())
        else:
            converted = _untyped(value, name, where)
        if converted is not value:
            if out is None:
                out = dict(state)
            out[name] = converted
    return state if out is None else out


def convert_value(value: Any, btype: Type, types: StateTypes, *, name: str,
                  where: str = "the state") -> Any:
    """One value converted to ``btype`` (a variable ``name`` of ``types``' machine)."""
    return _Convert(types, name, where).value(value, resolve_all(btype), ())


def _untyped(value: Any, name: str, where: str) -> Any:
    """What converts without a type: numpy scalars and arrays as :func:`.state.native_state`
    does, a dict as a function, a set as a set."""
    kind = type(value)
    if kind is dict:
        return FuncValue({_untyped(k, name, where): _untyped(v, name, where)
                          for k, v in value.items()})
    if kind is set:
        return frozenset(_untyped(v, name, where) for v in value)
    if kind is list:
        raise InputError(f"{where}: {name} is a list, and without the machine's type it is "
                         "ambiguous (a sequence? a set?)",
                         hint="give a shield that declares it, or the B value itself: a "
                              "frozenset, a tuple for a pair, tracecheck.b.values.sequence(…)")
    return _native(value, name, None, where)


def _not_finite(name: str, value: Any, where: str) -> InputError:
    return InputError(f"{where}: {name} is {value}, not a B real",
                      hint="B reals are finite numbers: the observation holds a NaN or an "
                           "infinity (check the environment, or map it to a number in state())")


def _brief(value: Any) -> str:
    text = repr(value)
    return printable(text if len(text) <= 80 else text[:77] + "...")


class _Convert:
    """One variable's value converted, its path inside the value kept for messages."""

    def __init__(self, types: StateTypes, name: str, where: str) -> None:
        self.types, self.name, self.where = types, name, where
        self.in_array = False

    def fail(self, value: Any, t: Type, path: tuple, hint: str) -> InputError:
        inner = "".join(path)
        part = f"{self.name}{inner}" if inner else self.name
        declared = show(self.types.types[self.name])
        of = (f"{part} should be of type {show(t)} ({self.name} : {declared} in "
              f"{self.types.machine})" if inner else
              f"{self.name} is of type {declared} in {self.types.machine}")
        if type(value).__module__ == "numpy" and hasattr(value, "shape"):
            given = f"a numpy array of shape {value.shape} and dtype {value.dtype}"
        else:
            given = (f"{_brief(value)} (a {type(value).__module__.replace('builtins', 'Python')}"
                     f" {type(value).__name__})")
        return InputError(f"{self.where}: {of}, but it is {given}", hint=hint)

    def value(self, value: Any, t: Type, path: tuple) -> Any:
        kind = type(value)
        if kind.__module__ == "numpy" and getattr(value, "ndim", 0) == 0:
            value = _numpy_scalar(value)
            kind = type(value)
            if kind.__module__ == "numpy":
                raise self.fail(value, t, path, f"a numpy {kind.__name__} is no B value; give "
                                                "numbers, booleans, strings, or sets of them")
        if isinstance(t, Base):
            return self.scalar(value, kind, t, path)
        if isinstance(t, Pow):
            return self.set(value, kind, t, path)
        if isinstance(t, Prod):
            if kind in (tuple, list) and len(value) == 2:
                return (self.value(value[0], t.left, path + (".0",)),
                        self.value(value[1], t.right, path + (".1",)))
            raise self.fail(value, t, path, "a pair is a tuple of two: (a, b)")
        if isinstance(t, Rec):
            if kind is Record:
                return value
            names = [n for n, _ in t.fields]
            if kind is dict and sorted(value) == sorted(names):
                return Record((n, self.value(value[n], f, path + (f"'{n}",)))
                              for n, f in t.fields)
            raise self.fail(value, t, path, f"a record is a dict with the fields "
                                            f"{', '.join(names)}")
        return _untyped(value, self.name, self.where)

    def scalar(self, value: Any, kind: type, t: Base, path: tuple) -> Any:
        name = t.name
        if kind.__module__ == "numpy":  # an array where one value belongs
            raise self.fail(value, t, path, "give one value: obs[0], not obs[0:1]")
        if name == "REAL":
            if kind is float:
                if not math.isfinite(value):
                    raise _not_finite(self.name, value, self.where)
                return value
            if kind is int:
                real = float(value)
                if int(real) == value:
                    return real
                raise self.fail(value, t, path, "this integer is not a float exactly; give "
                                                "the real you mean")
            hint = "give a float: float(x)"
        elif name == "INTEGER":
            if kind is int:
                return value
            if kind is float and self.in_array and value.is_integer():
                return int(value)  # a numpy array holds one dtype: (1, 2.5) is float64
            hint = ("give an int: int(x) (round(x) if it may not be whole)"
                    if kind is float else "give an int")
        elif name == "BOOL":
            if kind is bool:
                return value
            hint = "give a bool: bool(x)"
        elif name == "STRING":
            if isinstance(value, str):
                return str(value)
            hint = "give a str"
        else:  # an enumerated or deferred set
            elements = self.types.elements.get(name, {})
            if isinstance(value, str) and value in elements:
                return elements[value]
            shown = ", ".join(list(elements)[:12]) + (", …" if len(elements) > 12 else "")
            hint = (f"give the name of one of its elements as a str: {shown}"
                    if elements else f"{name} has no elements here")
        raise self.fail(value, t, path, hint)

    def set(self, value: Any, kind: type, t: Pow, path: tuple) -> Any:
        elem = t.elem
        function = isinstance(elem, Prod)
        if kind in _CONTAINERS:
            return _native(value, self.name, t, self.where)
        if kind is dict:
            if not function:
                raise self.fail(value, t, path, "a dict is a function; give a set")
            return FuncValue({self.value(k, elem.left, path + (f"[{k!r}]",)):
                              self.value(v, elem.right, path + (f"[{k!r}]",))
                              for k, v in value.items()})
        if kind in (set, list, tuple):
            if kind is set and function and not path and \
                    self.types.indices.get(self.name, ()) is None:  # a seq(…) as a set
                raise self.fail(value, t, path, "a sequence is a list (its order is the "
                                                "sequence's; its first entry has index 1)")
            if kind is not set and function and elem.left == INTEGER:
                return FuncValue({i: self.value(v, elem.right, path + (f"[{i - 1}]",))
                                  for i, v in enumerate(value, 1)})
            return frozenset(self.value(v, elem, path + ("{…}",)) for v in value)
        if kind.__module__ == "numpy" and hasattr(value, "shape"):
            return self.array(value, t, path)
        raise self.fail(value, t, path, "give a set (frozenset), or a dict for a function")

    def array(self, value: Any, t: Pow, path: tuple) -> Any:
        self.in_array = True
        elem = t.elem
        if not path and isinstance(elem, Prod) and self.name in self.types.indices:
            axes = self.types.indices[self.name]
            if axes is None:  # a sequence
                if value.ndim == 1:
                    return FuncValue({i: self.value(v, elem.right, (f"[{i - 1}]",))
                                      for i, v in enumerate(value.tolist(), 1)})
            elif value.shape == tuple(len(a) for a in axes):
                items = value.tolist()
                if len(axes) == 1:
                    return FuncValue({k: self.value(v, elem.right, (f"[{i}]",))
                                      for i, (k, v) in enumerate(zip(axes[0], items))})
                return FuncValue({(r, c): self.value(items[i][j], elem.right, (f"[{i}, {j}]",))
                                  for i, r in enumerate(axes[0]) for j, c in enumerate(axes[1])})
            shape = "×".join(str(len(a)) for a in axes) if axes else "n"
            raise self.fail(value, t, path, f"the invariant gives {self.name} an index set "
                                            f"of shape {shape}; give an array of that shape")
        scalar = ("INTEGER", "REAL", "BOOL")
        numeric = value.dtype.kind in "biuf"
        if numeric and value.ndim == 1 and getattr(elem, "name", None) in scalar:
            if len(set(value.tolist())) < len(value):  # [0, 1, 1, 0, 0] read as {0, 1}
                raise self.fail(value, t, path, _MASK_HINT)
            return frozenset(self.value(v, elem, path + ("{…}",)) for v in value.tolist())
        if numeric and value.ndim == 2 and value.shape[1] == 2 and isinstance(elem, Prod):
            return frozenset(self.value(tuple(v), elem, path + ("{…}",)) for v in value.tolist())
        if isinstance(elem, Prod):
            hint = (f"say which index each entry has: declare {self.name} : 0..{len(value) - 1} "
                    f"--> … (or seq(…)) in the invariant, or give a dict")
        else:
            hint = "give a set: frozenset(…)"
        raise self.fail(value, t, path, f"a numpy array of shape {value.shape} is ambiguous "
                                        f"here; {hint}")


def _numpy_scalar(value: Any) -> Any:
    """A numpy scalar as the Python value it is exactly (a float32 as its float)."""
    import numpy as np

    if isinstance(value, np.ndarray):
        value = value[()]
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.str_):
        return str(value)
    return value


# ------------------------------------------------------------------ numpy at the boundary

_PLAIN = frozenset({int, float, bool, str, Elem})


def native_state(state: Mapping[str, Any], types: Optional[Mapping[str, Any]] = None,
                 *, where: str = "the state") -> Mapping[str, Any]:
    """``state`` with numpy values turned into the Python values B computes with, exactly:
    ``np.float32(30.1)`` becomes the float it is (30.100000381469727, not 30.1),
    ``np.int64`` an int, ``np.bool_`` a bool — at any depth (in sets, pairs and functions).
    A numpy array becomes a set only where the variable's B type (``types``, the machine's
    ``type_objects``) makes that unambiguous: a 1-D array for a set of numbers or booleans,
    an (n, 2) array for a set of pairs of them. Anything else — a 1-D array for a sequence
    (B's start at 1), an array for a number, NaN — is an :class:`InputError` naming the
    variable. A state without numpy values comes back as it is.

    >>> import numpy as np
    >>> native_state({"Gap": np.float32(30.1), "Lane": np.int64(2)})
    {'Gap': 30.100000381469727, 'Lane': 2}
    """
    out = None
    for name, value in state.items():
        if type(value) in _PLAIN and (type(value) is not float or math.isfinite(value)):
            continue
        native = _native(value, name, (types or {}).get(name), where)
        if native is not value:
            if out is None:
                out = dict(state)
            out[name] = native
    return state if out is None else out


#: sets found to hold no numpy value: a grid world's map is one object in every state, and
#: walking it every step was a third of a grid world's rollout
_CLEAN: ByIdentity[bool] = ByIdentity(64)


def _native(value: Any, name: str, btype: Any, where: str) -> Any:
    """One value of ``name`` converted (the same object when nothing in it is numpy)."""
    kind = type(value)
    if kind is float and not math.isfinite(value):  # a Python NaN as a numpy one
        raise InputError(f"{where}: {name} is {value}, not a B real",
                         hint="B reals are finite numbers; check the observation")
    if kind in _PLAIN:
        return value
    if kind is FuncValue or kind is frozenset:
        if _CLEAN.get(value):
            return value
        native = _native_set(value, kind, name, where)
        if native is value:
            _CLEAN.put(value, True)
        return native
    if kind is tuple:
        if _plain_and_finite(value):
            return value
        items = [_native(v, name, None, where) for v in value]
        return value if all(a is b for a, b in zip(items, value)) else kind(items)
    if kind.__module__ == "numpy":
        return _numpy(value, name, btype, where)
    return value  # symbolic sets and the like: B's own values


def _native_set(value: Any, kind: type, name: str, where: str) -> Any:
    """A set or function converted (the same object when nothing in it is numpy)."""
    if kind is FuncValue:
        if _plain_and_finite(value.map) and _plain_and_finite(value.map.values()):
            return value  # the common case, at C speed
        items = {_native(k, name, None, where): _native(v, name, None, where)
                 for k, v in value.map.items()}
        if all(a is b for a, b in zip(items, value.map)) and all(
                a is b for a, b in zip(items.values(), value.map.values())):
            return value  # the same object: a grid world's map is one object every step
        return FuncValue(items)
    if _plain_and_finite(value):
        return value
    items = [_native(v, name, None, where) for v in value]
    return value if all(a is b for a, b in zip(items, value)) else kind(items)


_NUMBERS = frozenset({int, float, bool})
_NO_FLOAT = _PLAIN - {float}


def _plain_and_finite(values) -> bool:
    """Whether ``values`` are all plain B values and none is a NaN or infinite float (a
    numpy value or a NaN takes the slow path, which converts or refuses it)."""
    if _NO_FLOAT.issuperset(map(type, values)):  # elements, ints: the common keys
        return True
    kinds = set(map(type, values))
    if not _PLAIN.issuperset(kinds):
        return False
    if float not in kinds:
        return True
    if _NUMBERS.issuperset(kinds) and math.isfinite(sum(values)):  # one C call: a NaN or
        return True  # an infinity makes the sum one (an overflow too: checked one by one)
    return all(math.isfinite(v) for v in values if type(v) is float)


def _numpy(value: Any, name: str, btype: Any, where: str) -> Any:
    import numpy as np

    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return _numpy(value[()], name, btype, where)
        return _array(value, name, btype, where)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        number = float(value)  # exactly the float32's value: float32 ⊂ float64
        if not math.isfinite(number):
            raise InputError(f"{where}: {name} is {number}, not a B real",
                             hint="B reals are finite numbers; check the observation")
        return number
    if isinstance(value, np.str_):
        return str(value)
    raise InputError(f"{where}: {name} is a numpy {type(value).__name__}, which is no B value",
                     hint="give numbers, booleans, strings, or sets of them")


#: a 1-D array of numbers with repeats given for a set (a MultiBinary observation)
_MASK_HINT = ("an array holding a value twice is no set: for a 0/1 mask (a MultiBinary "
              "observation) give the set of its indexes, set(np.flatnonzero(mask).tolist())")


def _array(value: Any, name: str, btype: Any, where: str) -> frozenset:
    """A numpy array as a B set, where the variable's type says so unambiguously."""
    from .btypes import Pow, Prod, resolve_all, show

    t = resolve_all(btype) if btype is not None else None
    elem = t.elem if isinstance(t, Pow) else None
    scalar = {"INTEGER", "REAL", "BOOL"}
    numeric = value.dtype.kind in "biuf"
    if numeric and value.ndim == 1 and getattr(elem, "name", None) in scalar:
        if len(set(value.tolist())) < len(value):
            raise InputError(f"{where}: {name} is a numpy array holding a value twice "
                             f"({_brief(value)}), which is no set", hint=_MASK_HINT)
        return frozenset(_numpy(x, name, None, where) for x in value)
    if numeric and value.ndim == 2 and value.shape[1] == 2 and isinstance(elem, Prod) and (
            getattr(elem.left, "name", None) in scalar
            and getattr(elem.right, "name", None) in scalar):
        return frozenset((_numpy(a, name, None, where), _numpy(b, name, None, where))
                         for a, b in value)
    wanted = show(t) if t is not None else "not known (not a variable of the machine)"
    hint = ("give a number: obs[0], not obs[0:1]" if elem is None and t is not None else
            "a sequence is a function from 1..n: give tracecheck.b.values.sequence(list(a)), "
            "or a frozenset of (index, value) pairs"
            if isinstance(elem, Prod) and value.ndim == 1 else
            "convert it to the B value you mean: a frozenset, a tuple, a number")
    raise InputError(f"{where}: {name} is a numpy array of shape {value.shape} and dtype "
                     f"{value.dtype}, which is ambiguous as a B value of type {wanted}",
                     hint=hint)
