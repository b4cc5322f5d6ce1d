"""State files: a JSON object mapping variable names to B literals or JSON values."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import BSyntaxError, InputError, TracecheckError, caret_excerpt
from ..inputs import read_json
from .notation import from_json
from .conversion import native_state

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
