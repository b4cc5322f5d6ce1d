"""Machines: load a ``.mch`` file, set up its sets and constants, ask it questions.

>>> m = load_machine_text('''MACHINE Counter
... VARIABLES n
... INVARIANT n : NATURAL
... INITIALISATION n := 0
... OPERATIONS inc = PRE n < 3 THEN n := n + 1 END END''')
>>> m.enabled({"n": 3})
set()
>>> m.check_after("inc", {"n": 1}, {"n": 2})
True
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, TypeVar

from ..errors import (BScopeError, EvaluationError, InputError, TracecheckError,
                      UnsupportedError, WellDefinednessError, did_you_mean)
from ..inputs import read_text
from . import ast
from .bindings import conjuncts
from .cache import Cache
from .constants import setup_constants
from .evaluation import Compiler
from .linear import real_parameters, real_typed
from .machine_batch import BatchQuestions
from ..limits import deep_recursion
from .parser import MachineSource, parse_formula, parse_machine_source
from .conversion import StateTypes, convert_state, unknown_elements
from .state import native_state
from .scope import PRED, check_kind, check_subst, expand, render
from .substitution import SubstCompiler, before_after, guard_of, strip_guards, written
from .values import Elem

K = TypeVar("K")
V = TypeVar("V")

__all__ = ["Machine", "Operation", "load_machine", "load_machine_text"]

@dataclass(frozen=True)
class Operation:
    """One operation: its guard (a predicate, None when always enabled) and body."""

    name: str
    params: tuple[str, ...]
    outputs: tuple[str, ...]
    guard: Optional[ast.Node]
    body: ast.Subst
    description: Optional[str] = None
    guard_source: Optional[str] = None  # the guard as written, definitions not expanded
    pos: Optional[ast.Pos] = field(default=None, compare=False)  # where it is declared

    @property
    def enabling_guard(self) -> Optional[ast.Node]:
        """When the operation is enabled, as a predicate of the state alone: the guard, for
        some values of the parameters (``#params.(guard)``); None when always enabled."""
        if self.params and self.guard is not None:
            return ast.Quant("#", self.params, self.guard, pos=self.guard.pos)
        return self.guard


@dataclass
class Machine(BatchQuestions):
    """A loaded machine. Build one with :func:`load_machine`."""

    name: str
    file: Optional[str]
    source: str
    sha256: str
    sets: dict[str, tuple[Elem, ...]]
    enumerated: frozenset[str]
    constants: dict[str, Any]
    variables: tuple[str, ...]
    invariant_node: Optional[ast.Node]
    assertion_nodes: tuple[ast.Node, ...]
    operations: dict[str, Operation]
    descriptions: dict[str, str]
    definitions: dict = field(default_factory=dict)
    properties_node: Optional[ast.Node] = None
    initialisation: Optional[ast.Subst] = None
    constants_declared: tuple[str, ...] = ()
    types: dict[str, str] = field(default_factory=dict)
    type_objects: dict = field(default_factory=dict, repr=False)
    #: constants the PROPERTIES do not give one value, and why (see :meth:`settle_constants`)
    unset_constants: dict[str, str] = field(default_factory=dict)
    _compiled: dict = field(default_factory=dict, repr=False)

    # -- environments
    @property
    def base_env(self) -> dict[str, Any]:
        """Constants, set names and enumerated elements: what every formula can see."""
        env = self._compiled.get("base_env")
        if env is None:
            env = {name: frozenset(elems) for name, elems in self.sets.items()}
            for name in self.enumerated:
                env.update({str(e): e for e in self.sets[name]})
            env.update(self.constants)
            self._compiled["base_env"] = env
        return env

    def env(self, state: Mapping[str, Any]) -> dict[str, Any]:
        """What a formula sees in ``state``: the constants and sets, and the state's values
        — numpy scalars and arrays converted exactly at this boundary (see
        :func:`~tracecheck.b.state.native_state`), so a Gymnasium observation's float32
        can be given as it is."""
        env = dict(self.base_env)
        env.update(self.native(state))
        return env

    def native(self, state: Mapping[str, Any], *, where: str = "the state"
               ) -> Mapping[str, Any]:
        """``state`` from Python code made B values by this machine's types
        (:func:`.conversion.convert_state`: numpy values exactly, a ``str`` naming an
        element, a ``dict`` for a function, arrays by the invariant's index sets); the same
        mapping when nothing needed converting."""
        return convert_state(state, self.state_types(), where=where)

    def state_types(self) -> StateTypes:
        """What converting this machine's states needs (:class:`.conversion.StateTypes`)."""
        types = self._compiled.get("state_types")
        if types is None:
            types = self._compiled["state_types"] = StateTypes.of(self)
        return types

    def element_sets(self) -> dict[Elem, str]:
        """Which set each element belongs to."""
        return {e: name for name, elems in self.sets.items() for e in elems}

    def check_state(self, state: Mapping[str, Any], *, where: str = "the state",
                    python: bool = False) -> None:
        """Raise :class:`InputError` unless every value in ``state`` fits its variable's type.

        Names the variable, the type it needs and the type of the value it got; values of
        names the machine does not declare are an error too. ``python``: the state comes
        from Python code (an adapter's ``state()``), not a file of B literals — the hints
        say so.
        """
        from .typecheck import describe_value_type, type_of_value, unify_quiet

        owners = self.element_sets()
        given = (self.native(state, where=where) if python else  # B literals: no int for
                 native_state(state, self.type_objects, where=where))  # a REAL, no str for an element
        for name, value in given.items():
            if name not in self.variables:
                if name in self.constants or name in self.sets:
                    continue
                near = did_you_mean(name, self.variables)
                raise InputError(f"{where} gives a value for {name}, which the machine "
                                 f"{self.name} does not declare; its variables are "
                                 f"{', '.join(self.variables)}",
                                 hint=(f"{near + ' ' if near else ''}name the variables "
                                       "as the machine does (the adapter's variables and "
                                       "the keys state() returns)") if python else near or None)
            wanted = self.type_objects.get(name)
            if wanted is None:
                continue
            unknown = unknown_elements(value, owners)
            if unknown:
                raise InputError(f"{where}: {name} mentions {', '.join(sorted(unknown))}, "
                                 f"which no set of {self.name} contains")
            if not unify_quiet(wanted, type_of_value(value, owners)):
                got = describe_value_type(value, owners)
                raise InputError(f"{where}: {name} must be of type {self.types[name]}, but "
                                 f"its value is of type {got}",
                                 hint="give B values by the machine's types: a str naming an "
                                      "element, a dict for a function (docs/environments.md, "
                                      "\"States\")" if python else
                                 self._literal_hint(name, got))

    def _literal_hint(self, name: str, got: str) -> str:
        """How a state file writes a value of ``name``'s type, where it gave one of ``got``."""
        wanted = self.types[name]
        if (got, wanted) == ("INTEGER", "REAL"):
            return "reals are written with a decimal point: 1.0, not 1"
        if (got, wanted) == ("REAL", "INTEGER"):
            return "integers are written without a decimal point: 1, not 1.0"
        if wanted in self.sets:
            some = next(iter(self.sets[wanted]), None)
            return (f"an element is written bare, as B writes it: \"{name}\": \"{some}\""
                    if some is not None else f"{wanted} has no elements here")
        return ("a value is written as B writes it: TRUE or FALSE, 1 (an INTEGER), 1.0 (a "
                "REAL), an element bare, a string in quotes (\"\\\"text\\\"\"), a set in "
                "braces (\"{1, 2}\")")

    def compiler(self) -> Compiler:
        comp = Compiler(source=self.source, file=self.file)
        comp.unset = self.unset_constants
        return comp

    def fix_constants(self, values: Mapping[str, Any]) -> None:
        """Give constants their values (set up after loading: :meth:`settle_constants`)."""
        self.constants.update(values)
        self._compiled.pop("base_env", None)

    def settle_constants(self, names: list[str]) -> None:
        """Give the constants ``names``, which no equality of the PROPERTIES fixes, their
        values: here none (each is recorded in :attr:`unset_constants` with the reason); a
        shield's machine (:class:`tracecheck.checking.shield.ShieldMachine`) asks the
        solver, as ProB's SETUP_CONSTANTS does."""
        self.unset_constants = {n: "no equality of the PROPERTIES fixes it (c = value), and "
                                   "this machine is not set up with the solver" for n in names}

    # -- formulas
    def parse(self, text: str, *, kind: str = PRED) -> ast.Node:
        """Parse ``text`` in this machine's scope (its definitions expanded)."""
        with deep_recursion():
            node = expand(parse_formula(text, dotted=frozenset(
                n for n in (*self.variables, *self.constants) if "." in n)), self.definitions)
            check_kind(node, kind, source=text, context="the formula")
        return node

    def check_formula(self, text: str, *, file: str, kind: str = PRED,
                      extra: Optional[Mapping[str, Any]] = None,
                      hint: Optional[str] = None) -> ast.Node:
        """``text`` parsed, its definitions expanded and type-checked in this machine's
        scope — the one path ``eval --model`` takes too (:func:`.typecheck.check_formula`).
        For formulas a user gives (``prove --assume``); ``file`` names where they came from
        (``--assume``, ``obs.toml: implies[2].predicate``). ``extra``: more names in scope
        and their types (an operation's parameters); ``hint`` for an unknown name."""
        from .typecheck import check_formula

        names = ", ".join([*self.variables, *self.constants, *(extra or {})]) or "none"
        node, _ = check_formula(text, {**self.type_objects, **(extra or {})}, file=file,
                                kind=kind, definitions=self.definitions,
                                unknown_hint=hint or f"the variables and constants of "
                                                     f"{self.name} are {names}")
        return node

    def compile(self, node: ast.Node, *, source: Optional[str] = None) -> Callable[[dict], Any]:
        comp = Compiler(source=source or self.source, file=None if source else self.file)
        comp.unset = self.unset_constants
        return comp.compile(node)

    def evaluate(self, text_or_node, state: Mapping[str, Any]) -> Any:
        """Evaluate a formula (text or node) in ``state``."""
        if isinstance(text_or_node, str):
            with deep_recursion():
                node = expand(parse_formula(text_or_node), self.definitions)
            return self.compile(node, source=text_or_node)(self.env(state))
        return self.compile(text_or_node)(self.env(state))

    # -- questions
    def _guard_fns(self) -> dict[str, Callable[[dict], bool]]:
        fns = self._compiled.get("guards")
        if fns is None:
            comp = self.compiler()
            fns = {}
            for op in self.operations.values():
                guard = op.enabling_guard
                if real_parameters(op):  # some REAL values allowed: decided by linear.py
                    fns[op.name] = self._real_guard(op.name)
                    continue
                fns[op.name] = comp.compile(guard) if guard is not None else (lambda env: True)
                if real_typed(op):  # REAL parameters beside others: enumerated where it can
                    fns[op.name] = self.mixed(op, fns[op.name])
            self._compiled["guards"] = fns
        return fns

    def mixed(self, op: Operation, fn: Callable[[Any], Any]) -> Callable[[Any], Any]:
        """``fn`` (evaluating the guard of ``op``, which types some of its parameters REAL
        but not all) raising, where it cannot enumerate a parameter, why (see
        :func:`mixed_parameters`) instead of naming that parameter alone."""
        reals = real_typed(op)

        def guard(*args: Any) -> Any:
            try:
                return fn(*args)
            except EvaluationError as exc:  # (a batch's says the state first)
                if not any(f"cannot enumerate {p} in " in exc.message for p in reals):
                    raise  # not a REAL parameter: what it says is the problem
                raise mixed_parameters(op, self.file, self.source) from exc
        return guard

    def _real_guard(self, name: str) -> Callable[[dict], bool]:
        return lambda env: self.allowed_in(name, env).witness() is not None

    def allowed(self, op: str, state: Mapping[str, Any]):
        """The values of ``op``'s REAL parameters its guard allows in ``state``: an
        :class:`~tracecheck.b.linear.AllowedSet` (exact over the reals, confirmed by the
        evaluator), or where the guard is not linear in them what :meth:`beyond_linear`
        gives (a shield's machine: the solver's set; else refused)."""
        return self.allowed_in(op, self.env(state))

    def allowed_in(self, op: str, env: dict[str, Any]):
        """:meth:`allowed` for an environment made by :meth:`env`."""
        from .linear import allowed_set

        try:
            return allowed_set(self, op, env=env)
        except UnsupportedError:
            beyond = self.beyond_linear(op, env) if real_parameters(self.operation(op)) \
                else None
            if beyond is None:
                raise
            return beyond

    def allows(self, op: str, state: Mapping[str, Any], parameters: Mapping[str, Any]) -> bool:
        """Whether ``op``'s guard holds in ``state`` with its parameters bound to
        ``parameters`` (a recorded continuous action): the evaluator's answer."""
        from .linear import guard_with_parameters

        env = self.env(state)
        env.update({p: parameters[p] for p in self.operation(op).params})
        return bool(guard_with_parameters(self, op)(env))

    def enabled(self, state: Mapping[str, Any]) -> set[str]:
        """The operations whose guard holds in ``state`` (parameters: for some value)."""
        return self.enabled_in(self.env(state))

    def enabled_in(self, env: dict[str, Any]) -> set[str]:
        """:meth:`enabled` for an environment made by :meth:`env` (or kept and updated by a
        caller that decides many times: a live shield)."""
        return {name for name, fn in self._guard_fns().items() if fn(env)}

    def is_enabled(self, op: str, state: Mapping[str, Any]) -> bool:
        return self.is_enabled_in(op, self.env(state))

    def is_enabled_in(self, op: str, env: dict[str, Any]) -> bool:
        """:meth:`is_enabled` for an environment made by :meth:`env` (see
        :meth:`enabled_in`)."""
        return bool(self._guard_fns()[self.operation(op).name](env))

    def guard_variables(self) -> dict[str, frozenset[str]]:
        """For each operation with a guard, the state variables the guard reads (its
        parameters aside), in the order of the operations."""
        variables = set(self.variables)
        return {name: frozenset(ast.free_names(op.enabling_guard) & variables)
                for name, op in self.operations.items() if op.guard is not None}

    def operation(self, name: str) -> Operation:
        try:
            return self.operations[name]
        except KeyError:
            raise InputError(f"the machine {self.name} has no operation {name!r}; it has "
                             f"{', '.join(self.operations) or 'none'}",
                             hint=did_you_mean(name, self.operations) or None) from None

    def check_after(self, op: str, before: Mapping[str, Any],
                    after: Mapping[str, Any]) -> bool:
        """Whether ``after`` is a possible outcome of ``op`` executed in ``before``.

        Variables the operation does not write must be unchanged. For an operation with
        parameters, some parameter values satisfying its guard must allow ``after``.
        """
        def body(operation: Operation) -> ast.Subst:
            if not operation.params:
                return operation.body
            # parameters are not part of the state: some value of them must do
            return ast.Any(operation.params, operation.guard or ast.BoolLit(True), operation.body,
                         pos=operation.body.pos)

        outcome = self._outcome("checks", op, body)
        missing = [v for v in self.variables if v not in after]
        if missing:
            raise EvaluationError(f"the state after {op} has no value for "
                                  f"{', '.join(missing)}")
        return self._outcome_holds(op, outcome, before, after)

    def postcondition(self, op: str) -> Optional[ast.Node]:
        """The predicate replay checks for a step of ``op``: the effect of its body without
        the guards (checked on their own as feasibility), over ``v`` after and ``v$0``
        before, frame included. None when the body has a form without such a predicate."""
        cache = self._compiled.setdefault("postconditions", {})
        if op not in cache:
            body = strip_guards(self.operation(op).body)
            cache[op] = before_after(body, self.variables)
        return cache[op]

    def effect_ok(self, op: str, before: Mapping[str, Any], after: Mapping[str, Any]) -> bool:
        """Whether ``after`` is a possible effect of ``op``'s body from ``before``, its
        guards aside (see :meth:`postcondition`)."""
        outcome = self._outcome("effects", op, lambda operation: strip_guards(operation.body))
        return self._outcome_holds(op, outcome, before, after)

    def initialisation_ok(self, state: Mapping[str, Any]) -> bool:
        """Whether ``state`` is a possible outcome of the INITIALISATION (every variable
        given)."""
        check = self.cached("initialisation", None, lambda: SubstCompiler(
            self.compiler()).compile(self.initialisation or ast.Skip()))
        missing = [v for v in self.variables if v not in state]
        if missing:
            raise EvaluationError(f"the initial state has no value for {', '.join(missing)}")
        after = self.native(state, where="the initial state")
        return bool(check(dict(self.base_env), dict(after)))

    def cached(self, cache: "Cache[K, V]", key: K, make: Callable[[], V]) -> V:
        """What ``make()`` builds for ``key`` in ``cache``, built once per machine.

        Args:
            cache: a module's own :class:`Cache` (its compiled checks, kept with the machine
                they belong to, and gone with it).
            key: what the value is for (an operation's name, a formula).
            make: builds the value the first time.
        """
        store = self._compiled.setdefault(cache, {})
        if key not in store:
            store[key] = make()
        return store[key]

    def beyond_linear(self, op: str, env: dict[str, Any]):
        """The allowed set of ``op`` in ``env`` where its guard is not linear in its REAL
        parameters: None here (:meth:`allowed` then refuses, UnsupportedError); a shield's
        machine (:class:`tracecheck.checking.shield.ShieldMachine`) asks the solver."""
        return None

    def successor(self, op: Optional[str], before: Mapping[str, Any],
                  predicate: Optional[ast.Node], *, fixed: Optional[Mapping[str, Any]] = None):
        """The state after ``op`` (None: the INITIALISATION) that satisfies ``predicate``
        (or gives the variables the values ``fixed``), as ProB finds it for SimB's external
        simulation (:func:`.transitions.successor`)."""
        from .transitions import successor

        return successor(self, op, before, predicate, fixed=fixed)

    def _outcome(self, kind: str, op: str, body_of: Callable[[Operation], ast.Subst]) -> tuple:
        """(the compiled check of ``body_of(op)``, the variables it leaves unchanged), once
        per operation and ``kind``."""
        operation = self.operation(op)
        cache = self._compiled.setdefault(kind, {})
        if op not in cache:
            body = body_of(operation)
            frame = tuple(v for v in self.variables if v not in written(body))
            cache[op] = (SubstCompiler(self.compiler()).compile(body), frame)
        return cache[op]

    def _outcome_holds(self, op: str, outcome: tuple, before: Mapping[str, Any],
                       after: Mapping[str, Any]) -> bool:
        """Whether ``after`` is an outcome of the compiled body from ``before`` (see
        :meth:`_outcome`): the frame unchanged and the body's predicate true."""
        check, frame = outcome
        after = self.native(after, where=f"the state after {op}")
        pre = self.env(before)
        if any(after[v] != pre.get(v) for v in frame):
            return False
        return bool(check(pre, dict(after)))

    def invariant(self, state: Mapping[str, Any]) -> bool:
        """Whether the INVARIANT holds in ``state``."""
        if self.invariant_node is None:
            return True
        fn = self._compiled.get("invariant")
        if fn is None:
            fn = self._compiled["invariant"] = self.compile(self.invariant_node)
        return bool(fn(self.env(state)))

    def violated_invariant(self, state: Mapping[str, Any]) -> list[str]:
        """The INVARIANT conjuncts that do not hold in ``state`` (as source text)."""
        return self._conjunct_results(state, tolerate=False)[0]

    def invariant_check(self, state: Mapping[str, Any]
                        ) -> tuple[list[str], list[tuple[str, str]]]:
        """(the INVARIANT conjuncts that do not hold in ``state``, (conjunct, reason) for
        those that cannot be evaluated there, e.g. ``x has no value here``), as source text:
        for a partial state too (``tracecheck guards``)."""
        return self._conjunct_results(state, tolerate=True)

    def _conjunct_results(self, state: Mapping[str, Any], tolerate: bool
                          ) -> tuple[list[str], list[tuple[str, str]]]:
        """(broken conjuncts, (conjunct, reason) of those that cannot be evaluated — an
        :class:`EvaluationError` propagates unless ``tolerate``)."""
        if self.invariant_node is None:
            return [], []
        env = self.env(state)
        comp = self.compiler()
        broken, unchecked = [], []
        for c in conjuncts(self.invariant_node):
            try:
                if not comp.compile(c)(env):
                    broken.append(render(c, self.source))
            except (EvaluationError, WellDefinednessError) as exc:  # v : 1..3 & f(v) >= 10
                if not tolerate:                                     # at v = 5: the first
                    raise                                            # broken, f(5) unknown
                unchecked.append((render(c, self.source), exc.message))
        return broken, unchecked

    def constant_assertions(self) -> list[tuple[str, Optional[bool], str]]:
        """Each ASSERTION as (its text, its value, why there is none): those that read no
        variable decided once over the constants (None and the reason where tracecheck
        cannot tell); those that read variables are for each state (None, "reads …")."""
        out: list[tuple[str, Optional[bool], str]] = []
        for node in self.assertion_nodes:
            text = render(node, self.source)
            reads = sorted(ast.free_names(node) & set(self.variables))
            if reads:
                out.append((text, None, f"reads {', '.join(reads)}: holds or not per state"))
                continue
            try:
                out.append((text, self.compile(node)(dict(self.base_env)) is True, ""))
            except TracecheckError as exc:
                out.append((text, None, exc.message))
        return out

    def assertions(self, state: Mapping[str, Any]) -> list[bool]:
        env = self.env(state)
        return [bool(self.compile(a)(env)) for a in self.assertion_nodes]


# ------------------------------------------------------------------ loading


def load_machine(path: str | Path, kind: "Optional[type[Machine]]" = None) -> Machine:
    """Read, check and set up the classical B machine in ``path``.

    Args:
        path: a ``.mch`` file.
        kind: the class made (:class:`Machine`, or a subclass such as a shield's).

    Returns:
        The :class:`Machine`: its sets, constants, variables and operations, ready to
        evaluate guards (:meth:`Machine.enabled`).

    Raises:
        TracecheckError: a located error (file, line, column) for what it cannot read.

    >>> load_machine("models/shields/paper.mch").name  # repo root
    'PaperShield'
    """
    return load_machine_text(read_text(path, "model file"), file=str(path), kind=kind)


def load_machine_text(text: str, *, file: Optional[str] = None,
                      kind: "Optional[type[Machine]]" = None) -> Machine:
    """Set up a machine from its text (see :func:`load_machine`).

    Args:
        text: the machine's text.
        file: where it comes from, for error messages.
        kind: the class made (:class:`Machine`, or a subclass such as a shield's).

    Returns:
        The :class:`Machine`.

    >>> load_machine_text("MACHINE M VARIABLES x INVARIANT x : 0..3 INITIALISATION x := 0 "
    ...                   "OPERATIONS Up = SELECT x < 3 THEN x := x + 1 END END").enabled({"x": 3})
    set()
    """
    src = None
    try:
        with deep_recursion():  # expanding, checking and setting up recurse into formulas
            src = parse_machine_source(text, file=file)
            return _build(src, kind or Machine)
    except TracecheckError as exc:  # in the text of every machine read (SEES, INCLUDES)
        raise exc.located(file=file or "<model>", source=src.text if src else text) from None


def _build(src: MachineSource, kind: "type[Machine]") -> Machine:
    defs = src.definitions
    _check_names(src)

    def pred(node: Optional[ast.Node], what: str) -> Optional[ast.Node]:
        if node is None:
            return None
        node = expand(node, defs)
        check_kind(node, PRED, source=src.text, context=what)
        return node

    properties = pred(src.properties, "the PROPERTIES")
    invariant = pred(src.invariant, "the INVARIANT")
    assertions = tuple(pred(a, "each assertion") for a in src.assertions)
    operations = {}
    starts = [op.pos.start if op.pos is not None else len(src.text) for op in src.operations]
    for op, until in zip(src.operations, starts[1:] + [len(src.text)]):
        body = expand(op.body, defs)
        check_subst(body, source=src.text)
        written_guard = guard_of(op.body)
        operations[op.name] = Operation(
            op.name, op.params, op.outputs, guard_of(body), body, _op_description(src, op, until),
            render(written_guard, src.text) if written_guard is not None else None, op.pos)
    descriptions = {}
    for name, pos in src.constants + src.variables:
        desc = src.description_after(pos)
        if desc:
            descriptions[name] = desc
    for name, _, pos in src.sets:
        desc = src.description_after(pos)
        if desc:
            descriptions[name] = desc
    sets, enumerated, constants = setup_constants(src, properties)
    init = None
    if src.initialisation is not None:
        init = expand(src.initialisation, defs)
        check_subst(init, source=src.text)
    machine = kind(
        name=src.name, file=src.file, source=src.text,
        sha256=hashlib.sha256(src.text.encode("utf-8")).hexdigest(), sets=sets,
        enumerated=enumerated, constants=constants,
        variables=tuple(n for n, _ in src.variables), invariant_node=invariant,
        assertion_nodes=assertions, operations=operations, descriptions=descriptions,
        definitions=defs, properties_node=properties, initialisation=init,
        constants_declared=tuple(n for n, _ in src.constants),
    )
    from .typecheck import typecheck_machine

    machine.types = typecheck_machine(machine)
    unset = [c for c in machine.constants_declared if c not in machine.constants]
    if unset:
        machine.settle_constants(unset)
    return machine


def _op_description(src: MachineSource, op, until: int) -> Optional[str]:
    """An operation's ``/*@desc …*/``: after its name or header (``Op(x) /*@desc …*/ =``),
    after the ``=`` (``Op = /*@desc …*/ SELECT …``), or after its body (``… END /*@desc
    …*/;``, before ``until``, where the next operation starts)."""
    found = src.description_after(op.pos)
    body = op.body.pos
    if found is not None or body is None or op.pos is None:
        return found
    before = [t for end, t in src.descriptions.items() if op.pos.end < end <= body.start]
    after = [t for end, t in sorted(src.descriptions.items()) if body.end <= end < until]
    return (before or after or [None])[0]


def _check_names(src: MachineSource) -> None:
    seen: dict[str, str] = {}
    entries = [(n, "set", p) for n, _, p in src.sets]
    entries += [(e, "set element", p) for _, elems, p in src.sets for e in (elems or ())]
    entries += [(n, "constant", p) for n, p in src.constants]
    entries += [(n, "variable", p) for n, p in src.variables]
    for name, what, pos in entries:
        if name in seen:
            raise BScopeError(f"{name} is declared twice (as {seen[name]} and as {what})",
                              line=pos.line if pos else None,
                              column=pos.column if pos else None)
        seen[name] = what


def mixed_parameters(op: Operation, file: Optional[str] = None,
                     source: Optional[str] = None) -> UnsupportedError:
    """Why ``op``, whose guard types some parameters ``p : REAL`` but not the others, has
    no enabled set tracecheck can decide where it cannot enumerate them: a REAL one is no
    finite set to walk (unless the guard fixes it, ``a = 0.5``), and only an operation
    whose every parameter is typed REAL is a continuous action."""
    typed = real_typed(op)
    reals = [p for p in op.params if p in typed]
    others = [p for p in op.params if p not in typed]
    pos = op.guard.pos if op.guard is not None else None
    return UnsupportedError(
        f"{op.name}({', '.join(op.params)}) types {', '.join(reals)} REAL in its guard but "
        f"not {', '.join(others)}: tracecheck decides an operation's REAL parameters as a "
        "continuous action only when its guard types every parameter so",
        file=file, line=pos.line if pos else None, column=pos.column if pos else None,
        source=source, hint=f"add `{others[0]} : REAL` to the guard of {op.name}, or make "
                            f"{', '.join(others)} the parameters of another operation")
