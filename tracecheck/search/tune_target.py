"""What ``tracecheck tune`` varies: one number of a shield — a CONSTANT the PROPERTIES give by
an equality (``Limit = 4.0``), a DEFINITION that is a number (``TOLERANCE == 0.05``) or a
literal at one place in the text (``--literal Brake:40.0``) — its place in the text (what a
rewritten machine changes), its value, and the operations whose guards read it.

Every way of naming one that cannot work is an :class:`~tracecheck.errors.InputError` that
says what can be named instead; a range of values is checked against the machine before any
state is read: each end written in must give a machine that loads (type-checks) and whose
PROPERTIES hold over the whole range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal
from fractions import Fraction
from typing import Optional

from ..b import ast
from ..b.bindings import conjuncts
from ..b.threshold import Values, threshold_guard, values_of
from ..errors import InputError, TracecheckError, UnsupportedError

__all__ = ["Target", "resolve_target", "written", "check_range", "number_text", "numeric_names",
           "literal_specs", "TUNED"]

#: the name a tuned definition or literal goes by in the guards (no B identifier has it)
TUNED = "$tuned"
_LITERALS = (ast.RealLit, ast.IntLit)


@dataclass(frozen=True)
class Target:
    """One number of a machine to tune.

    Attributes:
        label: how the user named it (``Limit``, ``TOLERANCE``, ``Brake:40.0``).
        kind: ``constant``, ``definition`` or ``literal``.
        value: its value in the machine as written.
        integer: an INTEGER (values are whole numbers) rather than a REAL.
        span: the text it is written as (start, end offsets): what a rewritten machine
            replaces.
        line: where that text starts (1-based) …
        column: … and its column.
        name: the name it goes by in the guards (the constant's own, else :data:`TUNED`).
        nodes: the places (start, end) of the formulas replaced by ``name`` (a definition's
            body or the literal), empty for a constant.
        guards: per operation whose guard reads it, that guard with ``name`` in its place.
    """

    label: str
    kind: str
    value: float
    integer: bool
    span: tuple[int, int]
    line: int
    column: int
    name: str
    nodes: frozenset
    guards: dict

    @property
    def where(self) -> str:
        return f"line {self.line}, column {self.column}"


def resolve_target(machine, param: Optional[str] = None,
                   literal: Optional[str] = None) -> Target:
    """The :class:`Target` ``--param NAME`` or ``--literal SCOPE:VALUE[@LINE:COL]`` names.

    Raises:
        InputError: the name is no constant or definition of the machine, is not a number,
            is not given one by an equality, or no guard reads it; a literal not found (the
            message lists those in its scope), or found at several places (it lists them).
    """
    if literal is not None:
        return _literal(machine, literal)
    assert param is not None
    if param in machine.constants_declared:
        return _constant(machine, param)
    d = machine.definitions.get(param)
    if d is not None:
        return _definition(machine, param, d)
    names = ", ".join(numeric_names(machine)) or "none"
    raise InputError(f"--param {param}: {machine.name} has no constant or definition "
                     f"{param}", hint=f"its numeric constants and definitions: {names}; a "
                     "number written in a guard is named with --literal OPERATION:VALUE")


def numeric_names(machine) -> list[str]:
    """The constants and definitions of ``machine`` that are numbers (what --param takes)."""
    found = [c for c in machine.constants_declared
             if isinstance(machine.constants.get(c), (int, float))
             and not isinstance(machine.constants.get(c), bool)]
    found += [n for n, d in machine.definitions.items()
              if d.kind == "formula" and not d.params and _number_node(d.body) is not None]
    return found


def _number_node(node) -> Optional[float]:
    """The number a literal (or a negated one) is, else None."""
    if isinstance(node, _LITERALS) and not isinstance(node.value, bool):
        return node.value
    if isinstance(node, ast.Neg) and isinstance(node.operand, _LITERALS):
        return -node.operand.value
    return None


def _constant(machine, name: str) -> Target:
    value = machine.constants.get(name)
    if machine.types.get(name) not in ("REAL", "INTEGER"):
        raise InputError(f"--param {name}: the constant {name} is not a number "
                         f"({machine.types.get(name, 'of no number type')})",
                         hint=f"numeric ones: {', '.join(numeric_names(machine)) or 'none'}")
    lit = None
    for c in conjuncts(machine.properties_node) if machine.properties_node else []:
        if isinstance(c, ast.Rel) and c.op == "=":
            for a, b in ((c.left, c.right), (c.right, c.left)):
                if isinstance(a, ast.Name) and a.id == name and _number_node(b) is not None:
                    lit = b
    if lit is None or lit.pos is None or type(value) is bool or not isinstance(value, (int, float)):
        raise InputError(f"--param {name}: the PROPERTIES do not give {name} by an equality "
                         f"with a number (`{name} = 4.0`)",
                         hint="tune a constant the PROPERTIES set that way, or a number "
                         "written in a guard with --literal OPERATION:VALUE")
    return _made(machine, name, "constant", value, machine.types.get(name) == "INTEGER", lit,
                 name, frozenset())


def _definition(machine, name: str, d) -> Target:
    value = _number_node(d.body) if d.kind == "formula" and not d.params else None
    if value is None or d.body.pos is None:
        raise InputError(f"--param {name}: the definition {name} is not a number",
                         hint=f"numeric ones: {', '.join(numeric_names(machine)) or 'none'}; "
                         f"a number inside it is named with --literal {name}:VALUE")
    spans = frozenset({(d.body.pos.start, d.body.pos.end)})
    return _made(machine, name, "definition", value, isinstance(_plain(d.body), ast.IntLit),
                 d.body, TUNED, spans)


def _plain(node):
    return node.operand if isinstance(node, ast.Neg) else node


def _literal(machine, spec: str) -> Target:
    scope, sep, rest = spec.partition(":")
    want, _, at = rest.partition("@")
    try:
        number = float(want)
    except ValueError:
        number = None
    if not sep or number is None:
        raise InputError(f"--literal {spec}: expected OPERATION:VALUE or DEFINITION:VALUE",
                         hint="e.g. --literal Brake:40.0, with @LINE:COLUMN after the value "
                         "where it is written at several places")
    if scope in machine.operations:
        where = machine.operations[scope].guard
        what = f"the guard of {scope}"
    elif scope in machine.definitions and machine.definitions[scope].kind == "formula":
        where = machine.definitions[scope].body
        what = f"the definition {scope}"
    else:
        raise InputError(f"--literal {spec}: {machine.name} has no operation or definition "
                         f"{scope}", hint="operations: " + ", ".join(machine.operations))
    found: dict[tuple[int, int], ast.Node] = {}
    everything: dict[tuple[int, int], ast.Node] = {}
    for n in _numbers(where):
        everything[(n.pos.start, n.pos.end)] = n
        if _number_node(n) == number:
            found[(n.pos.start, n.pos.end)] = n
    if at:
        found = {k: n for k, n in found.items() if f"{n.pos.line}:{n.pos.column}" == at}
    listing = "; ".join(f"{_text(machine, n)} at {n.pos.line}:{n.pos.column}"
                        for n in sorted(everything.values(), key=lambda n: n.pos.start))
    if not found:
        raise InputError(f"--literal {spec}: {what} has no number {want}"
                         + (f" at {at}" if at else ""),
                         hint=f"the numbers in it: {listing or 'none'}")
    if len(found) > 1:
        places = ", ".join(f"--literal {scope}:{want}@{n.pos.line}:{n.pos.column}"
                           for n in found.values())
        raise InputError(f"--literal {spec}: {want} is written at {len(found)} places in "
                         f"{what}", hint=f"name one: {places}")
    (span, node), = found.items()
    value = _number_node(node)
    return _made(machine, spec, "literal", value, isinstance(_plain(node), ast.IntLit),
                 node, TUNED, frozenset({span}))


def literal_specs(machine, op: str) -> list[str]:
    """A ``--literal`` for each number written in ``op``'s guard (each place once, definitions
    it uses included): ``OP:VALUE@LINE:COLUMN``."""
    seen: dict = {}
    for n in _numbers(machine.operations[op].guard):
        seen.setdefault((n.pos.start, n.pos.end), n)
    return [f"{op}:{_number_node(n)!r}@{n.pos.line}:{n.pos.column}"
            for _, n in sorted(seen.items())]


def _numbers(node) -> list:
    """The numbers written in ``node`` (a negated literal as one), each once."""
    out: list = []

    def walk(n) -> None:
        if n is None:
            return
        if _number_node(n) is not None and n.pos is not None:
            out.append(n)
            if isinstance(n, ast.Neg):
                return
        for c in ast.children(n):
            walk(c)
    walk(node)
    return out


def _text(machine, node) -> str:
    return machine.source[node.pos.start:node.pos.end]


def _made(machine, label, kind, value, integer, node, name, spans) -> Target:
    def is_param(n) -> bool:
        return n.pos is not None and (n.pos.start, n.pos.end) in spans and (
            _number_node(n) is not None)

    if spans and machine.properties_node is not None and _reads(machine.properties_node, is_param):
        raise InputError(f"{label} is read by the PROPERTIES: the constants they give would "
                         "change with it, and tune holds the constants at their values",
                         hint="tune the constant the PROPERTIES compute instead, or a number "
                         "only the guards read")
    guards = {}
    for op_name, op in machine.operations.items():
        if op.guard is None:
            continue
        g = threshold_guard(machine, op.guard, name, is_param) if spans else op.guard
        if name in ast.free_names(g):
            guards[op_name] = g
    if not guards:
        raise InputError(f"{label} is read by no operation's guard: tuning it changes no "
                         "step's feasibility", hint="tune a number a guard reads")
    return Target(label, kind, value, integer, (node.pos.start, node.pos.end), node.pos.line,
                  node.pos.column, name, spans, guards)


def _reads(node, is_param) -> bool:
    """Whether a formula ``is_param`` picks is inside ``node``."""
    return is_param(node) or any(_reads(c, is_param) for c in ast.children(node))


def written(text: str, target: Target, value: float) -> str:
    """The machine's text with ``value`` written in the target's place."""
    start, end = target.span
    return text[:start] + number_text(value, target.integer) + text[end:]


def number_text(value: float, integer: bool) -> str:
    """``value`` as a B literal (a negative one in parentheses; no exponent)."""
    if integer:
        s = str(int(value))
    else:
        v = float(value)
        s = repr(v)
        if "e" in s or "E" in s:
            s = format(Decimal(v), "f")
        if "." not in s:
            s += ".0"
    return f"({s})" if s.startswith("-") else s


def check_range(machine, target: Target, low: float, high: float) -> None:
    """Refuse (exit 2, naming it) a range whose ends make the machine ill-typed, or over
    which its PROPERTIES do not hold, or that is not whole numbers for an INTEGER."""
    from ..b import load_machine_text

    if not (math.isfinite(low) and math.isfinite(high)) or low > high:
        raise InputError(f"{target.label}={low}..{high}: the range must be finite and go up")
    if target.integer and (low != int(low) or high != int(high)):
        raise InputError(f"{target.label}={low}..{high}: {target.label} is an INTEGER; give "
                         "whole numbers")
    if target.kind == "constant" and machine.properties_node is not None:
        _check_properties(machine, target, low, high)
    for value in (low, high):
        try:
            load_machine_text(written(machine.source, target, value), file=machine.file)
        except TracecheckError as exc:
            raise InputError(f"{target.label} = {number_text(value, target.integer)} makes "
                             f"{machine.name} wrong: {exc.message}",
                             hint="give a range the machine is well-typed and its "
                             "PROPERTIES hold over") from None


def _check_properties(machine, target: Target, low: float, high: float) -> None:
    span = Values.half(Fraction(low), True, True).intersect(
        Values.half(Fraction(high), False, True))
    for c in conjuncts(machine.properties_node):
        if target.name not in ast.free_names(c) or _defines(c, target):
            continue
        try:
            holds = values_of(machine, c, target.name, {}, integer=target.integer)
        except UnsupportedError as exc:
            raise InputError(f"{target.label}: tracecheck cannot tell for which values the "
                             f"PROPERTIES hold: {exc.message}") from None
        bad = span.intersect(holds.complement())
        other = _defined(machine, c, target)
        if not bad.empty and other is not None:
            raise InputError(f"{target.label}: the PROPERTIES compute {other} from it "
                             f"(`{_text(machine, c) if c.pos else c}`), and tune holds the "
                             "other constants at their values",
                             hint=f"tune {other}'s own number, or write {target.label}'s value "
                             "where the guards read it")
        if not bad.empty:
            raise InputError(f"{target.label}={low}..{high}: the PROPERTIES are false for "
                             f"{bad.text(target.label)}: `{_text(machine, c) if c.pos else c}`",
                             hint="give a range within which they hold")


def _defined(machine, c, target: Target) -> Optional[str]:
    """The other constant an equality of the PROPERTIES computes (``Lim = X * 2.0``)."""
    if not (isinstance(c, ast.Rel) and c.op == "="):
        return None
    for side in (c.left, c.right):
        if isinstance(side, ast.Name) and side.id != target.name and \
                side.id in machine.constants_declared:
            return side.id
    return None


def _defines(c, target: Target) -> bool:
    return c.pos is not None and any(
        isinstance(side, ast.Node) and side.pos is not None
        and (side.pos.start, side.pos.end) == target.span for side in (c.left, c.right))
