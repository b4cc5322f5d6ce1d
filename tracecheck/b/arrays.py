"""The values the batch compiler (:mod:`.vector`) computes with and the numpy operations on
them: :data:`VectorValue` (a tag and arrays), the :class:`BatchContext` of one batch (which
rows go to the scalar path), arithmetic, rounding and typing tests that mark the rows
where numpy would not give B's exact result, and :func:`float_column` for the numbers of a
batch's result as floats."""

from __future__ import annotations

import math
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Optional

import numpy as np

from ..errors import EvaluationError, printable
from .columns import Columns

__all__ = ["NotVectorizable", "VectorValue", "BatchContext", "union_rows", "concat_numbers",
           "typed_member", "arith", "integral", "mark_nonfinite", "per_row", "num_of",
           "bool_of", "is_int_array", "fits", "float_column", "intern_key", "shared", "all_last"]


class NotVectorizable(Exception):
    """A formula (or part) outside the shapes the batch compiler handles: the caller
    evaluates it row by row with the scalar path instead."""


# A vector value: (tag, payload). Tags: "num", "bool" (arrays broadcastable to (n, k)),
# "elem" (an int index, or an (1, k) index array for an element-axis variable),
# "set" (bool mask (…, k)), "func" ((values, defined), each (n, k)), "nums" (a set of numbers:
# (values, member), each (n or 1, m): the values of the row where member is true).
VectorValue = tuple[str, Any]


class BatchContext:
    """One batch being evaluated: its columns, the rows marked for the scalar path, the LET
    variables in scope and the values of shared sub-formulas."""

    def __init__(self, cols: Columns) -> None:
        self.cols = cols
        self.bad: Optional[np.ndarray] = None  # the rows marked for the scalar path, if any
        self.lets: dict[str, VectorValue] = {}  # LET variables in scope
        self.memo: dict[int, tuple] = {}  # values of shared sub-formulas, see _shared

    def mark(self, rows: np.ndarray) -> None:
        """Remember the rows where ``rows`` (any shape starting with rows or 1) is true."""
        rows = self.any_per_row(rows)
        if rows.any():
            self.bad = rows if self.bad is None else self.bad | rows

    def any_per_row(self, cells: Any) -> np.ndarray:
        """Per row: whether ``cells`` (a bool, or an array of rows or 1 × axes) holds in any
        of the row's cells."""
        cells = np.asarray(cells)
        if cells.ndim == 0:
            return np.full(self.cols.n, bool(cells))
        cells = np.broadcast_to(cells, (self.cols.n,) + cells.shape[1:])
        return cells.reshape(self.cols.n, -1).any(axis=1)

    @contextmanager
    def only_where(self, cells: Any) -> Iterator[None]:
        """Inside: what is marked counts only in the rows where ``cells`` holds somewhere (the
        part of a formula evaluated there)."""
        outer, self.bad = self.bad, None
        try:
            yield
        finally:
            self.bad = union_rows(outer, None if self.bad is None
                              else self.bad & self.any_per_row(cells))


def union_rows(a: Optional[np.ndarray], b: Optional[np.ndarray]) -> Optional[np.ndarray]:
    """Rows marked in ``a`` or ``b`` (None: none)."""
    if a is None:
        return b
    return a if b is None else a | b


_INTERNED: dict[tuple, int] = {}


def intern_key(key: tuple) -> int:
    """A number for a sub-formula in its scope (equal formulas, equal numbers)."""
    return _INTERNED.setdefault(key, len(_INTERNED))


def shared(fn: Callable[[BatchContext], VectorValue], key: int
           ) -> Callable[[BatchContext], VectorValue]:
    """``fn`` computed once per batch (per :attr:`BatchContext.memo`, under ``key`` from
    :func:`intern_key`); what it marked ill-defined is marked again wherever its value is
    used."""
    def shared_fn(ctx: BatchContext) -> VectorValue:
        hit = ctx.memo.get(key)
        if hit is None:
            outer, ctx.bad = ctx.bad, None
            try:
                value = fn(ctx)
            finally:
                produced, ctx.bad = ctx.bad, union_rows(outer, ctx.bad)
            ctx.memo[key] = (value, produced)
            return value
        value, produced = hit
        ctx.bad = union_rows(ctx.bad, produced)
        return value
    return shared_fn


