"""A machine's questions asked of a whole recording at once: each guard, the INVARIANT and
each operation's before-after predicate evaluated over columns (one call per formula), a
mixin of :class:`~tracecheck.b.machine.Machine` (which gives ``base_env``, ``operations``,
``allowed_in``, …)."""

from __future__ import annotations

from typing import Any, Mapping, Optional

from ..errors import InputError, UnsupportedError
from . import ast
from .linear import real_parameters, real_typed

__all__ = ["BatchQuestions"]


class BatchQuestions:
    """``enabled_batch``, ``invariant_batch``, ``postcondition_batch``."""

    def batch(self, node: ast.Node):
        """A :class:`~tracecheck.b.vector.BatchFormula` for ``node`` in this machine."""
        from .vector import BatchFormula

        return BatchFormula(node, self.base_env, source=self.source, file=self.file)

    def _batch_cached(self, key: tuple, node: ast.Node):
        cache = self._compiled.setdefault("batch", {})
        if key not in cache:
            cache[key] = self.batch(node)
        return cache[key]

    def enabled_batch(self, columns, candidates: Optional[Mapping[str, Any]] = None, *,
                      bounds: Optional[Mapping[str, tuple[dict, dict]]] = None) -> dict:
        """For each operation, a bool array: is it enabled in each row of ``columns``?

        An operation with REAL parameters is enabled where some values are allowed. Where
        ``candidates[op]`` (a list of ``{parameter: array of a value per row}``, NaN: none)
        holds values that its guard allows, by one batch evaluation of the guard with them
        bound, that is the answer (the evaluator confirmed an allowed value); the other rows
        are decided one distinct state at a time, as :meth:`enabled` decides them — within
        ``bounds[op]`` (an action space's (low, high) by parameter) where given."""
        import numpy as np

        out = {}
        memo: dict = {}  # what the guards have in common, computed once
        for name, op in self.operations.items():
            if op.guard is None:
                out[name] = np.ones(columns.n, dtype=bool)
                continue
            if real_parameters(op):
                out[name] = self._enabled_real(name, columns, (candidates or {}).get(name, ()),
                                               (bounds or {}).get(name))
                continue
            guard = self._batch_cached(("guard", name), op.enabling_guard)
            if real_typed(op):  # as the scalar path says it
                guard = self.mixed(op, guard)
            out[name] = guard(columns, memo).astype(bool)
        return out

    def _enabled_real(self, name: str, columns, candidates,
                      bounds: Optional[tuple[dict, dict]] = None) -> Any:
        """:meth:`enabled_batch` for an operation with REAL parameters (some values allowed
        within ``bounds``, where given: candidates are the caller's to keep within them)."""
        import numpy as np

        op = self.operation(name)
        enabled = np.zeros(columns.n, dtype=bool)
        guard = self._batch_cached(("guard with parameters", name), op.guard)
        for values in candidates:
            given = np.all([np.isfinite(values[p]) for p in op.params], axis=0)
            rows = np.flatnonzero(given & ~enabled)
            if not len(rows):
                continue
            bound = columns.take(rows)
            bound.numbers.update({p: np.asarray(values[p], dtype=float)[rows]
                                  for p in op.params})
            enabled[rows] = np.asarray(guard(bound), dtype=bool)
        rest = np.flatnonzero(~enabled)
        if len(rest):  # the scalar decision, once per distinct state
            decide = self._guard_fns()[name] if bounds is None else \
                (lambda env: self.allowed_in(name, env).within(*bounds).witness() is not None)
            others = columns.take(rest)
            first, index = others.distinct()

            def one(i: int) -> bool:
                try:
                    return bool(decide(self.env(others.row(i))))
                except (UnsupportedError, InputError) as exc:  # undecided, or a value the
                    if others.label is None or exc.line is not None:  # shield has not: say
                        raise  # which state
                    message = exc.message.removeprefix("the state: ")
                    raise type(exc)(f"{others.label(i)}: {message}", hint=exc.hint) from None
            enabled[rest] = np.array([one(int(i)) for i in first], dtype=bool)[index]
        return enabled

    def invariant_batch(self, columns):
        """A bool array: does the INVARIANT hold in each row of ``columns``?"""
        import numpy as np

        if self.invariant_node is None:
            return np.ones(columns.n, dtype=bool)
        return self._batch_cached(("invariant",), self.invariant_node)(columns).astype(bool)

    def postcondition_batch(self, op: str, pairs):
        """A bool array over step pairs (``v`` after, ``v$0`` before, see
        :meth:`postcondition`): is each step a possible effect of ``op``? None when the body
        has no such predicate (then :meth:`effect_ok` decides step by step)."""
        node = self.postcondition(op)
        if node is None:
            return None
        return self._batch_cached(("post", op), node)(pairs).astype(bool)

