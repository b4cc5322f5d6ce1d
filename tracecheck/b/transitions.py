"""Successor states the way ProB finds them for SimB's external simulation.

An agent script that speaks SimB's external-simulation protocol answers each step with an
operation and a predicate over the state after it (``x = 3 & y = 0``, usually one equation
per variable). As in ProB, the successor is a state that the operation can reach from the
current one *and* that satisfies the predicate: variables the predicate fixes take its
values, the others the values the operation's substitution gives them (the drone swarm's
script sends only ``drone_positions``; its machine computes ``visited`` and
``current_drone``). A variable fixed by neither is an error, never a guess.

>>> from tracecheck.b import load_machine_text
>>> m = load_machine_text('''MACHINE Walk
... VARIABLES pos, steps
... INVARIANT pos : 0..3 & steps : NATURAL
... INITIALISATION pos :: 0..3 ; steps := 0
... OPERATIONS Right = PRE pos < 3 THEN pos := pos + 1 ; steps := steps + 1 END END''')
>>> first = successor(m, None, {}, m.parse("pos = 1"))
>>> dict(first.state), first.possible
({'pos': 1, 'steps': 0}, True)
>>> nxt = successor(m, "Right", first.state, m.parse("pos = 2"))
>>> dict(nxt.state), nxt.possible
({'pos': 2, 'steps': 1}, True)
>>> successor(m, "Right", nxt.state, m.parse("pos = 0")).possible  # not what Right does
False
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from itertools import islice
from typing import Any, Callable, Mapping, Optional

from .cache import Cache
from ..errors import EvaluationError, InputError, TracecheckError, UnsupportedError
from . import ast
from .bindings import conjuncts
from .memo import fresh
from .notation import parse_literal
from .substitution import SubstCompiler, written
from .values import Elem

__all__ = ["Successor", "successor", "fixed_values", "equations", "initial_state_ok",
           "UndeterminedError"]

#: per machine, (operation, strict) -> how its successors are found
_PLANS: Cache = Cache("successor plans")

#: the most candidate outcomes tried for one step (SELECT/CHOICE branches, ANY values)
MAX_CANDIDATES = 4096

Env = dict
Plan = Callable[[Env, Mapping[str, Any]], list]


class UndeterminedError(InputError):
    """The predicate and the operation together leave a variable without a value, or with
    several."""


@dataclass(frozen=True)
class Successor:
    """The state after a step, and whether the operation (its guards aside) can reach it
    while satisfying the predicate — False is a postcondition violation."""

    state: Mapping[str, Any]
    possible: bool
    #: whether the predicate holds in ``state`` (False only when it says more than which
    #: values the variables have: ``x > 3`` where the operation gives ``x`` its value)
    satisfies: bool = True


def fixed_values(machine, predicate: ast.Node) -> dict[str, Any]:
    """The values the conjuncts ``v = E`` (or ``E = v``) of ``predicate`` give state
    variables, ``E`` not reading the state (a literal, constants)."""
    variables = set(machine.variables)
    comp = machine.compiler()
    out: dict[str, Any] = {}
    for conj in conjuncts(predicate):
        if not (isinstance(conj, ast.Rel) and conj.op == "="):
            continue
        for name, expr in ((conj.left, conj.right), (conj.right, conj.left)):
            if (isinstance(name, ast.Name) and name.id in variables and name.id not in out
                    and not (ast.free_names(expr) & variables)):
                out[name.id] = comp.compile(expr)(dict(machine.base_env))
                break
    return out


def equations(machine, text: str, memo: Optional[dict] = None) -> Optional[dict[str, Any]]:
    """The values of a predicate that is only ``v = literal`` conjuncts (what agent scripts
    send: ``x = 3 & field = {(0 |-> 0) |-> ICE, …}``), each variable once and every name in
    a literal an element of the machine's sets — read by the literal reader, which is
    ~50 times faster than the grammar on such text; None for anything else (parse it).
    Each value is type-checked against its variable (:class:`InputError` if it does not
    fit); ``memo`` keeps the literals read and checked before, by variable, so a value sent
    again unchanged (a map in every step) is read once.

    >>> from tracecheck.b import load_machine_text
    >>> m = load_machine_text("MACHINE M SETS C = {red, blue} VARIABLES x, c "
    ...                       "INVARIANT x : INTEGER & c : C INITIALISATION x, c := 0, red END")
    >>> equations(m, "x = -2 & c = blue") == {"x": -2, "c": Elem("blue")}
    True
    >>> equations(m, "x = 1 + 1"), equations(m, "x = 2 or c = red"), equations(m, "c = x")
    (None, None, None)
    """
    parts = _top_level_and(text)
    if parts is None:
        return None
    owners = machine.element_sets()
    out: dict[str, Any] = {}
    for part in parts:
        found = _equation(part)
        if found is None or found[0] not in machine.variables or found[0] in out:
            return None
        name, literal = found
        known = memo.get(name) if memo is not None else None
        if known is not None and known[0] == literal:
            out[name] = known[1]
            continue
        try:
            value = parse_literal(literal)
        except TracecheckError:
            return None
        if any(e not in owners for e in _elements(value)):
            return None  # a constant's or a variable's name: only the grammar knows
        machine.check_state({name: value}, where="the predicate")
        if memo is not None:
            memo[name] = (literal, value)
        out[name] = value
    return out


def _equation(part: str) -> Optional[tuple[str, str]]:
    """``name = literal`` as (name, literal), the spaces around each left out; None where
    ``part`` is not that (``<=``, ``==``, ``=>``, no name, nothing after)."""
    name, eq, rest = part.partition("=")
    name, literal = name.strip(), rest.strip()
    if not eq or not literal or rest[0] in "=>" or not (
            name.isascii() and name.isidentifier()):
        return None
    return name, literal


_SPECIAL = re.compile(r'[()\[\]{}"&\\]')


def _top_level_and(text: str) -> Optional[list[str]]:
    """``text`` split at the ``&`` outside brackets and strings; None when they do not
    balance."""
    if '"' not in text and "\\" not in text:  # no string: the brackets counted between &s
        return _split_counted(text)
    parts, depth, start, quoted, escaped = [], 0, 0, False, -1
    for m in _SPECIAL.finditer(text):
        c, i = m.group(), m.start()
        if i == escaped:
            continue
        if quoted:
            if c == "\\":
                escaped = i + 1
            elif c == '"':
                quoted = False
        elif c == '"':
            quoted = True
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
            if depth < 0:
                return None
        elif c == "&" and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    if depth or quoted:
        return None
    parts.append(text[start:])
    return parts


def _split_counted(text: str) -> Optional[list[str]]:
    """:func:`_top_level_and` for a text without strings, the brackets counted in C between
    one ``&`` and the next (an agent's predicate is a long map and a few ``&``). Where the
    depth dips below zero inside a part and comes back (``x = )(``), that part is no
    literal and the caller parses the predicate with the grammar, as when None."""
    parts, pieces, depth = [], [], 0
    for piece in text.split("&"):
        pieces.append(piece)
        depth += (piece.count("(") + piece.count("[") + piece.count("{")
                  - piece.count(")") - piece.count("]") - piece.count("}"))
        if depth < 0:
            return None
        if depth == 0:
            parts.append("&".join(pieces))
            pieces = []
    return None if depth or pieces else parts


def _elements(value: Any):
    if isinstance(value, Elem):
        yield value
    elif isinstance(value, (tuple, frozenset, list)):
        for item in value:
            yield from _elements(item)
    elif hasattr(value, "map"):
        for pair in value.map.items():
            yield from _elements(pair)


def successor(machine, op: Optional[str], before: Mapping[str, Any],
              predicate: Optional[ast.Node], *,
              fixed: Optional[Mapping[str, Any]] = None) -> Successor:
    """The state after ``op`` (None: the INITIALISATION) from ``before`` that satisfies
    ``predicate`` (parsed and checked in ``machine``'s scope) — or, with ``predicate``
    None, that gives the variables the values ``fixed`` (the :func:`equations` of a
    predicate, type-checked by the caller).

    Raises :class:`UndeterminedError` when a variable is fixed neither by the predicate nor
    by the substitution, or when several different states qualify.
    """
    if predicate is None:
        if fixed is None:
            raise ValueError("successor() needs a predicate or the fixed values")
    else:
        fixed = fixed_values(machine, predicate)
    body = machine.initialisation if op is None else machine.operation(op).body
    if body is None:
        body = ast.Skip()
    writes = written(body)
    free = [v for v in machine.variables if v not in fixed and (op is None or v in writes)]
    pre = machine.env({} if op is None else before)
    if not free:
        candidates = [{}]
    else:
        if op is not None and machine.operation(op).params:
            raise UndeterminedError(
                f"{op} has parameters, so tracecheck does not run it to find "
                f"{', '.join(free)}; the predicate must fix every variable it writes")
        candidates = _plan(machine, op, body)(pre, fixed)
    outcome = _choose(machine, op, before, predicate, fixed, candidates)
    if outcome is None:
        missing = [v for v in free if v not in (candidates[0] if candidates else {})]
        what = "the INITIALISATION" if op is None else op
        raise UndeterminedError(
            f"{', '.join(missing or free)} fixed neither by the predicate nor by {what}",
            hint="the predicate must give every variable the operation does not compute "
                 "(`v = value`)")
    return outcome


def _choose(machine, op, before, predicate, fixed, candidates) -> Optional[Successor]:
    """The one state among ``candidates`` (updates, fixed values override) that the
    operation reaches and the predicate accepts; else the first the predicate accepts, else
    the first (flagged); None when a candidate leaves a variable without a value."""
    check = machine.compile(predicate) if predicate is not None else None
    states, good = [], []
    for updates in candidates:
        state = {v: before[v] for v in machine.variables if v in before and op is not None}
        state.update(updates)
        state.update(fixed)
        if any(v not in state for v in machine.variables):
            return None
        state = {v: state[v] for v in machine.variables}
        holds = check is None or bool(check(machine.env(state)))
        possible = _possible(machine, op, before, state)
        states.append(Successor(state, possible, holds))
        if possible and holds and state not in good:
            good.append(state)
    if len(good) > 1:
        differ = sorted(v for v in machine.variables if good[0][v] != good[1][v])
        raise UndeterminedError(
            f"{', '.join(differ)}: several values fit the predicate and "
            f"{'the INITIALISATION' if op is None else op}",
            hint="fix them in the predicate (`v = value`)")
    if good:
        return Successor(good[0], True)
    if not states:  # no branch of the substitution applies (its guards are false)
        return None
    return next((s for s in states if s.satisfies), states[0])


def _possible(machine, op, before, state) -> bool:
    """Whether the substitution (guards aside) reaches ``state``: the before-after check of
    replay where it applies; for a sequence that starts non-deterministically (``x :: S ;
    y := f(x)``, common in INITIALISATIONs) by running it with the chosen values checked.
    An operation with parameters: for some values of them (its guard included, since the
    parameters' types are part of it). Raises :class:`UnsupportedError` when it cannot
    tell."""
    try:
        try:
            if op is None:
                return machine.initialisation_ok(state)
            if machine.operation(op).params:
                return machine.check_after(op, before, state)
            return machine.effect_ok(op, before, state)
        except UnsupportedError:
            return _possible_by_running(machine, op, before, state)
    except EvaluationError as exc:  # a limit, a set it cannot walk: it cannot tell
        what = "the INITIALISATION" if op is None else op
        raise UnsupportedError(f"tracecheck cannot tell whether {what} can give this state: "
                               f"{exc.message}", file=exc.file, source=exc.source,
                               line=exc.line, column=exc.column, hint=exc.hint) from None


def _possible_by_running(machine, op, before, state) -> bool:
    body = machine.initialisation if op is None else machine.operation(op).body
    start = {} if op is None else {v: before[v] for v in machine.variables if v in before}
    try:
        runs = _plan(machine, op, body, strict=True)(machine.env(start), state)
    except UndeterminedError as exc:
        what = "the INITIALISATION" if op is None else op
        raise UnsupportedError(f"tracecheck cannot check whether {what} can give this state: "
                               f"{exc.message}") from None
    target = {v: state[v] for v in machine.variables}
    return any(dict(start, **run) == target for run in runs)


def initial_state_ok(machine, state: Mapping[str, Any]) -> bool:
    """Whether the INITIALISATION can give ``state`` (every variable given) — also when it
    starts non-deterministically (``x :: S ; y := f(x)``). Raises :class:`UnsupportedError`
    when tracecheck cannot tell, :class:`EvaluationError` when a variable is missing."""
    missing = [v for v in machine.variables if v not in state]
    if missing:
        raise EvaluationError(f"the initial state has no value for {', '.join(missing)}")
    return _possible(machine, None, {}, state)


def _plan(machine, op, body, strict: bool = False) -> Plan:
    return machine.cached(_PLANS, (op, strict), lambda: _Planner(
        SubstCompiler(machine.compiler()), strict).plan(body or ast.Skip()))


class _Planner:
    """Compiles a substitution into ``plan(env, fixed) -> [updates, …]``: its possible
    outcomes, a variable the predicate fixes taking that value where the substitution
    cannot decide it (``x :: S``, ``ANY``). ``strict``: such a value must be one the part
    can choose (else that run has no outcome) — to check a state rather than find one."""

    def __init__(self, subst: SubstCompiler, strict: bool = False) -> None:
        self.subst = subst
        self.comp = subst.comp
        self.strict = strict

    def plan(self, s: ast.Subst) -> Plan:
        method = getattr(self, "p_" + type(s).__name__, None)
        writes = written(s)
        if method is None:
            return self._from_fixed(s, writes)
        inner = method(s)
        if self.strict:
            return inner

        def plan(env: Env, fixed: Mapping[str, Any]) -> list:
            if writes and writes <= fixed.keys():
                return [{v: fixed[v] for v in writes}]
            return inner(env, fixed)
        return plan

    def _from_fixed(self, s: ast.Subst, writes: frozenset[str]) -> Plan:
        ids = ", ".join(getattr(s, "ids", ()))
        name = {"BecomesIn": f"`{ids} :: …`", "BecomesSuchThat": f"`{ids} : (…)`",
                "Any": f"`ANY {ids}`"}.get(type(s).__name__, type(s).__name__)
        check = self.subst.compile(s) if self.strict else None

        def plan(env: Env, fixed: Mapping[str, Any]) -> list:
            missing = sorted(writes - fixed.keys())
            if missing:
                raise UndeterminedError(
                    f"{', '.join(missing)} fixed neither by the predicate nor by the "
                    f"operation (its {name} chooses it)",
                    hint="the predicate must give every such variable (`v = value`)")
            chosen = {v: fixed[v] for v in writes}
            if check is not None and not check(fresh(env), dict(chosen)):
                return []
            return [chosen]
        return plan

    def p_Skip(self, s: ast.Skip) -> Plan:
        return lambda env, fixed: [{}]

    def p_Assign(self, s: ast.Assign) -> Plan:
        run = self.subst.execute(s)
        targets = written(s)
        strict = self.strict

        def assign(env: Env, fixed: Mapping[str, Any]) -> list:
            try:
                return [run(env)]
            except EvaluationError as exc:  # ill-defined here (a blocked action's effect)
                if strict:
                    return []
                if targets <= fixed.keys():
                    return [{v: fixed[v] for v in targets}]
                raise UndeterminedError(f"cannot compute {', '.join(sorted(targets))}: "
                                        f"{exc.message}") from None
        return assign

    def p_Parallel(self, s: ast.Parallel) -> Plan:
        parts = [self.plan(i) for i in s.items]

        def parallel(env: Env, fixed: Mapping[str, Any]) -> list:
            out = [{}]
            for p in parts:
                out = _capped(dict(a, **b) for a in out for b in p(env, fixed))
            return out
        return parallel

    def p_Sequence(self, s: ast.Sequence) -> Plan:
        # a fixed value is the one *after* the whole sequence: an earlier part may take it
        # only when no later part writes that variable again
        later = [frozenset().union(*(written(i) for i in s.items[k + 1:]))
                 for k in range(len(s.items))]
        parts = [(self.plan(i), after) for i, after in zip(s.items, later)]

        def sequence(env: Env, fixed: Mapping[str, Any]) -> list:
            runs = [({}, env)]
            for p, after in parts:
                allowed = {k: v for k, v in fixed.items() if k not in after}
                step = []
                for done, here in runs:
                    for upd in p(here, allowed):
                        local = fresh(here)
                        local.update(upd)
                        step.append((dict(done, **upd), local))
                runs = _capped(step)
            return [done for done, _ in runs]
        return sequence

    def p_Pre(self, s: ast.Pre) -> Plan:
        return self.plan(s.body)  # the guard is checked on its own (enabledness)

    def p_Assert(self, s: ast.Assert) -> Plan:
        return self.plan(s.body)

    def _branches(self, s, first_only: bool) -> Plan:
        branches = [(self.comp.compile(c), self.plan(b)) for c, b in s.branches]
        other = self.plan(s.else_) if s.else_ is not None else (
            (lambda env, fixed: [{}]) if first_only else None)

        def branching(env: Env, fixed: Mapping[str, Any]) -> list:
            out, taken = [], False
            for cond, body in branches:
                if cond(env):
                    taken = True
                    out += body(env, fixed)
                    if first_only:
                        return out
            if not taken and other is not None:
                return other(env, fixed)
            if not taken and not self.strict:
                # a SELECT whose guards are all false (an action the machine blocks): its
                # effect as if they held, as for PRE — the step is recorded and flagged
                for _, body in branches:
                    out += body(env, fixed)
            return out
        return branching

    def p_Select(self, s: ast.Select) -> Plan:
        return self._branches(s, first_only=False)

    def p_IfSubst(self, s: ast.IfSubst) -> Plan:
        return self._branches(s, first_only=True)

    def p_Choice(self, s: ast.Choice) -> Plan:
        parts = [self.plan(i) for i in s.items]
        return lambda env, fixed: _capped(u for p in parts for u in p(env, fixed))

    def p_VarSubst(self, s: ast.Subst) -> Plan:
        every = self.subst.outcomes(s)
        return lambda env, fixed: _capped(every(env))

    p_While = p_VarSubst

    def p_LetSubst(self, s: ast.LetSubst) -> Plan:
        with self.comp.binding(s.ids):
            assign = self.comp.let_values(s, s.ids, s.pred)
            body = self.plan(s.body)

        def let(env: Env, fixed: Mapping[str, Any]) -> list:
            local = fresh(env)
            assign(local)
            return body(local, fixed)
        return let

    def p_Any(self, s: ast.Any) -> Plan:
        try:
            with self.comp.binding(s.ids):
                bind = self.comp.bindings(s, s.ids, s.pred)
                body = self.plan(s.body)
        except TracecheckError:  # values it cannot enumerate: only the predicate can say
            return self._from_fixed(s, written(s))

        def any_(env: Env, fixed: Mapping[str, Any]) -> list:
            out = []
            local = fresh(env)
            for n, problem in enumerate(bind(local)):
                if problem is not None:
                    raise problem
                if n >= MAX_CANDIDATES:
                    raise UndeterminedError(
                        f"ANY has more than {MAX_CANDIDATES} values to try here; the "
                        f"predicate must fix what it writes ({', '.join(sorted(written(s)))})")
                out += body(fresh(local), fixed)
            return _capped(out)
        return any_


def _capped(items) -> list:
    out = list(islice(items, MAX_CANDIDATES + 1))
    if len(out) > MAX_CANDIDATES:
        raise UndeterminedError(f"more than {MAX_CANDIDATES} possible outcomes of the "
                                "operation; the predicate must fix the variables it chooses")
    return out
