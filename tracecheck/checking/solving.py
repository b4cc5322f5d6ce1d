"""A predicate's free identifiers solved for, as ProB's ``:solve`` does (``tracecheck eval
'x*x = 100 & x < 0'``): a solution, or a proof that there is none, or ``unknown`` with the
reason — never a guess.

* Where the conjuncts bound every identifier to a finite set (``x : 1..9``, ``{x, y} <: S``,
  ``x < 5 & x >= 0``, BOOL, the elements of a set) and there are at most
  :data:`SMALL_SPACE` candidates, tracecheck's own evaluator walks them (each conjunct
  checked as soon as its identifiers have values): exact, and complete.
* Otherwise identifiers that are integers, reals or booleans become z3 variables (the
  translation of :mod:`.smt`, with its well-definedness conditions: a solution is one where
  the predicate is defined and true). ``unsat`` is ``FALSE``; ``sat`` gives a model whose
  values (reals rounded to floats) the evaluator checks again before they are a solution;
  ``unknown`` (time limit, a construct z3 cannot take) is ``unknown`` with the reason.
* A finite problem the solver cannot take is walked by the evaluator within the time limit.

z3 is imported only when the solver is asked.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from itertools import combinations, product
from typing import Any, Callable, Optional

from ..b import ast
from ..b.bindings import conjuncts
from ..b.btypes import BOOL, INTEGER, REAL, Base, Pow, Prod, Type, show
from ..b.evaluation import Compiler
from ..b.memo import fresh
from ..b.typecheck import UNSUPPORTED_KEYWORDS
from ..b.values import (Interval, SymbolicSet, cardinality, format_value, make_set, members,
                        sort_key)
from ..errors import TracecheckError, UnsupportedError, WellDefinednessError
from .candidates import Clock, assignments, computed
from .solving_z3 import Z3Solver

__all__ = ["Answer", "solve", "free_identifiers", "SMALL_SPACE", "MAX_SUBSET_BASE"]

#: Candidate assignments the evaluator walks before the solver is asked instead.
SMALL_SPACE = 100_000
#: ``x <: S`` enumerates the subsets of S up to this many elements.
MAX_SUBSET_BASE = 12
#: Candidates of the identifiers the solver does not choose, each solved for the rest.
MAX_PICKED = 1_000


@dataclass
class Answer:
    """``status``: TRUE (``solutions`` holds at least one), FALSE (none exists) or unknown
    (``reason`` says why). Asked for all of them: ``complete`` when every solution is
    listed, ``more`` True where there are more than the limit (None: not known)."""

    status: str
    names: tuple[str, ...]
    solutions: list[dict[str, Any]] = field(default_factory=list)
    complete: bool = True
    more: Optional[bool] = None
    reason: str = ""
    method: str = ""
    note: str = ""

    def shown(self, solution: dict[str, Any]) -> dict[str, str]:
        return {n: format_value(solution[n]) for n in self.names}


def free_identifiers(node: ast.Node, known) -> tuple[str, ...]:
    """The names ``node`` uses that nothing declares (not in ``known``, not built-in, not
    bound inside it), in the order they first appear."""
    free = {n for n in ast.free_names(node) if n not in known and n not in ast.BUILTIN_SETS
            and n not in UNSUPPORTED_KEYWORDS and not n.endswith(("'", "$0"))}
    out: list[str] = []
    stack = [node]
    while stack:
        n = stack.pop()
        if isinstance(n, ast.Name) and n.id in free and n.id not in out:
            out.append(n.id)
        stack.extend(reversed(ast.children(n)))
    return tuple(out)


def solve(node: ast.Node, types: dict[str, Type], env: dict, *, sets: Optional[dict] = None,
          source: Optional[str] = None, file: Optional[str] = None, timeout_s: float = 10.0,
          all_solutions: bool = False, limit: int = 100,
          inner: Optional[Callable] = None, everywhere: bool = False) -> Answer:
    """Solve the predicate ``node`` for the identifiers ``types`` (name: resolved type; in
    the order they are printed), everything else taking its value from ``env``; the first
    solution, or with ``all_solutions`` up to ``limit`` of them. ``timeout_s`` bounds the
    whole search. ``inner``: how comprehensions and quantifiers inside it take their
    variables (:func:`tracecheck.checking.bound_solver.bound_solver`, given by the caller).
    With ``everywhere``, a solution is given only where the predicate is also known to
    have a value for every value of the identifiers (``note`` says where it has none).
    Raises :class:`Disagreement` where the evaluator rejects an integer solution of the
    solver (a bug in one of the two)."""
    problem = _Problem(node, types, env, sets or {}, source, file,
                       time.monotonic() + timeout_s, timeout_s,
                       limit if all_solutions else 1, all_solutions, inner, everywhere)
    domains = problem.domains()
    derived = problem.derived(domains)
    walked = [d for n, d in domains.items() if n not in derived]
    finite = all(d is not None for d in walked)
    size = math.prod(len(d) for d in walked) if finite else math.inf
    if size <= SMALL_SPACE:
        return _walked_all(problem, domains, derived)
    fixed = {n: d[0] for n, d in domains.items() if d is not None and len(d) == 1}
    if fixed and len(fixed) < len(types):  # f = {…} & x*x = 100: f in the scope, x solved
        rest = solve(node, {n: t for n, t in types.items() if n not in fixed},
                     {**env, **fixed}, sets=sets, source=source, file=file,
                     timeout_s=max(0.0, problem.deadline - time.monotonic()),
                     all_solutions=all_solutions, limit=limit, inner=inner,
                     everywhere=everywhere)
        rest.names = problem.names
        rest.solutions = [{**fixed, **s} for s in rest.solutions]
        return rest
    why = problem.not_numbers(domains)
    picked = [n for n in problem.names if types[n] not in (INTEGER, REAL, BOOL)]
    if why is not None and all(domains[n] is not None for n in picked) and \
            math.prod(len(domains[n]) for n in picked) <= MAX_PICKED:
        return _picked(problem, picked, domains, inner)
    try:  # sets and functions of elements or over integers too (vec : 1..10 --> 0..99)
        solver = Z3Solver(problem)
    except UnsupportedError as exc:
        if why is None or "which the solver cannot choose" not in exc.message:
            why = f"{exc.location}: {exc.message}"
    else:
        return _defined(solver.solve(), problem)
    if finite:
        return _walked_all(problem, domains, derived)
    return problem.answer("unknown", reason=why)


def _walked_all(problem: "_Problem", domains: dict, derived: dict) -> Answer:
    """The walk's answer; asked ``everywhere``, every candidate walked (where the predicate
    has no value is then seen), or unknown where the walk did not finish."""
    if not problem.everywhere:
        return problem.walk(domains, derived)
    problem.all_solutions, problem.limit = True, SMALL_SPACE
    got = problem.walk(domains, derived)
    if got.status == "TRUE" and not got.complete:
        return problem.answer("unknown", method=got.method,
                              reason=f"a solution, but not every value walked to learn "
                                     f"whether the predicate has a value everywhere "
                                     f"({got.reason or f'more than {SMALL_SPACE:,} solutions'})")
    return got


def _picked(problem: "_Problem", picked: list, domains: dict,
            inner: Optional[Callable]) -> Answer:
    """Each candidate of the identifiers the solver does not choose (``t1 : dom(f)``, an
    element of a deferred set), the numbers solved for at each: the answers merged. No
    solution anywhere is FALSE only where every candidate's answer is FALSE."""
    names = [n for n in problem.names if n not in picked]
    solutions: list[dict] = []
    unknown, undefined, complete, note = None, None, True, ""
    for values in product(*(domains[n] for n in picked)):
        fixed = dict(zip(picked, values))
        try:
            answer = solve(problem.node, {n: problem.types[n] for n in names},
                           {**problem.env, **fixed}, sets=problem.sets,
                           source=problem.source, file=problem.file,
                           timeout_s=max(0.0, problem.deadline - time.monotonic()),
                           all_solutions=problem.all_solutions, limit=problem.limit,
                           inner=inner, everywhere=problem.everywhere)
        except WellDefinednessError as exc:
            undefined = undefined or exc
            continue
        if answer.status == "unknown":
            unknown = unknown or answer
            complete = False
        note = note or answer.note
        complete = complete and answer.complete
        solutions += [{**fixed, **s} for s in answer.solutions]
        if len(solutions) >= problem.limit and not problem.everywhere:
            complete = False  # the candidates after these not asked
            break
    if problem.everywhere and unknown is not None:  # where it has a value: not known
        return problem.answer("unknown", reason=unknown.reason, method=unknown.method)
    if undefined is not None:
        note = note or undefined.message
    more: Optional[bool] = True if len(solutions) > problem.limit else None
    solutions = solutions[:problem.limit]
    if solutions:
        return problem.answer("TRUE", solutions=solutions, method="enumeration and solver",
                              complete=complete and not more, more=False if complete else more,
                              note=note)
    if unknown is not None:
        return problem.answer("unknown", reason=unknown.reason, method=unknown.method)
    if undefined is not None:
        raise undefined
    return problem.answer("FALSE", method="enumeration and solver")


