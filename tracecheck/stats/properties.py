"""Property sets: the B predicates and metrics that statistics are computed from.

A property file is TOML::

    [metrics.velocity]
    expression = "RSQRT(VehiclesVx(EgoVehicle)**2 + VehiclesVy(EgoVehicle)**2)"
    aggregate = "average"           # steps | average | sum | sum_between_steps | min | max | …
    estimate = { value = 22.0, epsilon = 1.0 }   # optional: SimB's "desired value ± ε"

    [properties.SAF1]
    predicate = "Crash = FALSE"
    kind = "invariant"              # invariant | eventually | final
    test = { p = 0.9, alpha = 0.05, tail = "left" }   # optional hypothesis test

Aggregates over the states s0 … sn of an episode (n = steps), as SimB defines them:
``steps`` is n; ``return`` the sum of the recorded step rewards (no expression); ``average`` the mean over s0…sn; ``sum`` the sum over s0…sn;
``sum_between_steps`` Σ_{k=1..n} (value in s(k−1) + value in s(k)) / 2; ``min``, ``max``;
``average_between_steps`` that sum divided by n (0 when n = 0), ``min_between_steps`` and
``max_between_steps`` the least and greatest of its n terms (SimB's ``…_MEAN_BETWEEN_STEPS``
checking types; not a number when n = 0).
An estimate checks the mean over the episodes (SimB's estimation): with ``type = "mean"`` (the
default) it must lie within value ± ε, with ``"minimum"`` be at least value − ε, with
``"maximum"`` at most value + ε.
``interventions`` the share of the episode's steps where the shield replaced the agent's
preferred action (from the recorded action values; for continuous actions, the steps whose
executed values differ from the agent's proposal; no expression).
A property of kind ``invariant`` holds in every state (the initial state included),
``eventually`` in some state, ``final`` in the last one; of kind ``ltl``, its ``predicate``
is an LTL formula in ProB's syntax (``G({Crash = FALSE} => …)``, see
:mod:`tracecheck.checking.ltl`) that holds for the episode — its atoms are checked against
the environment's machine, and ``e(Op)`` and ``deadlock`` use that machine as the shield;
of kind ``stl``, an STL formula (:mod:`tracecheck.checking.stl`) whose robustness is
positive; of kind ``end``, its ``predicate`` is an end reason (``crashed``, ``time-limit``,
``end-of-trace``, ``deadlock``, ``interrupted``) and it holds when the episode ended so. A
metric with ``aggregate = "stl"`` is the robustness of its STL ``expression`` per episode.

Every formula (B, LTL atoms, STL) can read ``crashed``, the crash flag recorded with each
state (a BOOL: ``crashed = TRUE``, in LTL ``{crashed = TRUE}``), in every environment — unless
the environment's machine or states have a ``crashed`` of their own, which is then what the
name means (with a warning).

Without a property file, ``stats`` uses :data:`GENERIC_TOML` (any run) with the adapter's own
set added (:func:`with_generic`).
"""

from __future__ import annotations

import re

import functools
import math
import tomllib
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from ..b import ast
from ..b.parser import parse_formula
from ..b.scope import EXPR, PRED, check_kind
from ..episodes.model import END_REASONS
from ..errors import InputError, TracecheckError
from .. import registry
from ..inputs import read_text

__all__ = ["Metric", "Property", "HypothesisTest", "PropertySet", "load_properties",
           "bundled_set",
           "builtin_sets", "GENERIC_SET", "AGGREGATES", "KINDS", "TAILS", "ESTIMATE_TYPES",
           "with_generic"]

AGGREGATES = ("steps", "average", "sum", "sum_between_steps", "min", "max", "return", "stl",
              "interventions", "average_between_steps", "min_between_steps",
              "max_between_steps")
#: how an estimate judges the mean over the episodes (SimB's ESTIMATION_TYPE)
ESTIMATE_TYPES = ("mean", "minimum", "maximum")
KINDS = ("invariant", "eventually", "final", "ltl", "stl", "end")
TAILS = ("left", "right", "two")


@dataclass(frozen=True)
class HypothesisTest:
    p: float
    alpha: float = 0.05
    tail: str = "left"


