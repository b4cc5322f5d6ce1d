"""What statistics are computed from: the runs' environment, and each metric and property
of a set type-checked against its machine and prepared for batch evaluation.

The environment of a run is the one its file names, else the installed one that claims its
states; a formula is checked against that environment's machine (the shield its adapter
names), or against a sample state's types where there is none; LTL and STL properties are
read in the machine, with the recorded crash flag as one more variable.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import numpy as np

from ..b.typecheck import typecheck_formula
from ..b.vector import BatchFormula
from ..checking.crashflag import CRASH_FLAG, flagged
from ..episodes.columns import RunColumns
from ..errors import EvaluationError, InputError, TracecheckError
from ..live.adapter import installed_adapter
from .properties import PropertySet, bundled_set, load_properties, with_generic

__all__ = ["Formulas", "prepare", "environment_of", "default_set", "adapter_set",
           "check_environment", "naming"]


@dataclass
class Formulas:
    """A property set prepared for evaluation: per metric and per property its formula (a
    batch formula, or an LTL/STL formula over whole episodes), and the warnings found."""

    metrics: dict[str, Any] = field(default_factory=dict)
    properties: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def environment_of(path: str | Path) -> str:
    """The environment a run file's states come from: the one its header names; for a file
    that names none (imported traces, files from before environments were recorded), the
    installed environment that claims its state variables
    (:meth:`~tracecheck.live.adapter.EnvAdapter.claims`), else the name of its machine
    (looked up among the installed adapters only, so usually none: generic statistics)."""
    from ..episodes.reader import read_header
    from ..live.adapter import claiming_adapter

    header = read_header(path)
    if header.environment:
        return header.environment
    claimed = claiming_adapter(header.variables or _first_variables(path))
    if claimed is not None:
        return claimed.name
    return header.model_name or "unnamed"


def _first_variables(path: str | Path) -> tuple[str, ...]:
    """The variables of a run's first state (a header that declares none: files written
    through the library without them)."""
    from ..episodes.reader import read_episodes

    try:
        first = next(iter(read_episodes(path)), None)
    except TracecheckError:  # what is damaged is said where the run is read for its values
        return ()
    return tuple(first.steps[0].state) if first is not None and first.steps else ()


@dataclass
class _Scope:
    """What formulas are checked against: names with their types, constants, the state
    variables (for hints), and whether ``crashed`` is the environment's own name."""

    names: dict
    constants: dict
    variables: tuple
    own_crashed: bool


def _typing_scope(environment=None, sample: Optional[dict] = None,
                  machine=None) -> _Scope:
    """The names and constants properties are checked against: those of ``machine`` when
    given, else of the environment's machine (the shield its adapter names), else the types
    of a sample state's values — and the recorded crash flag ``crashed``, unless they have a
    ``crashed`` of their own."""
    from ..b.btypes import BOOL
    from ..b.typecheck import type_of_value

    adapter = None if machine is not None else installed_adapter(environment, required=False)
    if machine is None and adapter is not None and adapter.default_shield is not None:
        machine = own_shield(adapter).machine
    if machine is not None:
        names, constants, variables = (dict(machine.type_objects), dict(machine.base_env),
                                       machine.variables)
    else:  # no machine: the recorded states' own types (none before the first episode)
        sample = sample or {}
        names, constants = {k: type_of_value(v) for k, v in sample.items()}, {}
        variables = tuple(sample) or (tuple(adapter.variables) if adapter else ())
    own = CRASH_FLAG in names
    if not own:
        names[CRASH_FLAG] = BOOL
    return _Scope(names, constants, variables, own)


def _class(adapter) -> str:
    return f"{type(adapter).__module__}:{type(adapter).__qualname__}"


def _reads_crashed(node, text: Optional[str]) -> bool:
    import re

    from ..b.ast import free_names

    if node is not None:
        return CRASH_FLAG in free_names(node)
    return bool(re.search(rf"\b{CRASH_FLAG}\b", text or ""))


