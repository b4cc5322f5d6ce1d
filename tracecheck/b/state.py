"""State files: a JSON object mapping variable names to B literals or JSON values."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Optional

from ..errors import BSyntaxError, InputError, TracecheckError, caret_excerpt
from ..identity import ByIdentity
from ..inputs import read_json
from .notation import from_json
from .values import Elem, FuncValue

__all__ = ["read_state_file", "state_from_json", "native_state", "MAX_STATE_BYTES"]

#: The largest state file tracecheck reads (a state of five vehicles' positions, speeds and accelerations is about 1 kB).
MAX_STATE_BYTES = 16 << 20


def state_from_json(data: Any, *, file: str = "<state>") -> dict[str, Any]:
    """Turn a decoded JSON object into a state (dict of B values)."""
    if not isinstance(data, dict):
        raise InputError(f"a state file holds a JSON object mapping variable names to values, "
                         f"not {type(data).__name__}", file=file)
    state = {}
    for name, value in data.items():
        try:
            state[name] = from_json(value, where=f"variable {name}")
        except BSyntaxError as exc:
            # the column is one of the literal, not of the file: say so, show the literal
            raise BSyntaxError(f"{exc.message}, at column {exc.column} of the literal:"
                               f"{caret_excerpt(exc.source, exc.line, exc.column)}",
                               file=file) from None
        except TracecheckError as exc:
            raise exc.located(file=file) from None
    return state


def read_state_file(path: str | Path) -> dict[str, Any]:
    """Read a state file, e.g. ``{"Crash": "FALSE", "VehiclesX": "{(EgoVehicle↦1.0)}"}``.

    Args:
        path: a JSON file of variable names to B literals (ProB's notation).

    Returns:
        The state: variable names to B values.

    Raises:
        InputError: naming the file, the variable and what is wrong.

    >>> sorted(read_state_file("models/examples/state_approaching.json"))[:2]  # repo root
    ['Crash', 'PresentVehicles']
    """
    return state_from_json(read_json(path, "state file", MAX_STATE_BYTES), file=str(path))


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


def _array(value: Any, name: str, btype: Any, where: str) -> frozenset:
    """A numpy array as a B set, where the variable's type says so unambiguously."""
    from .btypes import Pow, Prod, resolve_all, show

    t = resolve_all(btype) if btype is not None else None
    elem = t.elem if isinstance(t, Pow) else None
    scalar = {"INTEGER", "REAL", "BOOL"}
    numeric = value.dtype.kind in "biuf"
    if numeric and value.ndim == 1 and getattr(elem, "name", None) in scalar:
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