@dataclass(frozen=True)
class Metric:
    name: str
    aggregate: str
    expression: Optional[str] = None
    node: Optional[ast.Node] = None
    description: str = ""
    estimate: Optional[tuple[float, float]] = None  # (value, epsilon)
    estimate_type: str = "mean"  # one of ESTIMATE_TYPES


@dataclass(frozen=True)
class Property:
    name: str
    predicate: str
    node: Optional[ast.Node]  # None for kinds "ltl", "stl" (see tracecheck.checking.ltl), "end"
    kind: str = "invariant"
    description: str = ""
    test: Optional[HypothesisTest] = None


@dataclass(frozen=True)
class PropertySet:
    name: str
    metrics: tuple[Metric, ...] = ()
    properties: tuple[Property, ...] = field(default_factory=tuple)
    file: str = ""  # where it was read (messages name it); the name if empty

    @property
    def where(self) -> str:
        return self.file or self.name

    def select(self, names: Optional[list[str]]) -> "PropertySet":
        """Only the metrics and properties named (all when ``names`` is empty)."""
        if not names:
            return self
        known = {m.name for m in self.metrics} | {p.name for p in self.properties}
        unknown = [n for n in names if n not in known]
        if unknown:
            raise InputError(f"the set {self.name} has no metric or property "
                             f"{', '.join(unknown)}; it has {', '.join(sorted(known))}")
        return PropertySet(self.name, tuple(m for m in self.metrics if m.name in names),
                           tuple(p for p in self.properties if p.name in names), self.file)


def _formula(text: object, kind: str, where: str, file: str) -> ast.Node:
    if not isinstance(text, str):
        raise InputError(f"{file}: {where} must be a string with a B {kind}")
    try:
        node = parse_formula(text, file=f"{file}: {where}")
        check_kind(node, PRED if kind == "predicate" else EXPR, source=text,
                   context=f"the {kind}")
    except TracecheckError as exc:
        exc.file = f"{file}: {where}"
        if kind == "predicate" and re.match(r"\s*(not\s*)?[GFX]\s*(\[[^]]*\]\s*)?[({]",
                                            text):  # G({x > 0}) under kind = "invariant"
            exc.hint = "a temporal formula: kind = \"ltl\" (or \"stl\" for its robustness)"
        raise exc.located(source=text) from None
    return node


def _number(value: object, name: str, where: str, file: str, *, open01: bool = False,
            at_least: Optional[float] = None) -> float:
    if type(value) not in (int, float):
        raise InputError(f"{file}: {where}: {name} must be a number, not {_shown(value)}")
    try:
        number = float(value)
    except OverflowError:  # a TOML integer beyond any float
        number = math.inf
    if not math.isfinite(number):
        raise InputError(f"{file}: {where}: {name} must be a finite number, not "
                         f"{_shown(value)}")
    if open01 and not 0.0 < number < 1.0:
        raise InputError(f"{file}: {where}: {name} must lie strictly between 0 and 1, "
                         f"not {value}")
    if at_least is not None and number < at_least:
        raise InputError(f"{file}: {where}: {name} must be at least {at_least:g}, not {value}")
    return number


def _shown(value: object) -> str:
    """A TOML value for a message: what it is, cut short."""
    kind = {bool: "the boolean", str: "the string", int: "the number", float: "the number",
            list: "the array", dict: "the table"}.get(type(value), "the value")
    text = repr(value).replace("True", "true").replace("False", "false")
    return f"{kind} {text if len(text) <= 60 else text[:57] + '...'}"


def _controls(text: str) -> bool:
    return any(unicodedata.category(c) == "Cc" for c in text)


def _string(spec: dict, key: str, where: str, file: str, default: str = "") -> str:
    """``spec[key]``: a string without control characters (names and descriptions reach
    terminals, tables and plots)."""
    value = spec.get(key, default)
    if not isinstance(value, str):
        raise InputError(f"{file}: {where}: {key} must be a string, not {_shown(value)}")
    if _controls(value):
        raise InputError(f"{file}: {where}: {key} holds a control character (NUL, escape, "
                         "line break, …); write it on one line without them")
    return value


