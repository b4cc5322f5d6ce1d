"""Linear temporal logic over recorded episodes, in ProB's syntax, on finite traces.

A formula is checked on every episode of a file at once: its atoms are evaluated on the
batch path over all states, and each temporal operator is a few numpy scans over all rows
that respect episode boundaries. An episode satisfies a formula when it holds at the
episode's first state.

Syntax (ProB's LTL): atoms ``{P}`` (a B predicate on the state), ``BA({P})`` (a
before-after predicate on the step from this state to the next: ``x$0`` is the value here,
``x`` the value after), ``[Op]`` (the next action is Op), ``e(Op)`` (Op is enabled under the
shield), ``deadlock`` (no operation enabled), ``true``, ``false``; ``not``, ``&``, ``or``,
``=>``; future ``X F G U W R``, past ``Y O H S T``; bounded ``G[a,b]`` and ``F[a,b]`` (steps
from now). Binding, tightest first: unary operators, then ``U W R S T`` (right-associative),
``&``, ``or``, ``=>`` (right-associative).

Finite-trace semantics (positions 0 … n of an episode with n steps):

* ``X f`` is the strong next: false at the last position. ``Y f`` is false at position 0.
* ``[Op]`` is false at the last position (no action follows); ``BA({P})`` is *true* there:
  no step leaves the last state, so none breaks P — ``G(BA({…}))`` says every step does.
* ``G f`` holds where f holds from here to the end; ``F f`` where it holds here or later;
  ``f U g``: g holds here or later and f until then; ``f W g``: ``f U g`` or ``G f``;
  ``f R g``: ``not(not f U not g)``; the past operators mirror them towards position 0.
* ``G[a,b] f``: f at every position from here + a to here + b that the episode has (true
  if it has none); ``F[a,b] f``: at one of them. The bounds are whole numbers of any size:
  one past the episode's end is the same as its end (``G[0,99999999999999999999] f`` is
  ``G f``), and they are checked in time independent of their size.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..b import ast
from ..b.columns import step_pairs
from ..errors import BSyntaxError, InputError, TracecheckError

__all__ = ["parse_ltl", "Formula", "evaluate_ltl", "reference_ltl", "assertions",
           "check_ltl", "LtlCheck"]


# ------------------------------------------------------------------ formulas


@dataclass(frozen=True)
class Formula:
    """A node of an LTL formula (``op`` says which; see the module docstring)."""

    op: str  # atom, before_after, next_op, enabled, deadlock, true, false, not,
    #          G F X Y H O, & or =>, U W R S T
    args: tuple = ()
    text: str = ""  # the B text of an atom, or the operation name
    node: Optional[ast.Node] = None  # the parsed B predicate of an atom
    lo: Optional[int] = None  # bounds of G[a,b] / F[a,b]
    hi: Optional[int] = None
    column: int = 0


_UNARY = {"G", "F", "X", "Y", "H", "O", "not"}
_BINARY = {"U": 4, "W": 4, "R": 4, "S": 4, "T": 4, "&": 3, "or": 2, "=>": 1}
_RIGHT = {"U", "W", "R", "S", "T", "=>"}
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_BOUND = re.compile(r"\[\s*-?\d")
MAX_NESTING = 200


#: Bounds above this are read as this: no episode has that many steps, and past its last
#: step a window ends where the episode ends (see the module docstring).
MAX_BOUND = 10 ** 18


def _bound(digits: str) -> int:
    return int(digits) if len(digits) <= 18 else MAX_BOUND


def _short(digits: str) -> str:
    return digits if len(digits) <= 30 else f"{digits[:12]}…({len(digits)} digits)"


class _Parser:
    def __init__(self, text: str, where: str) -> None:
        self.text, self.where, self.i, self.depth = text, where, 0, 0

    def fail(self, message: str, at: Optional[int] = None) -> BSyntaxError:
        at = self.i if at is None else at
        line = self.text.count("\n", 0, at) + 1
        column = at - (self.text.rfind("\n", 0, at) + 1) + 1
        return BSyntaxError(message, file=self.where, line=line, column=column,
                            source=self.text)

    def skip(self) -> None:
        while self.i < len(self.text) and self.text[self.i].isspace():
            self.i += 1

    def peek(self) -> str:
        """The next token (without taking it)."""
        self.skip()
        t = self.text
        if self.i >= len(t):
            return ""
        for sym in ("=>", "&", "(", ")", "{", "[", "∧", "∨", "¬"):
            if t.startswith(sym, self.i):
                return sym
        m = _WORD.match(t, self.i)
        return m.group() if m else t[self.i]

    def take(self, token: str) -> None:
        if self.peek() != token:
            found = self.peek() or "the end of the formula"
            raise self.fail(f"expected {token!r} but found {found!r}")
        self.i += len(token)

    def formula(self, min_prec: int = 1) -> Formula:
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise self.fail(f"the formula nests more than {MAX_NESTING} levels deep")
        try:
            left = self.unary()
            while True:
                tok = {"∧": "&", "∨": "or"}.get(self.peek(), self.peek())
                prec = _BINARY.get(tok)
                if prec is None or prec < min_prec:
                    return left
                start = self.i
                self.i += len(self.peek())
                right = self.formula(prec if tok in _RIGHT else prec + 1)
                left = Formula(tok, (left, right), column=start)
        finally:
            self.depth -= 1

    def unary(self) -> Formula:
        tok = {"¬": "not"}.get(self.peek(), self.peek())
        start = self.i
        if tok in _UNARY:
            self.i += len(self.peek())
            lo = hi = None
            if tok in ("G", "F") and self.peek() == "[" and _BOUND.match(self.text, self.i):
                lo, hi = self.bounds()  # G[a,b] f; but F [Op] is F of an action
            self.depth += 1
            if self.depth > MAX_NESTING:
                raise self.fail(f"the formula nests more than {MAX_NESTING} levels deep")
            try:
                inner = self.unary()
            finally:
                self.depth -= 1
            return Formula(tok, (inner,), lo=lo, hi=hi, column=start)
        return self.atom()

    def bounds(self) -> tuple[int, int]:
        start = self.i
        self.take("[")
        m = re.compile(r"\s*(\d+)\s*,\s*(\d+)\s*\]").match(self.text, self.i)
        if not m:
            raise self.fail("expected bounds [a,b] with whole numbers of steps, e.g. [0,3]")
        lo, hi = (m.group(k).lstrip("0") or "0" for k in (1, 2))
        if (len(lo), lo) > (len(hi), hi):  # compared as written: any number of digits
            raise self.fail(f"the bounds [{_short(lo)},{_short(hi)}] are empty: the first is "
                            "larger than the second", at=start)
        self.i = m.end()
        return _bound(lo), _bound(hi)

    def braces(self) -> tuple[str, int]:
        """The B text between ``{`` and its matching ``}``."""
        self.take("{")
        start, depth = self.i, 1
        while self.i < len(self.text) and depth:
            depth += {"{": 1, "}": -1}.get(self.text[self.i], 0)
            self.i += 1
        if depth:
            raise self.fail("this '{' is never closed", at=start - 1)
        return self.text[start:self.i - 1], start

    def operation(self, open_: str, close: str) -> str:
        """An operation name between ``open_`` and ``close`` (``[Op]``, ``e(Op)``)."""
        self.take(open_)
        name = self.peek()
        if not _WORD.fullmatch(name or "-"):
            raise self.fail(f"expected an operation name in {open_}Op{close}")
        self.i += len(name)
        self.take(close)
        return name

    def atom(self) -> Formula:
        tok = self.peek()
        start = self.i
        if tok == "(":
            self.take("(")
            inner = self.formula()
            self.take(")")
            return inner
        if tok == "{":
            text, at = self.braces()
            return Formula("atom", text=text, column=at)
        if tok == "[":
            return Formula("next_op", text=self.operation("[", "]"), column=start)
        if tok in ("true", "false", "deadlock"):
            self.i += len(tok)
            return Formula(tok, column=start)
        if tok == "e":
            self.i += 1
            return Formula("enabled", text=self.operation("(", ")"), column=start)
        if tok == "BA":
            self.i += 2
            self.take("(")
            text, at = self.braces()
            self.take(")")
            return Formula("before_after", text=text, column=at)
        found = tok or "the end of the formula"
        raise self.fail(f"unexpected {found!r}; expected an atom ({{P}}, BA({{P}}), [Op], "
                        "e(Op), deadlock, true, false), '(' or an operator")


def parse_syntax(text: str, where: str, logic: str = "LTL") -> tuple["_Parser", Formula]:
    """The formula ``text`` as written (atoms unchecked), and its parser (for messages)."""
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"an {logic} formula is empty", file=where)
    p = _Parser(text, where)
    f = p.formula()
    if p.peek():
        raise p.fail(f"unexpected {p.peek()!r} after the formula")
    return p, f


def parse_ltl(text: str, machine, *, where: str = "<ltl>") -> Formula:
    """Parse an LTL formula and check its atoms against ``machine`` (B predicates that
    type-check, operations it has)."""
    _, f = parse_syntax(text, where)
    return _check(f, machine, text, where)


def _unknown_hint(machine) -> str:
    # a deferred set's own elements (Vehicles2, …) are not what an atom means to read
    elements = {str(e) for s, elems in machine.sets.items() if s not in machine.enumerated
                for e in elems} - set(machine.constants_declared)
    names = [n for n in machine.type_objects if "$" not in n and n not in elements]
    shown = ", ".join(names[:12]) + (", …" if len(names) > 12 else "")
    return f"an atom reads the names of {machine.name}: {shown or 'none'}"


def _check(f: Formula, machine, text: str, where: str) -> Formula:
    from dataclasses import replace

    from ..b.typecheck import typecheck_formula

    if f.op in ("atom", "before_after"):
        names = dict(machine.type_objects)
        if f.op == "before_after":
            names.update({f"{v}$0": machine.type_objects[v] for v in machine.variables
                          if v in machine.type_objects})
        try:
            node = machine.parse(f.text)
            typecheck_formula(node, names, kind="predicate", source=f.text,
                              unknown_hint=_unknown_hint(machine))
        except TracecheckError as exc:
            line = text.count("\n", 0, f.column) + 1
            column = f.column - (text.rfind("\n", 0, f.column) + 1) + 1 + (exc.column or 1) - 1
            raise type(exc)(f"in the atom {{{f.text.strip()}}}: {exc.message}", file=where,
                            line=line, column=column, source=text, hint=exc.hint) from None
        return replace(f, node=node)
    if f.op in ("next_op", "enabled") and f.text not in machine.operations:
        line = text.count("\n", 0, f.column) + 1
        column = f.column - (text.rfind("\n", 0, f.column) + 1) + 1
        raise InputError(f"unknown operation {f.text!r}; the operations of {machine.name} are "
                         f"{', '.join(machine.operations) or 'none'}", file=where, line=line,
                         column=column, source=text)
    if f.args:
        return replace(f, args=tuple(_check(a, machine, text, where) for a in f.args))
    return f


def assertions(machine) -> dict[str, str]:
    """The machine's ``ASSERT_LTL…`` definitions: name → formula text."""
    out = {}
    for name, d in getattr(machine, "definitions", {}).items():
        if name.startswith("ASSERT_LTL") and d.kind == "string":
            out[name] = d.body
    return dict(sorted(out.items()))