def _defined(answer: Answer, problem: "_Problem") -> Answer:
    """No solution, and a point without value: not FALSE but the error (as the walk)."""
    if answer.status == "FALSE" and answer.note:
        at = problem.undefined_at
        raise WellDefinednessError(answer.note, file=problem.file, source=problem.source,
                                   line=getattr(at, "line", None),
                                   column=getattr(at, "column", None))
    return answer


@dataclass
class _Problem:
    node: ast.Node
    types: dict
    env: dict
    sets: dict
    source: Optional[str]
    file: Optional[str]
    deadline: float
    timeout_s: float
    limit: int
    all_solutions: bool
    inner: Optional[Callable] = None
    everywhere: bool = False

    def __post_init__(self) -> None:
        self.undefined_at: Optional[TracecheckError] = None  # where it has no value
        self._closed: dict = {}  # closed's values, by formula and the identifiers it reads
        self.names = tuple(self.types)
        self.compiler = Compiler(source=self.source, file=self.file)
        if self.inner is not None:  # a comprehension inside ({x | x*x = n}): its variables
            self.compiler.solver = self.inner(self.types, self.sets, source=self.source,
                                              file=self.file, deadline=self.deadline)
        with self.compiler.binding(self.names):  # nothing with them in it is remembered
            self.whole = self.compiler.compile(self.node)

    def answer(self, status: str, **fields) -> Answer:
        """The answer, its solutions in order (elements as their sets list them)."""
        rank = {e: k for elems in self.sets.values() for k, e in enumerate(elems)}
        fields.get("solutions", []).sort(key=lambda s: [
            (0, rank[s[n]]) if s[n] in rank else (1, sort_key(s[n])) for n in self.names])
        return Answer(status, self.names, **fields)

    def holds(self, solution: dict) -> bool:
        """The evaluator's verdict on ``solution`` (False where the predicate has no value;
        where the evaluator cannot say — a refusal — its error is raised)."""
        try:
            return self.whole({**fresh(self.env), **solution}) is True
        except WellDefinednessError:
            return False

    def closed(self, expr: ast.Node, known: Optional[dict] = None) -> Any:
        """The value of ``expr`` if it reads none of the identifiers but those ``known``
        (the one value each can take), else None."""
        known = known or {}
        reads = ast.free_names(expr) & set(self.names)
        if reads - set(known):
            return None
        # an identifier known has its one value for the whole problem: computed once
        key = (id(expr), tuple(sorted(reads)))
        if key not in self._closed:
            try:
                with self.compiler.binding(self.names):
                    self._closed[key] = self.compiler.compile(expr)({**fresh(self.env),
                                                                     **known})
            except TracecheckError:
                self._closed[key] = None
        return self._closed[key]

    # -- finite domains
    def domains(self) -> dict[str, Optional[list]]:
        """Each identifier's candidate values: every solution takes one of them (None:
        nothing bounds it to a finite set). An identifier with one candidate (``s = {1, 2}``)
        is known to the conjuncts after it, whatever its type (``c = s * s``), until
        nothing more is learnt."""
        known: dict[str, Any] = {}
        while True:
            found: dict[str, dict] = {n: {"in": None, "lo": None, "hi": None}
                                      for n in self.names}
            for conj in conjuncts(self.node):
                self._bound_by(conj, found, known)
            domains = {n: self._domain(n, found[n]) for n in self.names}
            new = {n: d[0] for n, d in domains.items()
                   if n not in known and d is not None and len(d) == 1}
            if not new:
                return domains
            known.update(new)

    def _bound_by(self, conj: ast.Node, found: dict, known: Optional[dict] = None) -> None:
        if not isinstance(conj, ast.Rel):
            return
        left, right, op = conj.left, conj.right, conj.op
        flip = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "=": "="}
        if not (isinstance(left, ast.Name) and left.id in found) and op in flip and \
                isinstance(right, ast.Name) and right.id in found:
            left, right, op = right, left, flip[op]
        if op == "<:" and isinstance(left, ast.SetExt) and all(
                isinstance(i, ast.Name) and i.id in found for i in left.items):
            for item in left.items:  # {x, y} <: S: each is in S
                self._bound_by(ast.Rel(":", item, right), found, known)
            return
        if not (isinstance(left, ast.Name) and left.id in found):
            return
        bound = found[left.id]
        if op == "<:":
            value = self.closed(right, known)
            if _small_set(value, MAX_SUBSET_BASE):
                items = sorted(members(value), key=sort_key)
                subsets = [frozenset(c) for k in range(len(items) + 1)
                           for c in combinations(items, k)]
                bound["in"] = _meet(bound["in"], subsets)
            return
        if op == ":" and isinstance(right, ast.Name) and right.id in ("NATURAL", "NATURAL1"):
            _raise(bound, "lo", 0 if right.id == "NATURAL" else 1)
            return
        value = self.closed(right, known)
        if value is None:
            return
        if op == "=":
            bound["in"] = _meet(bound["in"], [value])
        elif op == ":" and isinstance(value, Interval):
            _raise(bound, "lo", value.lo)
            _lower(bound, "hi", value.hi)
        elif op == ":" and _small_set(value, SMALL_SPACE):
            bound["in"] = _meet(bound["in"], sorted(members(value), key=sort_key))
        elif op in ("<", "<=", ">", ">=") and type(value) is int:
            if op in ("<", "<="):
                _lower(bound, "hi", value - (op == "<"))
            else:
                _raise(bound, "lo", value + (op == ">"))

    def _domain(self, name: str, bound: dict) -> Optional[list]:
        t = self.types[name]
        lo, hi, listed = bound["lo"], bound["hi"], bound["in"]
        if listed is not None:
            return [v for v in listed if (lo is None or not _is_int(v) or v >= lo)
                    and (hi is None or not _is_int(v) or v <= hi)]
        if t == INTEGER and lo is not None and hi is not None:
            return range(lo, hi + 1) if hi >= lo else []  # type: ignore[return-value]
        return self.type_values(t)

    def type_values(self, t) -> Optional[list]:
        """Every value of a finite type (BOOL, a machine's set, sets and pairs of them: ``A
        \\/ B = D & A : POW(BOOL)`` walks B and D too), None where it is infinite or large."""
        if t == BOOL:
            return [False, True]
        if isinstance(t, Base):
            return list(self.sets[t.name]) if t.name in self.sets else None
        if isinstance(t, Prod):
            a, b = self.type_values(t.left), self.type_values(t.right)
            if a is None or b is None or len(a) * len(b) > SMALL_SPACE:
                return None
            return [(x, y) for x in a for y in b]
        if isinstance(t, Pow):
            items = self.type_values(t.elem)
            if items is None or len(items) > MAX_SUBSET_BASE:
                return None
            return [make_set(c) for k in range(len(items) + 1)
                    for c in combinations(items, k)]
        return None

    def equalities(self) -> list[tuple[str, ast.Node]]:
        """(identifier, E) for each conjunct ``identifier = E`` (either way round) where E
        does not read the identifier."""
        found = []
        for conj in conjuncts(self.node):
            if isinstance(conj, ast.Rel) and conj.op == "=":
                for left, right in ((conj.left, conj.right), (conj.right, conj.left)):
                    if isinstance(left, ast.Name) and left.id in self.names and \
                            left.id not in ast.free_names(right):
                        found.append((left.id, right))
        return found

    def derived(self, domains: dict) -> dict[str, ast.Node]:
        """Identifiers nothing bounds that an equality computes from the others
        (``y = COPY(x)`` with x walked): computed at each candidate, not walked. In the
        order they can be computed."""
        known = {n for n, d in domains.items() if d is not None}
        out: dict[str, ast.Node] = {}
        equalities = self.equalities()
        changed = True
        while changed:
            changed = False
            for name, expr in equalities:
                if name not in known and name not in out and \
                        ast.free_names(expr) & set(self.names) <= known | set(out):
                    out[name] = expr
                    changed = True
        return out

    def not_numbers(self, domains: dict) -> Optional[str]:
        """Why the solver cannot take the problem (an identifier it cannot choose that
        nothing bounds to a finite set), or None."""
        for n in self.names:
            if self.types[n] not in (INTEGER, REAL, BOOL):
                if domains[n] is None and any(m == n for m, _ in self.equalities()):
                    return (f"{n} is of type {show(self.types[n])}, which the solver does not "
                            f"choose, and an equality computes it from identifiers that no "
                            f"conjunct bounds to a finite set (bound them, e.g. x : 1..100)")
                if domains[n] is None:
                    return (f"{n} is of type {show(self.types[n])}: the solver chooses "
                            f"numbers and booleans, and no conjunct bounds {n} to a finite "
                            f"set (write {n} : S or {n} <: S)")
                return (f"{n} is of type {show(self.types[n])}, which the solver does not "
                        "choose")
        return None

    # -- walking the candidates
    def walk(self, domains: dict, derived: Optional[dict] = None) -> Answer:
        derived = derived or {}
        order = sorted((n for n in self.names if n not in derived),
                       key=lambda n: len(domains[n]))
        size = math.prod(len(domains[n]) for n in order)
        order += list(derived)  # computed once what they read has values
        checks: list[list] = [[] for _ in order]
        domains = dict(domains)
        undefined: list = []  # (the values so far, the error) where a computed one has none
        with self.compiler.binding(self.names):
            for name, expr in derived.items():
                domains[name] = computed(self.compiler.compile(expr), order, undefined)
            for conj in conjuncts(self.node):
                used = ast.free_names(conj) & set(self.names)
                depth = max((order.index(n) for n in used), default=0)
                checks[depth].append(self.compiler.compile(conj))
        env, clock = fresh(self.env), Clock(self.deadline)
        try:
            return self._walked(order, domains, checks, env, clock, size, undefined)
        except WellDefinednessError:
            raise
        except TracecheckError as exc:  # a refusal computing an identifier: no answer
            return self.answer("unknown", method="enumeration",
                               reason=f"tracecheck's evaluator cannot decide the predicate "
                                      f"for its candidates: {exc.message}")

    def _walked(self, order, domains, checks, env, clock, size, undefined) -> Answer:
        solutions: list[dict] = []
        more, problem = False, None
        for leaf in assignments(order, domains, checks, env, clock):
            try:
                if self.whole(leaf) is not True:
                    continue
            except WellDefinednessError as exc:
                problem = problem or (dict((n, leaf[n]) for n in self.names), exc)
                continue
            if len(solutions) == self.limit:
                more = True
                break
            solutions.append({n: leaf[n] for n in self.names})
            if not self.all_solutions:
                break
        problem = problem or (undefined[0] if undefined else None)
        note = ""
        if problem is not None:
            where = " & ".join(f"{n} = {format_value(v)}" for n, v in problem[0].items())
            note = f"the predicate has no value where {where}: {problem[1].message}"
        stopped = clock.stopped
        if stopped and not solutions:
            return self.answer("unknown", method="enumeration", note=note,
                               reason=f"time limit ({self.timeout_s:g} s) after "
                                      f"{clock.tried:,} of {size:,} candidate values")
        if not solutions and problem is not None and not stopped:
            # no solution, and a candidate where the predicate has no value: not FALSE but
            # not well-defined, as ProB's enumeration finds it
            raise WellDefinednessError(note, file=problem[1].file, source=problem[1].source,
                                       line=problem[1].line, column=problem[1].column)
        status = "TRUE" if solutions else "FALSE"
        return self.answer(status, solutions=solutions, method="enumeration", note=note,
                           complete=not (more or stopped), more=True if more else
                           (None if stopped else False),
                           reason=f"time limit ({self.timeout_s:g} s)" if stopped else "")


def _is_int(v: Any) -> bool:
    return type(v) is int


def _small_set(value: Any, limit: int) -> bool:
    if isinstance(value, frozenset):
        return len(value) <= limit
    if isinstance(value, SymbolicSet) and value.finiteness() is True:
        try:
            return cardinality(value) <= limit
        except TracecheckError:
            return False
    return False


def _meet(listed: Optional[list], values: list) -> list:
    if listed is None:
        return list(values)
    keep = set(values)
    return [v for v in listed if v in keep]


def _raise(bound: dict, key: str, value: int) -> None:
    bound[key] = value if bound[key] is None else max(bound[key], value)


def _lower(bound: dict, key: str, value: int) -> None:
    bound[key] = value if bound[key] is None else min(bound[key], value)