def _check(node, kind: str, where: str, text: str, scope: _Scope) -> None:
    try:
        typecheck_formula(node, scope.names, kind=kind, source=text, file=where,
                          unknown_hint="the state variables are "
                                       f"{', '.join([*scope.variables, CRASH_FLAG])}")
    except TracecheckError as exc:
        raise exc.located(file=where, source=text) from None


def default_set(paths: list[str | Path], adapter=None) -> tuple[PropertySet, list[str]]:
    """The generic set with the runs' environment's own set added where it has one (its
    adapter given, or installed), and notes for people (an adapter not installed here)."""
    environment = environment_of(paths[0]) if paths else None
    adapter = adapter if adapter is not None else (
        installed_adapter(environment, required=False) if environment else None)
    if adapter is None:
        from ..episodes.reader import read_header

        if paths and read_header(paths[0]).source == "external":
            return with_generic(None), [
                f"the runs come from an agent script (states of {environment}): generic "
                "statistics (give --properties FILE for the machine's own properties)"]
        if paths and not read_header(paths[0]).environment:
            return with_generic(None), [
                "these runs name no environment and no installed one claims their states: "
                "generic statistics only (give --env NAME or --properties FILE for their "
                "own properties)"]
        return with_generic(None), [
            f"the environment {environment} of these runs is not installed here: generic "
            "statistics only (give --env package.module:Class for its own property set)"]
    return adapter_set(adapter), []


def adapter_set(adapter) -> PropertySet:
    """The generic set with the adapter's own added (``stats`` and ``simulate`` without
    ``--properties``)."""
    own = adapter.property_sets.get(adapter.properties) if adapter.properties else None
    if own is not None:  # the environment's own set, whatever another declares by its name
        return with_generic(bundled_set(adapter.properties, own))
    return with_generic(load_properties(adapter.properties) if adapter.properties else None)


def own_shield(adapter):
    """The adapter's default shield: one it brings itself by that name (whatever another
    environment declares by the same name), else :func:`load_shield` of the name or path."""
    from ..checking.shield import Shield, ShieldMachine, load_shield
    from ..b.machine import load_machine

    own = adapter.shields.get(adapter.default_shield)
    if own is None:
        return load_shield(adapter.default_shield)
    machine = load_machine(own, kind=ShieldMachine)
    return Shield(name=adapter.default_shield, sha256=machine.sha256, path=str(own),
                  machine=machine)


def prepare(pset: PropertySet, environment=None, sample: Optional[dict] = None,
            machine=None) -> "Formulas":
    """Type-check every formula of ``pset`` against the environment's machine (a name or an
    adapter; ``sample``: a state to take types from where there is no machine; ``machine``:
    a machine to use instead, a ProB project's) and prepare it for batch evaluation.
    Its ``warnings`` say where ``crashed`` is the environment's own name, not the recorded
    crash flag."""
    needs_scope = any(m.node is not None for m in pset.metrics) or any(
        p.node is not None for p in pset.properties)
    if machine is None:
        environment = _environment_adapter(environment, sample) or environment
    scope = _typing_scope(environment, sample, machine) if needs_scope else None
    formulas = Formulas()

    def note(node, text, where) -> None:
        if scope is not None and scope.own_crashed and _reads_crashed(node, text):
            formulas.warnings.append(f"{where}: crashed is the environment's own "
                                        "variable here, not the recorded crash flag")

    for m in pset.metrics:
        where = f"{pset.where}: metric {m.name}"
        if m.aggregate == "stl":
            formulas.metrics[m.name] = _Temporal("stl", m.expression, _machine(environment),
                                                where)
            note(None, m.expression, where)
        elif m.node is not None:
            _check(m.node, "expression", where, m.expression, scope)
            formulas.metrics[m.name] = BatchFormula(m.node, scope.constants,
                                                   source=m.expression, file=where)
            note(m.node, None, where)
    for p in pset.properties:
        where = f"{pset.where}: property {p.name}"
        if p.kind in ("ltl", "stl"):
            formulas.properties[p.name] = _Temporal(p.kind, p.predicate, _machine(environment),
                                                where)
            note(None, p.predicate, where)
        elif p.node is not None:
            _check(p.node, "predicate", where, p.predicate, scope)
            formulas.properties[p.name] = BatchFormula(p.node, scope.constants, source=p.predicate,
                                                   file=where)
            note(p.node, None, where)
    return formulas


