"""Signal temporal logic over episodes: quantitative robustness, discrete time (one sample
per state).

The syntax is the LTL one of :mod:`tracecheck.checking.ltl` restricted to what has a
robustness: atoms ``{E < F}``, ``{E <= F}``, ``{E > F}``, ``{E >= F}`` over numeric B
expressions (robustness ``F - E`` for ``<``/``<=``, ``E - F`` for ``>``/``>=``), ``not``
(negation), ``&`` (minimum), ``or`` (maximum), ``=>`` (``max(-a, b)``), ``X`` (the next
sample; +∞ at the last — rtamt's weak next, unlike LTL's strong ``X``), ``G``/``F`` (minimum/maximum over the rest of the episode) and
``G[a,b]``/``F[a,b]`` (over the samples a … b steps ahead that the episode has; +∞/−∞ where it
has none) — as rtamt's discrete-time offline monitor computes them, which the tests check on
random signals. An episode's robustness is the value at its first state; it satisfies the
formula when that is positive.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..b import ast
from ..b.arrays import float_column
from ..errors import TracecheckError
from .ltl import Formula, parse_syntax

__all__ = ["parse_stl", "robustness", "episode_robustness"]

_ALLOWED = {"atom", "not", "&", "or", "=>", "X", "G", "F"}
_SIGN = {">": 1.0, ">=": 1.0, "<": -1.0, "<=": -1.0}
#: how the error below names an operator where that is not its op (the name it has always
#: printed for ``BA({P})``)
_NAMED = {"before_after": "ba"}


def parse_stl(text: str, machine, *, where: str = "<stl>") -> Formula:
    """Parse an STL formula; its atoms are comparisons of numbers in ``machine``."""
    from ..b.typecheck import typecheck_formula

    p, f = parse_syntax(text, where, "STL")

    def check(g: Formula) -> Formula:
        if g.op not in _ALLOWED:
            shown = f"[{g.text}]" if g.op == "next_op" else f"e({g.text})" if g.op == \
                "enabled" else _NAMED.get(g.op, g.op)  # as written, not the parser's name
            raise p.fail(f"{shown!r} has no robustness: STL formulas use "
                         "comparisons {E < F}, not, &, or, =>, X, G, F, G[a,b], F[a,b]",
                         at=g.column)
        if g.op != "atom":
            return replace(g, args=tuple(check(a) for a in g.args))
        try:
            node = machine.parse(g.text)
            typecheck_formula(node, dict(machine.type_objects), kind="predicate",
                              source=g.text)
        except TracecheckError as exc:
            raise p.fail(f"in the atom {{{g.text.strip()}}}: {exc.message}",
                         at=g.column) from None
        if not (isinstance(node, ast.Rel) and node.op in _SIGN):
            raise p.fail(f"the atom {{{g.text.strip()}}} is not a comparison E < F, E <= F, "
                         "E > F or E >= F of numbers", at=g.column)
        return replace(g, node=node)

    return check(f)


def robustness(f: Formula, cols, machine) -> np.ndarray:
    """The robustness of ``f`` at every row of ``cols`` (episodes kept apart)."""
    n = int(cols.starts[-1])
    idx = np.arange(n)
    lengths = np.diff(cols.starts)
    end = np.repeat(cols.starts[1:], lengths)

    def ev(g: Formula) -> np.ndarray:
        op = g.op
        if op == "atom":
            where = f"a side of the atom {{{g.text.strip()}}}"
            left = float_column(machine.batch(g.node.left)(cols.states), cols.states, where)
            right = float_column(machine.batch(g.node.right)(cols.states), cols.states, where)
            return _SIGN[g.node.op] * (left - right)
        a = ev(g.args[0])
        if op == "not":
            return -a
        if op == "X":
            return np.where(idx + 1 < end, a[np.minimum(idx + 1, n - 1)], np.inf)
        if op in ("G", "F"):
            pick = np.minimum if op == "G" else np.maximum
            empty = np.inf if op == "G" else -np.inf
            if g.lo is None:
                return _suffix(a, cols.starts, pick)
            return _window(a, cols.starts, g.lo, g.hi, pick, empty)
        b = ev(g.args[1])
        if op == "&":
            return np.minimum(a, b)
        if op == "or":
            return np.maximum(a, b)
        return np.maximum(-a, b)  # =>

    return ev(f)


def _suffix(a: np.ndarray, starts: np.ndarray, pick) -> np.ndarray:
    """``pick`` (minimum or maximum) over each row and the rows after it in its episode."""
    out = np.empty_like(a)
    for lo, hi in zip(starts[:-1].tolist(), starts[1:].tolist()):
        out[lo:hi] = pick.accumulate(a[lo:hi][::-1])[::-1]
    return out


def _window(a: np.ndarray, starts: np.ndarray, lo: int, hi: int, pick, empty: float
            ) -> np.ndarray:
    """``pick`` over the rows lo … hi ahead of each row that its episode has (``empty``
    where it has none): O(rows) whatever the bounds, which may exceed any episode (Python
    ints, never converted to numpy's)."""
    out = np.full(len(a), empty)
    for first, stop in zip(starts[:-1].tolist(), starts[1:].tolist()):
        if lo < stop - first:
            seg = a[first + lo:stop]  # out[first + i] = pick(seg[i : i + width])
            out[first:first + len(seg)] = _sliding(seg, min(hi - lo + 1, len(seg)), pick,
                                                   empty)
    return out


def _sliding(x: np.ndarray, width: int, pick, empty: float) -> np.ndarray:
    """``pick`` of ``x[i : i + width]`` for every i, past the end padded with ``empty``
    (van Herk / Gil-Werman: running picks forwards and backwards within blocks of
    ``width``, then one pick of two per window)."""
    m = len(x)
    blocks = -(-(m + width - 1) // width)
    padded = np.full(blocks * width, empty)
    padded[:m] = x
    grid = padded.reshape(blocks, width)
    forward = pick.accumulate(grid, axis=1).ravel()
    backward = pick.accumulate(grid[:, ::-1], axis=1)[:, ::-1].ravel()
    return pick(backward[:m], forward[width - 1:width - 1 + m])


def episode_robustness(f: Formula, cols, machine) -> np.ndarray:
    """The robustness of ``f`` for each episode (at its first state)."""
    return robustness(f, cols, machine)[cols.starts[:-1]]
