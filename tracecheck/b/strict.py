"""The errors of a quantified formula's values, kept until every value was seen
(:class:`Strict`), and the values of a binder over all its solutions (:func:`each`)."""

from __future__ import annotations

from typing import Any, Callable, Optional

from ..errors import TracecheckError
from .values import sort_key

__all__ = ["Strict", "each"]

Env = dict
Fn = Callable[[Env], Any]


class Strict:
    """The errors of a quantified formula's values, kept until every value was seen: the
    formula is not well-defined if it is not for one of them, whatever the others give (B's
    well-definedness), and the error raised is that of the least values in print order, so
    neither the answer nor the message depends on the order a set is walked in."""

    __slots__ = ("error", "key")

    def __init__(self, error: TracecheckError, key: tuple) -> None:
        self.error, self.key = error, key

    @staticmethod
    def note(strict: Optional["Strict"], ids: tuple[str, ...], env: Env,
             error: TracecheckError) -> "Strict":
        key = tuple(sort_key(env.get(i)) for i in ids)
        if strict is None or key < strict.key:
            return Strict(error, key)
        return strict

    def fail(self) -> None:
        raise self.error


def each(bind, ids: tuple[str, ...], env: Env, value: Fn) -> list:
    """``value`` for every solution of a binder (comprehensions, lambdas, SIGMA …), after
    all of them were tried (see :class:`Strict`)."""
    out, strict = [], None
    for problem in bind(env):
        try:
            if problem is not None:
                raise problem
            out.append(value(env))
        except TracecheckError as exc:
            strict = Strict.note(strict, ids, env, exc)
    if strict is not None:
        strict.fail()
    return out