def concat_numbers(ctx: BatchContext, a: tuple, b: tuple) -> tuple:
    """The union of two sets of numbers (as values and members side by side)."""
    (va, ma), (vb, mb) = a, b
    rows = max(len(va), len(vb), len(ma), len(mb))
    stretch = lambda x: np.broadcast_to(x, (rows, x.shape[1]))  # noqa: E731
    return (np.concatenate([stretch(va), stretch(vb)], axis=1),
            np.concatenate([stretch(ma), stretch(mb)], axis=1))


def typed_member(a: VectorValue, s: VectorValue, n: int) -> np.ndarray:
    """Typing predicates over whole columns: ``f : S --> REAL``, ``P : POW(S)``, ``x : REAL``."""
    yes = np.ones((n, 1, 1), dtype=bool)
    if s[0] == "type":
        name = s[1]
        if a[0] == "bool" and name == "BOOL":
            return yes
        if a[0] == "num" and name in ("REAL", "FLOAT") and np.asarray(a[1]).dtype.kind == "f":
            return yes
        if a[0] == "num" and name == "INTEGER" and np.asarray(a[1]).dtype.kind in "iu":
            return yes
        raise NotVectorizable("typing")
    if s[0] == "pow" and a[0] == "set" and s[1][0] == "set":
        return per_row(all_last(~a[1] | s[1][1]))
    if s[0] == "space" and a[0] == "func":
        op, dom, ran = s[1]
        vals, defined = a[1]
        if dom[0] != "set" or ran != ("type", "REAL") or vals.dtype.kind != "f":
            raise NotVectorizable("function space")
        if op == "-->":
            return per_row(all_last(defined == dom[1]))
        return per_row(all_last(~defined | dom[1]))
    raise NotVectorizable("membership")


def arith(ctx: BatchContext, fn, op: str, a: Any, b: Any) -> Any:
    """``fn(a, b)`` where numpy gives the exact B result; the other rows are marked for the
    scalar path (which computes them exactly or reports them): integer results beyond 2^62
    (numpy would wrap around), integer powers, and reals that overflow to inf or NaN."""
    if is_int_array(a) and is_int_array(b):
        if op == "**":
            raise NotVectorizable("integer power")
        with np.errstate(over="ignore", invalid="ignore"):
            approx = fn(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
        big = ~(np.abs(approx) < 2.0 ** 62)
        if np.any(big):
            ctx.mark(np.broadcast_to(big, np.broadcast(approx).shape) if np.ndim(big)
                     else np.ones(ctx.cols.n, dtype=bool))
            a = np.where(big, 0, a) if np.ndim(big) else 0
        return fn(a, b)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        value = fn(a, b)
    mark_nonfinite(ctx, value)
    return value


def power(ctx: BatchContext, a: Any, b: Any) -> Any:
    """``a ** b`` for a real ``a`` and an integer ``b``, element by element with Python's
    own power, as the scalar path computes it (numpy's differs in the last bit: for
    ``x ** 2`` in about 1 of 1000 reals, for ``x ** 3`` in 3 of 100); overflows and
    ``0.0 ** -n`` marked for the scalar path, which reports them. Integer powers (exact,
    unbounded) and real exponents (a type error there) are not vectorised."""
    if is_int_array(a) or not is_int_array(b):
        raise NotVectorizable("integer power" if is_int_array(a) else "real exponent")
    base, exp = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b))
    out = np.empty(base.shape)
    bad = np.zeros(base.shape, dtype=bool)
    flat_out, flat_bad = out.reshape(-1), bad.reshape(-1)
    for i, (x, y) in enumerate(zip(base.reshape(-1).tolist(), exp.reshape(-1).tolist())):
        try:
            flat_out[i] = x ** y
        except (OverflowError, ZeroDivisionError):
            flat_out[i], flat_bad[i] = np.nan, True
    if bad.any():
        ctx.mark(bad if bad.ndim else np.ones(ctx.cols.n, dtype=bool))
    mark_nonfinite(ctx, out)
    return out if out.ndim else float(out)


