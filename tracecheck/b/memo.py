"""Values remembered while evaluating: arithmetic on literals folded when compiling, and
sub-formulas computed once per state (kept in the environment under :data:`MEMO_KEY`)."""

from __future__ import annotations

import threading
from typing import Any, Callable

from ..errors import TracecheckError
from . import ast

__all__ = ["MEMO_KEY", "folded", "constant_number", "memoised", "fresh"]

Env = dict
Fn = Callable[[Env], Any]

MEMO_KEY = "$memo"  # not a B identifier: cannot clash with a variable
_SLOTS: dict[ast.Node, int] = {}
_SLOT_LOCK = threading.Lock()
_MISSING = object()


def folded(fn: Fn) -> Fn:
    """Arithmetic on literals (common after definitions are expanded: ``-4.0 - 2.0``) is
    computed once, when compiling; an ill-defined one is left to fail where it is used."""
    try:
        value = fn({})
    except TracecheckError:
        return fn
    except Exception:  # noqa: BLE001 - ill-typed (BOOL || {}): raised where it is evaluated,
        return fn      # as without folding, never when compiling a branch not taken
    folded = lambda env: value  # noqa: E731
    folded.constant = value  # type: ignore[attr-defined]
    return folded


def constant_number(node: ast.Node, fn: Fn) -> Any:
    """The value of a numeric literal, or of folded arithmetic on literals, else None."""
    if isinstance(node, (ast.IntLit, ast.RealLit)):
        return node.value
    value = getattr(fn, "constant", None)
    return value if type(value) in (int, float) else None


def memoised(fn: Fn, node: ast.Node) -> Fn:
    """Evaluate ``fn`` once per environment dict (one state), however often it is asked."""
    slot = _SLOTS.get(node)
    if slot is None:
        with _SLOT_LOCK:  # two threads compiling: never one slot for two formulas
            slot = _SLOTS.setdefault(node, len(_SLOTS))

    def memo(env: Env) -> Any:
        cache = env.get(MEMO_KEY)
        if cache is None:
            cache = env[MEMO_KEY] = {}
        value = cache.get(slot, _MISSING)
        if value is _MISSING:  # the first use in a state is the common case: no exception
            value = cache[slot] = fn(env)
        return value
    return memo


def fresh(env: Env) -> Env:
    """A copy of ``env`` to change: without the remembered values of the original."""
    out = dict(env)
    out.pop(MEMO_KEY, None)
    return out