def _environment_adapter(environment, sample: Optional[dict]):
    """The adapter of the runs' environment: the one named (or given) where it is installed,
    else — for runs that name none — the installed one that claims the variables of a
    sample state; None where neither is."""
    from ..live.adapter import EnvAdapter, claiming_adapter

    if isinstance(environment, EnvAdapter):
        return environment
    adapter = installed_adapter(environment, required=False) if environment else None
    if adapter is None and sample:
        adapter = claiming_adapter(tuple(sample))
    return adapter


def _machine(environment):
    """The machine of the environment's default shield (what LTL properties are read in),
    with the recorded crash flag as one more variable (unless it has a ``crashed``)."""

    adapter = installed_adapter(environment)
    if adapter.default_shield is None:
        raise InputError(f"the environment {adapter.name} names no machine to read LTL and "
                         "STL properties in: its adapter has no default_shield",
                         hint=f"set default_shield = \"NAME_OR_PATH.mch\" (a built-in shield's "
                              f"name or the path of a .mch file) on {_class(adapter)}")
    machine = own_shield(adapter).machine
    return flagged(machine)


@contextmanager
def naming(where: str):
    """An :class:`EvaluationError` raised inside says ``where`` first (the metric)."""
    try:
        yield
    except EvaluationError as exc:
        if not exc.message.startswith(where):
            exc.message = f"{where}: {exc.message}"
            exc.args = (exc.render(),)
        raise


class _Temporal:
    """An LTL or STL formula over whole episodes: per episode, whether it holds (LTL; STL:
    a positive robustness, and at 0 the formula's own truth read as LTL, as ``falsify``
    decides — ``G({battery >= 1})`` whose least battery is 1 holds; a bounded ``G[a,b]``,
    which LTL does not have: 0 is a violation) or its robustness (STL)."""

    def __init__(self, logic: str, text: str, machine, where: str) -> None:
        from ..checking.ltl import parse_ltl
        from ..checking.stl import parse_stl

        self.logic, self.machine, self.where = logic, machine, where
        self.formula = (parse_ltl if logic == "ltl" else parse_stl)(text, machine, where=where)
        self.truth = None  # an STL formula's, where LTL reads it
        if logic == "stl":
            try:
                self.truth = parse_ltl(text, machine, where=where)
            except TracecheckError:
                pass  # STL only (G[a,b]): a robustness of 0 is a violation

    def values(self, cols: RunColumns) -> np.ndarray:
        from ..checking.stl import episode_robustness

        with naming(self.where):
            return episode_robustness(self.formula, cols, self.machine)

    def holds(self, cols: RunColumns) -> np.ndarray:
        from ..checking.ltl import evaluate_ltl

        if self.logic == "stl":
            rho = self.values(cols)
            held, edge = rho > 0, rho == 0
            if self.truth is not None and edge.any():  # on the boundary: the truth decides
                held |= edge & evaluate_ltl(self.truth, cols, self.machine)[cols.starts[:-1]]
            return held
        return evaluate_ltl(self.formula, cols, self.machine)[cols.starts[:-1]]


def check_environment(adapter, path: str | Path) -> None:
    """``--env`` must be the adapter of the environment a run's file names (a run that
    names none takes the adapter given: its machine, its picture)."""
    from ..episodes.reader import read_header

    environment = read_header(path).environment
    if environment and adapter.name != environment:
        raise InputError(f"the runs come from the environment {environment}, but --env gives "
                         f"the adapter of {adapter.name}",
                         hint=f"give the adapter of {environment}, or leave --env out")