# ------------------------------------------------------------------ evaluation


class _Rows:
    """Where each row's episode starts and ends, for the scans."""

    def __init__(self, starts: np.ndarray) -> None:
        lengths = np.diff(starts)
        self.n = int(starts[-1])
        self.idx = np.arange(self.n)
        self.start = np.repeat(starts[:-1], lengths)
        self.end = np.repeat(starts[1:], lengths)  # exclusive

    def next_true(self, f: np.ndarray) -> np.ndarray:
        """The first row at or after each row where ``f`` holds (n if none)."""
        pos = np.where(f, self.idx, self.n)
        return np.minimum.accumulate(pos[::-1])[::-1]

    def prev_true(self, f: np.ndarray) -> np.ndarray:
        """The last row at or before each row where ``f`` holds (-1 if none)."""
        return np.maximum.accumulate(np.where(f, self.idx, -1))


def evaluate_ltl(f: Formula, cols, machine, enabled: Optional[dict] = None) -> np.ndarray:
    """Where ``f`` holds, row by row over all episodes of ``cols`` (a
    :class:`~tracecheck.episodes.columns.RunColumns`). ``enabled``: the shield's enabled
    operations per row, when already computed."""
    return _evaluator(_Rows(cols.starts), cols, machine, enabled)(f)


