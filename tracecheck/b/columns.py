"""Many B states held column by column: the :class:`Columns` container that episodes are
read into and that batch evaluation (:mod:`.vector`) works on, and :func:`step_pairs`, the
columns of consecutive states for formulas that read the state before a step (``x$0``).

Numbers and booleans become 1-D arrays, functions from the elements of one set
(``VehiclesX : Vehicles --> REAL``) ``(rows, elements)`` arrays with a mask of where they are
defined, subsets of that set boolean masks; anything else stays a list of values. The
elements are those the first state names (or given).

>>> from tracecheck.b.values import Elem, FuncValue
>>> a, b = Elem("a"), Elem("b")
>>> cols = Columns.from_states([{"x": 1, "f": FuncValue({a: 1.5, b: 0.5})},
...                             {"x": 2, "f": FuncValue({b: 3.0})}])
>>> cols.n, cols.elements, cols.numbers["x"].tolist()
(2, (Elem('a'), Elem('b')), [1, 2])
>>> cols.functions["f"][1].tolist()  # where f is defined
[[True, True], [False, True]]
>>> cols.row(1) == {"x": 2, "f": FuncValue({b: 3.0})}
True
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional, Sequence

import numpy as np

from .values import Elem, FuncValue, sort_key

__all__ = ["Columns", "step_pairs"]


@dataclass
class Columns:
    """Many states, column by column (see the module docstring).

    ``elements`` orders the elements of the one set that functions and masks range over.
    """

    n: int
    elements: tuple[Elem, ...]
    numbers: dict[str, np.ndarray] = field(default_factory=dict)
    booleans: dict[str, np.ndarray] = field(default_factory=dict)
    functions: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    masks: dict[str, np.ndarray] = field(default_factory=dict)
    others: dict[str, list] = field(default_factory=dict)
    label: Optional[Callable[[int], str]] = None  # names row i in messages ("state i")

    @classmethod
    def from_states(cls, states: Sequence[Mapping[str, Any]],
                    elements: Optional[Sequence[Elem]] = None) -> "Columns":
        """Columns from scalar states (dicts of B values), e.g. read from a trace."""
        n = len(states)
        if elements is None:  # every state's: a set of one element in the first state and
            #                   of two later must still be one column of one kind
            found: dict[Elem, None] = {}
            seen: set[int] = set()  # a grid world's map is one object in every state
            for state in states:
                for value in state.values():
                    if type(value) not in (FuncValue, frozenset) or id(value) in seen:
                        continue
                    seen.add(id(value))
                    keys = value.map if type(value) is FuncValue else value
                    found.update({k: None for k in keys if isinstance(k, Elem)})
            elements = tuple(sorted(found, key=sort_key))
        elements = tuple(elements)
        index = {e: i for i, e in enumerate(elements)}
        cols = cls(n=n, elements=elements)
        names = list(states[0]) if states else []
        for name in names:
            values = [s[name] for s in states]
            cols._add(name, values, index)
        return cols

    def _add(self, name: str, values: list, index: dict) -> None:
        first = values[0]
        k = len(index)
        if all(type(v) is bool for v in values):
            self.booleans[name] = np.array(values, dtype=bool)
        elif all(type(v) in (int, float) for v in values) and _fits(values):
            self.numbers[name] = np.array(values, dtype=float if any(
                type(v) is float for v in values) else np.int64)
        elif isinstance(first, FuncValue) and all(
                isinstance(v, FuncValue) and all(key in index and type(x) in (int, float)
                                                 for key, x in v.map.items())
                for v in values) and _fits([x for v in values for x in v.map.values()]):
            integers = not any(type(x) is float for v in values for x in v.map.values())
            vals = np.zeros((self.n, k), dtype=np.int64 if integers else float)  # 3 / 2 is 1
            defined = np.zeros((self.n, k), dtype=bool)
            for row, v in enumerate(values):
                for key, x in v.map.items():
                    vals[row, index[key]] = x
                    defined[row, index[key]] = True
            self.functions[name] = (vals, defined)
        elif all(isinstance(v, frozenset) and not isinstance(v, FuncValue)
                 and all(e in index for e in v) for v in values):
            mask = np.zeros((self.n, k), dtype=bool)
            for row, v in enumerate(values):
                for e in v:
                    mask[row, index[e]] = True
            self.masks[name] = mask
        else:
            self.others[name] = values

    def names(self) -> set[str]:
        return (set(self.numbers) | set(self.booleans) | set(self.functions)
                | set(self.masks) | set(self.others))

    def distinct(self) -> tuple[np.ndarray, np.ndarray]:
        """(the first row of each distinct state, ascending; for each row, the index of its
        state among those). Rows are the same state when every column holds the same bytes
        (numbers) or equal B values (other values)."""
        n = self.n
        if n == 0:  # no rows (a run without a complete episode): none to tell apart
            return np.arange(0), np.zeros(0, dtype=np.int64)
        parts = []
        for arr in (*self.numbers.values(), *self.booleans.values()):
            parts.append(np.ascontiguousarray(arr).reshape(n, -1).view(np.uint8))
        for vals, defined in self.functions.values():
            parts.append(np.ascontiguousarray(vals).reshape(n, -1).view(np.uint8))
            parts.append(np.ascontiguousarray(defined).reshape(n, -1).view(np.uint8))
        for mask in self.masks.values():
            parts.append(np.ascontiguousarray(mask).reshape(n, -1).view(np.uint8))
        for values in self.others.values():
            ids: dict = {}
            parts.append(np.array([ids.setdefault(v, len(ids)) for v in values],
                                  dtype=np.int64).reshape(n, 1).view(np.uint8))
        if not parts:
            return np.arange(1), np.zeros(n, dtype=np.int64)
        table = np.ascontiguousarray(np.concatenate(parts, axis=1))
        keys = table.view(np.dtype((np.void, table.shape[1]))).ravel()
        _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        return first[order], rank[inverse.ravel()]

    def take(self, rows: np.ndarray) -> "Columns":
        """The states at ``rows`` as columns of their own (each labelled as its row here)."""
        rows = np.asarray(rows, dtype=np.int64)
        label = self.label
        return Columns(
            n=len(rows), elements=self.elements,
            numbers={k: v[rows] for k, v in self.numbers.items()},
            booleans={k: v[rows] for k, v in self.booleans.items()},
            functions={k: (v[rows], d[rows]) for k, (v, d) in self.functions.items()},
            masks={k: v[rows] for k, v in self.masks.items()},
            others={k: [v[i] for i in rows.tolist()] for k, v in self.others.items()},
            label=None if label is None else (lambda i: label(int(rows[i]))))

    def row_reader(self, rows: Optional[np.ndarray] = None) -> Callable[[int], dict[str, Any]]:
        """:meth:`row` for many rows (``rows``: only those will be read; default all): their
        values made Python lists at once (a row is then read without a numpy scalar per
        value), each row the same dict :meth:`row` gives."""
        rows = np.arange(self.n) if rows is None else np.asarray(rows, dtype=np.int64)
        at = {int(r): k for k, r in enumerate(rows.tolist())}
        numbers = [(k, v[rows].tolist()) for k, v in self.numbers.items()]
        booleans = [(k, v[rows].tolist()) for k, v in self.booleans.items()]
        functions = [(k, v[rows].tolist(), d[rows].tolist())
                     for k, (v, d) in self.functions.items()]
        masks = [(k, m[rows].tolist()) for k, m in self.masks.items()]
        others = list(self.others.items())
        elements = self.elements

        def read(row: int) -> dict[str, Any]:
            i = at[row]
            state: dict[str, Any] = {k: v[i] for k, v in numbers}
            state.update((k, bool(v[i])) for k, v in booleans)
            for k, vals, defined in functions:
                state[k] = FuncValue({e: x for e, x, d in zip(elements, vals[i], defined[i])
                                      if d})
            for k, m in masks:
                state[k] = frozenset(e for e, inside in zip(elements, m[i]) if inside)
            state.update((k, v[row]) for k, v in others)
            return state
        return read

    def keys(self, rows: np.ndarray, ids: dict) -> list[bytes]:
        """For each of ``rows``, bytes that are equal exactly where the states are (as
        :meth:`distinct` compares them): a key that holds across blocks of columns read
        with the same ``ids`` (the number given to each value of a column of other values,
        kept by the caller)."""
        parts = [self._bytes(rows)]
        for values in self.others.values():
            parts.append(np.array([ids.setdefault(values[int(r)], len(ids)) for r in rows],
                                  dtype=np.int64).reshape(len(rows), 1).view(np.uint8))
        table = np.ascontiguousarray(np.concatenate(parts, axis=1))
        return [bytes(t) for t in table]

    def _bytes(self, rows: np.ndarray) -> np.ndarray:
        n = len(rows)
        parts = [np.zeros((n, 0), dtype=np.uint8)]
        for arr in (*self.numbers.values(), *self.booleans.values()):
            parts.append(np.ascontiguousarray(arr[rows]).reshape(n, -1).view(np.uint8))
        for vals, defined in self.functions.values():
            parts.append(np.ascontiguousarray(vals[rows]).reshape(n, -1).view(np.uint8))
            parts.append(np.ascontiguousarray(defined[rows]).reshape(n, -1).view(np.uint8))
        for mask in self.masks.values():
            parts.append(np.ascontiguousarray(mask[rows]).reshape(n, -1).view(np.uint8))
        return np.concatenate(parts, axis=1)

    def row(self, i: int) -> dict[str, Any]:
        """State ``i`` as a dict of scalar B values."""
        state: dict[str, Any] = {}
        for name, arr in self.numbers.items():
            state[name] = arr[i].item()
        for name, arr in self.booleans.items():
            state[name] = bool(arr[i])
        for name, (vals, defined) in self.functions.items():
            state[name] = FuncValue({e: vals[i, j].item() for j, e in enumerate(self.elements)
                                     if defined[i, j]})  # an int stays an int
        for name, mask in self.masks.items():
            state[name] = frozenset(e for j, e in enumerate(self.elements) if mask[i, j])
        for name, values in self.others.items():
            state[name] = values[i]
        return state


def shifted_pairs(cols: Columns) -> Columns:
    """Columns over every pair of neighbouring rows: ``v`` the state at row i + 1, ``v$0``
    the one at row i — views of the columns, not copies (pairs across two episodes are
    among them: a caller keeps only the rows it asks about).

    >>> pairs = shifted_pairs(Columns.from_states([{"x": 1}, {"x": 5}, {"x": 7}]))
    >>> pairs.numbers["x"].tolist(), pairs.numbers["x$0"].tolist()
    ([5, 7], [1, 5])
    """
    out = Columns(n=max(cols.n - 1, 0), elements=cols.elements)
    for name, arr in cols.numbers.items():
        out.numbers[name], out.numbers[name + "$0"] = arr[1:], arr[:-1]
    for name, arr in cols.booleans.items():
        out.booleans[name], out.booleans[name + "$0"] = arr[1:], arr[:-1]
    for name, (vals, defined) in cols.functions.items():
        out.functions[name] = (vals[1:], defined[1:])
        out.functions[name + "$0"] = (vals[:-1], defined[:-1])
    for name, mask in cols.masks.items():
        out.masks[name], out.masks[name + "$0"] = mask[1:], mask[:-1]
    for name, values in cols.others.items():
        out.others[name], out.others[name + "$0"] = values[1:], values[:-1]
    if cols.label is not None:
        out.label = lambda i: f"{cols.label(int(i) + 1)} (and the state before)"
    return out


def step_pairs(cols: Columns, rows: np.ndarray) -> Columns:
    """Columns over step pairs: ``v`` the state at ``rows``, ``v$0`` the state before it.

    >>> cols = Columns.from_states([{"x": 1}, {"x": 5}, {"x": 7}])
    >>> pairs = step_pairs(cols, np.array([1, 2]))
    >>> pairs.numbers["x"].tolist(), pairs.numbers["x$0"].tolist()
    ([5, 7], [1, 5])
    """
    out = Columns(n=len(rows), elements=cols.elements)
    before = rows - 1
    for name, arr in cols.numbers.items():
        out.numbers[name], out.numbers[name + "$0"] = arr[rows], arr[before]
    for name, arr in cols.booleans.items():
        out.booleans[name], out.booleans[name + "$0"] = arr[rows], arr[before]
    for name, (vals, defined) in cols.functions.items():
        out.functions[name] = (vals[rows], defined[rows])
        out.functions[name + "$0"] = (vals[before], defined[before])
    for name, mask in cols.masks.items():
        out.masks[name], out.masks[name + "$0"] = mask[rows], mask[before]
    for name, values in cols.others.items():
        out.others[name] = [values[i] for i in rows]
        out.others[name + "$0"] = [values[i] for i in before]
    if cols.label is not None:
        out.label = lambda i: f"{cols.label(int(rows[i]))} (and the state before)"
    return out


def _fits(numbers: list) -> bool:
    """Whether a column of these numbers holds each exactly: integers within int64, and
    beside floats within 2**53 (a larger one, 2**63 or 2**53 + 1, stays a Python int: the
    values' own column, evaluated one by one)."""
    ints = [v for v in numbers if type(v) is int]
    if not ints:
        return True
    most = 2 ** 53 if len(ints) < len(numbers) else 2 ** 63 - 1
    return -most - (len(ints) == len(numbers)) <= min(ints) and max(ints) <= most