def _keys(spec: object, allowed: tuple, where: str, file: str, what: str) -> dict:
    """``spec`` as a table with only ``allowed`` keys (a misspelt key would be ignored)."""
    if not isinstance(spec, dict):
        raise InputError(f"{file}: {where}: expected a table ({what}), got {_shown(spec)}")
    unknown = [k for k in spec if k not in allowed]
    if unknown:
        raise InputError(f"{file}: {where}: unknown key {unknown[0]!r}; {what} has "
                         f"{', '.join(allowed)}")
    return spec


def _entries(data: dict, section: str, file: str) -> dict:
    """The [section.NAME] tables of a property file, their names checked."""
    entries = data.get(section, {})
    if not isinstance(entries, dict):
        raise InputError(f"{file}: {section}: expected tables [{section}.NAME], got "
                         f"{_shown(entries)}")
    single = {"metrics": "metric", "properties": "property"}[section]
    for name in entries:
        if not name.strip() or _controls(name):
            raise InputError(f"{file}: {section}.{name!r}: a {single} name must be non-empty "
                             "printable text, without control characters (NUL, escape, line "
                             "break, …)")
    return entries


def parse_properties(text: str, *, name: str, file: str) -> PropertySet:
    """A property set from TOML text (see the module docstring). Every mistake is an
    :class:`InputError` naming the file and the entry."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML: {exc}", file=file, line=getattr(exc, "lineno", None),
                         column=getattr(exc, "colno", None), source=text) from None
    except RecursionError:
        raise InputError("not a property file: its arrays or tables nest thousands of levels "
                         "deep", file=file) from None
    extra = set(data) - {"metrics", "properties"}
    if extra:
        raise InputError(f"{file}: unknown section {sorted(extra)[0]!r}; a property file has "
                         "[metrics.NAME] and [properties.NAME] tables")
    metric_specs, property_specs = _entries(data, "metrics", file), _entries(data, "properties",
                                                                            file)
    both = sorted(set(metric_specs) & set(property_specs))
    if both:
        raise InputError(f"{file}: {both[0]!r} names both a metric and a property; give each "
                         "its own name")
    metrics = tuple(_metric(n, spec, file) for n, spec in metric_specs.items())
    props = tuple(_property(n, spec, file) for n, spec in property_specs.items())
    if not metrics and not props:
        raise InputError(f"{file}: no metrics and no properties")
    return PropertySet(name, metrics, props, file)


def _metric(name: str, spec: dict, file: str) -> Metric:
    where = f"metric {name}"
    spec = _keys(spec, ("expression", "aggregate", "estimate", "description"), where, file,
                 "a metric")
    aggregate = _choice(spec, "aggregate", "average", AGGREGATES, where, file)
    node = None
    if aggregate == "stl":
        _temporal_text(spec.get("expression"), "expression", "STL", where, file)
    elif aggregate not in ("steps", "return", "interventions"):
        node = _formula(spec.get("expression"), "expression", f"{where} expression", file)
    estimate, estimate_type = None, "mean"
    if "estimate" in spec:
        est = _keys(spec["estimate"], ("value", "epsilon", "type"), f"{where}: estimate", file,
                    "an estimate {value = …, epsilon = …}")
        estimate = (_number(est.get("value"), "estimate value", where, file),
                    _number(est.get("epsilon"), "estimate epsilon", where, file, at_least=0))
        estimate_type = _choice(est, "type", "mean", ESTIMATE_TYPES, f"{where}: estimate", file)
    return Metric(name, aggregate, spec.get("expression"), node,
                  _string(spec, "description", where, file), estimate, estimate_type)


def _choice(spec: dict, key: str, default: str, allowed: tuple, where: str, file: str) -> str:
    """``spec[key]`` (or ``default``), one of ``allowed``."""
    value = spec.get(key, default)
    if not isinstance(value, str) or value not in allowed:
        raise InputError(f"{file}: {where}: unknown {key} {value!r}; the {key}s are "
                         f"{', '.join(allowed)}")
    return value


def _temporal_text(text: object, key: str, logic: str, where: str, file: str) -> None:
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{file}: {where} {key} must be a string with an {logic} formula")


def _property(name: str, spec: dict, file: str) -> Property:
    where = f"property {name}"
    spec = _keys(spec, ("predicate", "kind", "description", "test"), where, file,
                 "a property")
    kind = _choice(spec, "kind", "invariant", KINDS, where, file)
    if kind == "end":

        if spec.get("predicate") not in END_REASONS:
            raise InputError(f"{file}: {where}: a property of kind end names an end reason "
                             f"({', '.join(END_REASONS)}), not {_shown(spec.get('predicate'))}")
        node = None
    elif kind in ("ltl", "stl"):  # parsed against the environment's machine (prepare)
        _temporal_text(spec.get("predicate"), "predicate", kind.upper(), where, file)
        node = None
    else:
        node = _formula(spec.get("predicate"), "predicate", f"{where} predicate", file)
    test = None
    if "test" in spec:
        t = _keys(spec["test"], ("p", "alpha", "tail"), f"{where}: test", file,
                  "a test {p = …, alpha = …, tail = …}")
        tail = _choice(t, "tail", "left", TAILS, where, file)
        test = HypothesisTest(_number(t.get("p"), "p", where, file, open01=True),
                              _number(t.get("alpha", 0.05), "alpha", where, file, open01=True),
                              tail)
    return Property(name, spec["predicate"], node, kind,
                    _string(spec, "description", where, file), test)


#: What ``stats`` gives for any run, whatever its environment (and whether or not its
#: adapter is installed): from what every recording holds.
GENERIC_TOML = """
[metrics.episode_length]
aggregate = "steps"
description = "Episode length (steps)"