def _evaluator(rows: "_Rows", cols, machine, enabled: Optional[dict]):
    """``ev(formula) -> values per row``, each sub-formula evaluated once."""
    cache: dict = {}

    def ops() -> dict:
        nonlocal enabled
        if enabled is None:
            enabled = machine.enabled_batch(cols.states)
        return enabled

    def ev(g: Formula) -> np.ndarray:
        key = id(g)
        if key in cache:
            return cache[key][1]
        value = _eval(g, ev, rows, cols, machine, ops)
        cache[key] = (g, value)
        return value

    return ev


def _eval(f: Formula, ev, rows: _Rows, cols, machine, ops) -> np.ndarray:
    n, idx, start, end = rows.n, rows.idx, rows.start, rows.end
    op = f.op
    if op == "true":
        return np.ones(n, dtype=bool)
    if op == "false":
        return np.zeros(n, dtype=bool)
    if op == "atom":
        return np.asarray(machine.batch(f.node)(cols.states), dtype=bool)
    if op == "before_after":
        has_next = idx + 1 < end
        out = np.ones(n, dtype=bool)  # no step leaves the last state
        steps = idx[has_next] + 1
        if len(steps):
            out[has_next] = np.asarray(machine.batch(f.node)(step_pairs(cols.states, steps)),
                                       dtype=bool)
        return out
    if op == "next_op":
        code = cols.action_names.index(f.text) if f.text in cols.action_names else -2
        nxt = np.minimum(idx + 1, n - 1)
        return (idx + 1 < end) & (cols.action[nxt] == code)
    if op == "enabled":
        return np.asarray(ops()[f.text], dtype=bool)
    if op == "deadlock":
        table = ops()
        return ~np.any(np.stack([table[o] for o in table]), axis=0) if table else \
            np.ones(n, dtype=bool)
    a = ev(f.args[0])
    if op == "not":
        return ~a
    if op == "X":
        return (idx + 1 < end) & a[np.minimum(idx + 1, n - 1)]
    if op == "Y":
        return (idx - 1 >= start) & a[np.maximum(idx - 1, 0)]
    if op in ("G", "F") and f.lo is not None:  # bounds past every episode's end: n
        lo, hi = idx + min(f.lo, n), np.minimum(idx + min(f.hi, n), end - 1)
        some = lo <= hi
        at = np.minimum(lo, n - 1)
        if op == "G":
            return ~some | (rows.next_true(~a)[at] > hi)
        return some & (rows.next_true(a)[at] <= hi)
    if op == "G":
        return rows.next_true(~a) >= end
    if op == "F":
        return rows.next_true(a) < end
    if op == "H":
        return rows.prev_true(~a) < start
    if op == "O":
        return rows.prev_true(a) >= start
    b = ev(f.args[1])
    if op == "&":
        return a & b
    if op == "or":
        return a | b
    if op == "=>":
        return ~a | b
    if op == "U":
        k = rows.next_true(b)
        return (k < end) & (rows.next_true(~a) >= k)
    if op == "W":
        k = rows.next_true(b)
        return ((k < end) & (rows.next_true(~a) >= k)) | (rows.next_true(~a) >= end)
    if op == "R":  # not(not a U not b)
        k = rows.next_true(~b)
        return ~((k < end) & (rows.next_true(a) >= k))
    if op == "S":
        k = rows.prev_true(b)
        return (k >= start) & (rows.prev_true(~a) <= k)
    if op == "T":  # not(not a S not b)
        k = rows.prev_true(~b)
        return ~((k >= start) & (rows.prev_true(a) <= k))
    raise AssertionError(op)