def integral(ctx: BatchContext, fn, x: Any) -> Any:
    """B's floor and ceiling are INTEGERs, exact: int64 where the result is within 2^62, the
    other rows (and infinities) marked for the scalar path, which gives the exact integer."""
    if is_int_array(x):
        return x
    with np.errstate(invalid="ignore"):
        y = fn(np.asarray(x, dtype=float))
        big = ~(np.abs(y) < 2.0 ** 62)
    if np.any(big):
        ctx.mark(big if np.ndim(big) else np.ones(ctx.cols.n, dtype=bool))
        y = np.where(big, 0.0, y)
    return y.astype(np.int64)


def mark_nonfinite(ctx: BatchContext, value: Any) -> None:
    bad = ~np.isfinite(value)
    if np.any(bad):
        ctx.mark(bad if np.ndim(bad) else np.ones(ctx.cols.n, dtype=bool))


def all_last(values: Any) -> np.ndarray:
    """``np.all(values, axis=-1)``, the same booleans: over the few members of a set a column
    at a time, which is 2.3× faster than numpy's reduction along a short last axis (5
    vehicles), the most of a replay's typing checks.

    >>> all_last(np.array([[True, True, False], [True, True, True]])).tolist()
    [False, True]
    """
    values = np.asarray(values)
    if values.ndim == 0 or not 0 < values.shape[-1] <= 16:
        return np.all(values, axis=-1)
    out = values[..., 0].astype(bool)
    for k in range(1, values.shape[-1]):
        np.logical_and(out, values[..., k], out=out)
    return out


def per_row(values: np.ndarray) -> np.ndarray:
    """One value per row, shaped to broadcast against (rows, axis 1, axis 2)."""
    return np.asarray(values).reshape(-1, 1, 1)


def num_of(v: VectorValue) -> Any:
    if v[0] != "num":
        raise NotVectorizable(f"number expected, got {v[0]}")
    return v[1]


def bool_of(v: VectorValue) -> Any:
    if v[0] != "bool":
        raise NotVectorizable(f"boolean expected, got {v[0]}")
    return v[1]


def is_int_array(x: Any) -> bool:
    return np.issubdtype(np.asarray(x).dtype, np.integer)


def fits(out: np.ndarray, value: Any) -> bool:
    """Whether ``out`` holds ``value`` exactly (a Python integer beyond its dtype does not)."""
    if not isinstance(value, int) or isinstance(value, bool):
        return True
    if out.dtype.kind in "iu":
        return bool(np.iinfo(out.dtype).min <= value <= np.iinfo(out.dtype).max)
    return out.dtype.kind not in "f" or abs(value) <= 2 ** 53


def float_column(values, cols: Columns, source: str) -> np.ndarray:
    """``values`` (a number per row of ``cols``, as
    :class:`~tracecheck.b.vector.BatchFormula` gives them: B integers exact, in an object
    array where they do not fit 64 bits) as floats, for
    statistics and robustness; an :class:`EvaluationError` naming the row (episode, step)
    and ``source`` where an integer is too large for a float — never infinity.

    >>> float_column(np.array([2 ** 70], dtype=object), Columns(1, ()), "`2 ** 70`")
    array([1.18059162e+21])
    """
    v = np.asarray(values)
    if v.dtype != object:
        return v.astype(float)
    out = np.empty(len(v))
    for i, x in enumerate(v.tolist()):
        try:
            out[i] = float(x)
        except (TypeError, ValueError):  # a set, a string, an element: no number
            where = cols.label(i) if cols.label is not None else f"state {i}"
            raise EvaluationError(f"{where}: the value of {source} is "
                                  f"{printable(repr(x))[:80]}, not a number",
                                  hint="a metric's expression must give a number in every "
                                       "state") from None
        except OverflowError:
            where = cols.label(i) if cols.label is not None else f"state {i}"
            digits = int(math.log10(abs(x))) + 1
            raise EvaluationError(f"{where}: the value of {source}, an integer of about "
                                  f"{digits:,} digits, does not fit a float (at most about "
                                  "1.8e308): statistics and robustness are computed in floats",
                                  hint="scale the expression down") from None
    return out