[metrics.return]
aggregate = "return"
description = "Return"

[metrics.interventions]
aggregate = "interventions"
description = "Interventions (share of steps)"

[properties.CRASH]
predicate = "crashed = TRUE"
kind = "eventually"
description = "crashed (the recorded crash flag)"

[properties.TIME_LIMIT]
predicate = "time-limit"
kind = "end"
description = "ran until a time limit (the environment's own or --duration)"
"""

GENERIC_SET = parse_properties(GENERIC_TOML, name="generic", file="<generic>")


def with_generic(own: Optional[PropertySet]) -> PropertySet:
    """The generic set, with an environment's own set added (its entries replace generic
    ones of the same name, in place: an environment's ``episode_length`` may count seconds)."""
    if own is None:
        return GENERIC_SET
    mine = {m.name: m for m in own.metrics}
    props = {p.name: p for p in own.properties}
    metrics = [mine.pop(m.name, m) for m in GENERIC_SET.metrics] + list(mine.values())
    properties = [props.pop(p.name, p) for p in GENERIC_SET.properties] + list(props.values())
    return PropertySet(f"generic+{own.name}", tuple(metrics), tuple(properties), own.file)


def builtin_sets() -> list[str]:
    """Every name ``--properties`` takes besides a path: ``generic`` and the property sets the
    installed environments bring (their adapters' ``property_sets``)."""
    return ["generic", *sorted(registry.bundled("property_sets"))]


def load_properties(spec: str | Path) -> PropertySet:
    """A property set by name or from a file.

    Args:
        spec: ``generic``, the name of a set an installed environment brings, or the path of
            a property file (TOML).

    Returns:
        The parsed and type-checked-for-syntax :class:`PropertySet`.

    >>> load_properties("generic").name
    'generic'
    """
    if str(spec) == "generic":
        return GENERIC_SET
    found = registry.bundled("property_sets").get(str(spec)) if not Path(spec).suffix else None
    twice = registry.clashes("property_sets").get(str(spec)) if found is not None else None
    if twice:
        raise InputError(f"the property set name {str(spec)!r} is declared by the "
                         f"environments {', '.join(twice)}, each for its own",
                         hint="give the path of the property file you mean")
    if found is not None:
        return bundled_set(str(spec), found[1])
    path = Path(spec)
    if not path.suffix and not path.exists():
        raise InputError(f"unknown property set {str(spec)!r}: give one of "
                         f"{', '.join(builtin_sets())} or the path of a property file (TOML)")
    return parse_properties(read_text(path, "property file"), name=path.stem, file=str(path))


@functools.lru_cache(maxsize=32)
def bundled_set(name: str, source: str | Path) -> PropertySet:
    """An environment's property set: its TOML text, or the path of its file (parsed once)."""
    if isinstance(source, Path):
        return parse_properties(read_text(source, "property file"), name=name, file=str(source))
    return parse_properties(source, name=name, file=f"<{name}>")