@dataclass(frozen=True)
class LtlCheck:
    """One formula on the episodes of one file."""

    name: str
    formula: str
    episodes: int
    satisfied: int
    violations: tuple[tuple[int, Optional[int]], ...]  # (episode id, first violating step)


def check_ltl(name: str, text: str, f: Formula, cols, machine,
              enabled: Optional[dict] = None) -> LtlCheck:
    """Which episodes of ``cols`` satisfy ``f`` (at their first state). The first violating
    step of an episode: for ``G g``, the first step where g fails; otherwise None (the
    formula fails as a whole)."""
    rows = _Rows(cols.starts)
    ev = _evaluator(rows, cols, machine, enabled)
    values = ev(f)
    firsts = cols.starts[:-1]
    failed = np.flatnonzero(~values[firsts])
    steps: dict[int, int] = {}
    if f.op == "G" and f.lo is None and len(failed):
        where = rows.next_true(~ev(f.args[0]))[firsts[failed]]
        steps = {int(i): int(w - firsts[i]) for i, w in zip(failed, where)}
    return LtlCheck(name, text, len(firsts), len(firsts) - len(failed),
                    tuple((int(cols.episode_ids[i]), steps.get(int(i))) for i in failed))


# ------------------------------------------------------------------ reference


def reference_ltl(f: Formula, trace: list[dict]) -> list[bool]:
    """The same semantics, position by position, on one episode given as a list of
    ``{"atoms": {text: bool}, "before_after": {text: bool}, "action": name or None (the action that
    led here), "enabled": set}`` — the slow, obvious definition the scans are tested
    against."""
    n = len(trace)

    def at(g: Formula, i: int) -> bool:
        op = g.op
        if op == "true":
            return True
        if op == "false":
            return False
        if op == "atom":
            return trace[i]["atoms"][g.text]
        if op == "before_after":
            return True if i == n - 1 else trace[i]["before_after"][g.text]
        if op == "next_op":
            return i + 1 < n and trace[i + 1]["action"] == g.text
        if op == "enabled":
            return g.text in trace[i]["enabled"]
        if op == "deadlock":
            return not trace[i]["enabled"]
        a = g.args[0]
        if op == "not":
            return not at(a, i)
        if op == "X":
            return i + 1 < n and at(a, i + 1)
        if op == "Y":
            return i >= 1 and at(a, i - 1)
        if op in ("G", "F") and g.lo is not None:
            span = range(i + g.lo, min(i + g.hi, n - 1) + 1)
            return all(at(a, k) for k in span) if op == "G" else any(at(a, k) for k in span)
        if op == "G":
            return all(at(a, k) for k in range(i, n))
        if op == "F":
            return any(at(a, k) for k in range(i, n))
        if op == "H":
            return all(at(a, k) for k in range(0, i + 1))
        if op == "O":
            return any(at(a, k) for k in range(0, i + 1))
        b = g.args[1]
        if op == "&":
            return at(a, i) and at(b, i)
        if op == "or":
            return at(a, i) or at(b, i)
        if op == "=>":
            return (not at(a, i)) or at(b, i)
        if op == "U":
            return any(at(b, k) and all(at(a, j) for j in range(i, k)) for k in range(i, n))
        if op == "W":
            return at(Formula("U", (a, b)), i) or all(at(a, k) for k in range(i, n))
        if op == "R":
            return not at(Formula("U", (Formula("not", (a,)), Formula("not", (b,)))), i)
        if op == "S":
            return any(at(b, k) and all(at(a, j) for j in range(k + 1, i + 1))
                       for k in range(0, i + 1))
        if op == "T":
            return not at(Formula("S", (Formula("not", (a,)), Formula("not", (b,)))), i)
        raise AssertionError(op)

    return [at(f, i) for i in range(n)]
