"""Tune two numbers of a shield at once (``tracecheck tune --param A --param B --grid N``): on
the grid of N values of each (and the machine's own value), and exactly along each axis — for each grid value of B, the
figures for every value of A (the machine with that B written in, tuned in A as
:mod:`.tuning` does), and for each grid value of A, every value of B. Where the two lines of
the grid cross, both give the figures of the machine with both values written in."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

from ..checking.shield import Shield
from ..errors import InputError
from .tune_target import Target, check_range, resolve_target
from .tuning import TuneResult, shield_with, tune

__all__ = ["PairResult", "tune_pair", "grid_values", "found_again"]


@dataclass
class PairResult:
    """Per grid value of one number, the exact tuning of the other (see the module)."""

    shield: dict
    targets: tuple[Target, Target]
    ranges: tuple[tuple[float, float], tuple[float, float]]
    grids: tuple[list[float], list[float]]
    #: along the first number, one tuning per grid value of the second; and the other way
    along_first: list[tuple[float, TuneResult]] = field(default_factory=list)
    along_second: list[tuple[float, TuneResult]] = field(default_factory=list)
    elapsed_s: float = 0.0


def grid_values(low: float, high: float, n: int, integer: bool) -> list[float]:
    """``n`` values evenly over [low, high] (whole numbers for an INTEGER, each once)."""
    step = (high - low) / (n - 1)
    values = [low + k * step for k in range(n)]
    if integer:
        values = [float(round(v)) for v in values]
    return list(dict.fromkeys(values))


def found_again(machine, target: Target, fixed: Target, shield: Shield) -> Target:
    """``target`` found again in ``machine`` (``shield``'s with ``fixed`` rewritten): the
    same constant or definition, or the same number written at its place, moved by what the
    rewriting changed before it on its line."""
    if target.kind != "literal":
        return resolve_target(machine, param=target.label)
    old = shield.machine.source
    start = target.span[0]
    if fixed.span[0] < start:
        start += len(machine.source) - len(old)
    line = machine.source.count("\n", 0, start) + 1
    column = start - (machine.source.rfind("\n", 0, start) + 1) + 1
    scope = target.label.partition(":")[0]
    return resolve_target(machine, literal=f"{scope}:{target.value!r}@{line}:{column}")


def tune_pair(paths: Iterable[str | Path], shield: Shield, targets: Sequence[Target],
              ranges: Sequence[tuple[float, float]], n: int) -> PairResult:
    """Tune ``targets`` (two) over their ``ranges`` on a grid of ``n`` values each, exactly
    along each axis (see the module docstring)."""
    a, b = targets
    if a.span == b.span:
        raise InputError(f"{a.label} and {b.label} are the same number: give two")
    paths = [str(p) for p in paths]
    start = time.perf_counter()
    grids = tuple(sorted(set(grid_values(lo, hi, n, t.integer)) | (
        {float(t.value)} if lo <= t.value <= hi else set()))  # the machine's own value too
        for (lo, hi), t in zip(ranges, targets))
    result = PairResult(shield.identity, (a, b), tuple(ranges), grids)  # type: ignore[arg-type]
    for along, fixed, lines, (lo, hi), out in (
            (a, b, grids[1], ranges[0], result.along_first),
            (b, a, grids[0], ranges[1], result.along_second)):
        crossing = grids[0] if along is a else grids[1]
        for v in lines:
            rewritten = shield_with(shield, fixed, v)
            moved = found_again(rewritten.machine, along, fixed, shield)
            check_range(rewritten.machine, moved, lo, hi)
            out.append((v, tune(paths, rewritten, moved, lo, hi, at=crossing)))
    result.elapsed_s = round(time.perf_counter() - start, 6)
    return result
