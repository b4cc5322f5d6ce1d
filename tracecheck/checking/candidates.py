"""Walking the candidate values of a predicate's identifiers (:mod:`.solving`'s finite
problems): each combination in turn, every conjunct checked as soon as its identifiers have
values, an identifier an equality computes taken from it, all within a deadline."""

from __future__ import annotations

import time
from typing import Iterator

from ..errors import TracecheckError, WellDefinednessError

__all__ = ["Clock", "assignments", "computed"]


class Clock:
    """Stops a walk at the deadline (looked at every 1024 values)."""

    def __init__(self, deadline: float) -> None:
        self.deadline, self.tried, self.stopped = deadline, 0, False

    def tick(self) -> bool:
        self.tried += 1
        if self.tried % 1024 == 0 and time.monotonic() > self.deadline:
            self.stopped = True
        return self.stopped


def assignments(order, domains, checks, env, clock: Clock) -> Iterator[dict]:
    """``env`` with each combination of values that passes the conjuncts checked at each
    depth (a conjunct with no value there is left to the whole predicate)."""
    def go(depth: int) -> Iterator[dict]:
        name = order[depth]
        values = domains[name]
        for value in (values(env) if callable(values) else values):
            if clock.tick():
                return
            env[name] = value
            if not all(passes(c, env) for c in checks[depth]):
                continue
            if depth + 1 == len(order):
                yield env
            else:
                yield from go(depth + 1)
    if order:
        yield from go(0)
    else:
        yield env


def computed(fn, order: list, undefined: list):
    """The values of an identifier an equality computes: the one its expression has here
    (none where it has no value: the first such place goes to ``undefined``)."""
    def values(env) -> list:
        try:
            return [fn(env)]
        except WellDefinednessError as exc:
            if not undefined:
                undefined.append(({n: env[n] for n in order if n in env}, exc))
            return []
    return values


def passes(check, env) -> bool:
    try:
        return check(env) is not False
    except TracecheckError:
        return True
