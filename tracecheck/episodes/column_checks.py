"""What a run file's columns must be before the rest of tracecheck reads them: the arrays an
episode's columns attachment holds (or a block of them), checked against its header — one
row per step, the right dtypes and shapes, action indexes within the actions, names that are
names, no infinities where continuous actions have none.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

__all__ = ["check_columns"]


_DTYPES = {"time": "<f8", "reward": "<f8", "action": "<i2", "crashed": "|b1", "values": "<f8",
           "num": ("<f8", "<i8"), "bool": "|b1", "fun": ("<f8", "<i8"), "def": "|b1",
           "set": "|b1", "lit": "<u4", "par": "<f8", "prop": "<f8", "dist": "<f8"}
#: float columns where NaN means "none in this row" (continuous actions: no infinities)
_NAN_ALLOWED = {"values", "par", "prop", "dist"}
_KINDS = {"num": ("num",), "bool": ("bool",), "func": ("fun", "def"), "set": ("set",),
          "lit": ("lit",)}


_NAMES_SEEN: list = [None, None]


def _check_names(actions, elements) -> None:
    if [actions, elements] == _NAMES_SEEN:  # every episode of a file has the same ones
        return
    if not isinstance(actions, list) or not isinstance(elements, list) or \
            not all(isinstance(a, str) for a in actions) or \
            not all(isinstance(e, str) and e.isidentifier() for e in elements):
        raise ValueError("the names of its actions or set elements are not names")
    _NAMES_SEEN[:] = [actions, elements]


def _check_continuous(name: str, prefix: str, arr: np.ndarray) -> None:
    """A column of continuous actions: named after a parameter, no infinities, distances
    not negative (NaN: none in that row)."""
    if (name == "dist") != (prefix == "dist") or (
            prefix != "dist" and not name[len(prefix) + 1:].isidentifier()):
        raise ValueError(f"the array {name} is not one tracecheck writes")
    if np.isinf(arr).any():
        raise ValueError(f"the array {name} holds an infinity")
    if prefix == "dist" and (arr < 0).any():
        raise ValueError(f"the array {name} holds a negative distance")


def check_columns(header: dict, arrays: dict, *, first_action: bool = True) -> None:
    """What the rest of tracecheck relies on: an integer episode id, one row per step in
    every array of the right dtype and shape, action indexes within the episode's actions,
    one array per variable of each kind (an :class:`~tracecheck.errors.InputError` if not)."""
    try:
        if type(header.get("episode")) is not int:
            raise ValueError(f"the episode id {header.get('episode')!r} is not an integer")
        actions, elements = header["actions"], header["elements"]
        literals = header.get("literals", {})  # files before literal columns have none
        if not isinstance(header["kinds"], dict) or not isinstance(literals, dict):
            raise ValueError("the kinds or literals are not tables")
        n = len(arrays["time"])
        _check_names(actions, elements)
        wide = {"fun": len(elements), "def": len(elements), "set": len(elements),
                "values": len(actions)}
        for name, arr in arrays.items():
            prefix = name.split(":")[0]
            want = _DTYPES.get(prefix)
            if want is None:
                raise ValueError(f"the array {name} is not one tracecheck writes")
            if arr.dtype.str not in (want if isinstance(want, tuple) else (want,)):
                raise ValueError(f"the array {name} has dtype {arr.dtype.str}, not {want}")
            shape = (n, wide[prefix]) if prefix in wide else (n,)
            if arr.shape != shape:
                raise ValueError(f"the array {name} has shape {arr.shape}, not {shape}")
            if arr.dtype.kind == "f" and prefix not in _NAN_ALLOWED and not (
                    math.isfinite(arr.sum()) or np.isfinite(arr).all()):  # the sum: quicker
                raise ValueError(f"the array {name} holds NaN or an infinity (B reals are "
                                 "finite)")
            if prefix in _NAN_ALLOWED and prefix != "values":
                _check_continuous(name, prefix, arr)
        for name in ("action", "reward", "crashed"):
            arrays[name]  # noqa: B018 - present
        for var, kind in header["kinds"].items():
            if kind not in _KINDS:
                raise ValueError(f"variable {var} has the unknown kind {kind!r}")
            for prefix in _KINDS[kind]:
                arrays[f"{prefix}:{var}"]  # noqa: B018 - present
            if kind == "lit":
                texts = literals[var]
                if not isinstance(texts, list) or not all(isinstance(t, str) for t in texts):
                    raise ValueError(f"the literals of {var} are not a list of texts")
                rows = arrays[f"lit:{var}"]
                if rows.size and int(rows.max()) >= len(texts):
                    raise ValueError(f"variable {var} refers to literal {int(rows.max())} of "
                                     f"{len(texts)}")
        action = arrays["action"]
        if not n:
            raise ValueError("it has no rows")
        first = action[:1] if first_action else action[:0]
        rest = action[1:] if first_action else action
        if (first.size and int(first[0]) != -1) or (rest.size and (
                int(rest.min()) < (0 if first_action else -1)
                or int(rest.max()) >= len(actions))):
            raise ValueError(f"an action index lies outside the {len(actions)} actions of the "
                             "episode")
    except KeyError as exc:
        raise InputError(f"damaged columns attachment: {exc} is missing") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"damaged columns attachment: {exc}") from None
