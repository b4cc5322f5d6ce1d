"""Frozen AST for B formulas, substitutions and machines.

Nodes compare by structure; source positions ride along (``pos``) but are left out of
equality, so ``parse(print(t)) == t`` holds whatever the layout.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

__all__ = [
    "Pos", "Node", "Name", "IntLit", "RealLit", "StrLit", "BoolLit", "BinOp", "Neg",
    "Apply", "Call", "Image", "Inverse", "SetExt", "Template", "Pair", "Comprehension", "Lambda",
    "QuantExpr", "IfExpr", "Let", "Record", "Struct", "Field", "And", "Or", "Implies", "Equiv",
    "Not", "Rel", "Quant",
    "Subst", "Skip", "Assign", "BecomesIn", "BecomesSuchThat", "Parallel", "Sequence",
    "Pre", "Assert", "Select", "Any", "IfSubst", "LetSubst", "Choice", "VarSubst", "While", "SubstRef", "BUILTIN_FUNCTIONS",
    "BUILTIN_SETS", "children", "depth", "pair_of", "map_children", "binders", "free_names",
    "described", "conjuncts", "membership_of",
]

#: Names that are functions of the language itself, applied as ``name(args)``.
BUILTIN_FUNCTIONS = frozenset({
    "card", "dom", "ran", "min", "max", "POW", "POW1", "FIN", "FIN1", "bool", "floor",
    "ceiling", "real", "RSQRT", "RABS", "union", "inter", "id", "prj1", "prj2", "closure",
    "closure1", "succ", "pred", "abs", "size", "first", "last", "front", "tail", "rev",
    "seq", "seq1", "iseq", "iseq1", "perm", "conc", "iterate", "fnc", "rel",
})

#: Names of the built-in sets.
BUILTIN_SETS = frozenset({
    "BOOL", "INTEGER", "NATURAL", "NATURAL1", "INT", "NAT", "NAT1", "REAL", "FLOAT",
    "STRING", "MAXINT", "MININT",
})


@dataclass(frozen=True, slots=True)
class Pos:
    """Where a node starts and ends in its source (lines and columns 1-based)."""

    line: int
    column: int
    end_line: int
    end_column: int
    start: int = 0
    end: int = 0

    def point(self) -> "Pos":
        """Where this starts, covering no text: the place of a node tracecheck builds (its
        errors point here; it prints as B, not as this text)."""
        return Pos(self.line, self.column, self.line, self.column, self.start, self.start)


@dataclass(frozen=True, slots=True)
class Node:
    pos: Optional[Pos] = field(default=None, compare=False, repr=False, kw_only=True)


# ------------------------------------------------------------------ expressions


@dataclass(frozen=True, slots=True)
class Name(Node):
    id: str


@dataclass(frozen=True, slots=True)
class IntLit(Node):
    value: int


@dataclass(frozen=True, slots=True)
class RealLit(Node):
    value: float


@dataclass(frozen=True, slots=True)
class StrLit(Node):
    value: str


@dataclass(frozen=True, slots=True)
class BoolLit(Node):
    value: bool


@dataclass(frozen=True, slots=True)
class BinOp(Node):
    """Binary expression operator, ``op`` in canonical ASCII (``+``, ``|->``, ``-->`` …)."""

    op: str
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Neg(Node):
    operand: Node


@dataclass(frozen=True, slots=True)
class Apply(Node):
    """``f(a, b)``: function application, or a use of a definition with parameters."""

    fn: Node
    args: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Call(Node):
    """A built-in function of the language: ``card(S)``, ``RSQRT(x)``."""

    name: str
    args: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Image(Node):
    rel: Node
    arg: Node


@dataclass(frozen=True, slots=True)
class Inverse(Node):
    rel: Node


@dataclass(frozen=True, slots=True)
class SetExt(Node):
    items: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Template(Node):
    """ProB's template string ```x = ${x}, y = $[2f]{y}```: text with formatted holes.

    ``texts`` has one more item than ``holes``; each hole is (format options, expression).
    """

    texts: tuple[str, ...]
    formats: tuple[str, ...]
    holes: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Pair(Node):
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Comprehension(Node):
    """``{x, y | P}`` (``expr`` is None) or ``{x . P | E}``."""

    ids: tuple[str, ...]
    pred: Node
    expr: Optional[Node] = None


@dataclass(frozen=True, slots=True)
class Lambda(Node):
    ids: tuple[str, ...]
    pred: Node
    expr: Node


@dataclass(frozen=True, slots=True)
class QuantExpr(Node):
    """``SIGMA``, ``PI``, ``UNION`` or ``INTER`` over ``ids`` with ``pred``, of ``expr``."""

    op: str
    ids: tuple[str, ...]
    pred: Node
    expr: Node


@dataclass(frozen=True, slots=True)
class IfExpr(Node):
    """``IF c1 THEN e1 ELSIF c2 THEN e2 ELSE e3 END`` as an expression or predicate."""

    branches: tuple[tuple[Node, Node], ...]
    else_: Node


@dataclass(frozen=True, slots=True)
class Let(Node):
    """``LET x BE x = E IN F END`` as an expression or predicate."""

    ids: tuple[str, ...]
    pred: Node
    body: Node


@dataclass(frozen=True, slots=True)
class Record(Node):
    """``rec(a: 1, b: TRUE)``: the fields in the order written (the value sorts them)."""

    fields: tuple[tuple[str, Node], ...]


@dataclass(frozen=True, slots=True)
class Struct(Node):
    """``struct(a: INTEGER, b: BOOL)``: the set of records whose fields lie in those sets."""

    fields: tuple[tuple[str, Node], ...]


@dataclass(frozen=True, slots=True)
class Field(Node):
    """``r'a``: the field ``a`` of the record ``r``."""

    record: Node
    name: str


# ------------------------------------------------------------------ predicates


@dataclass(frozen=True, slots=True)
class And(Node):
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Or(Node):
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Implies(Node):
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Equiv(Node):
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Not(Node):
    operand: Node


@dataclass(frozen=True, slots=True)
class Rel(Node):
    """Comparison or membership, ``op`` one of ``= /= < <= > >= : /: <: <<: /<: /<<:``."""

    op: str
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Quant(Node):
    """``!ids.(body)`` (op ``!``) or ``#ids.(body)`` (op ``#``)."""

    op: str
    ids: tuple[str, ...]
    body: Node


# ------------------------------------------------------------------ substitutions


@dataclass(frozen=True, slots=True)
class Subst(Node):
    pass


@dataclass(frozen=True, slots=True)
class Skip(Subst):
    pass


@dataclass(frozen=True, slots=True)
class Assign(Subst):
    """``x, f(a) := E, F``; targets are ``Name`` or ``Apply(Name, args)``."""

    targets: tuple[Node, ...]
    values: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class BecomesIn(Subst):
    ids: tuple[str, ...]
    set: Node


@dataclass(frozen=True, slots=True)
class BecomesSuchThat(Subst):
    """``x : (P)``; in P, ``x`` is the new value and ``x'`` or ``x$0`` the old one."""

    ids: tuple[str, ...]
    pred: Node


@dataclass(frozen=True, slots=True)
class Parallel(Subst):
    items: tuple[Subst, ...]


@dataclass(frozen=True, slots=True)
class Sequence(Subst):
    items: tuple[Subst, ...]


@dataclass(frozen=True, slots=True)
class Pre(Subst):
    guard: Node
    body: Subst


@dataclass(frozen=True, slots=True)
class Assert(Subst):
    cond: Node
    body: Subst


@dataclass(frozen=True, slots=True)
class Select(Subst):
    branches: tuple[tuple[Node, Subst], ...]
    else_: Optional[Subst] = None


@dataclass(frozen=True, slots=True)
class Any(Subst):
    ids: tuple[str, ...]
    pred: Node
    body: Subst


@dataclass(frozen=True, slots=True)
class IfSubst(Subst):
    branches: tuple[tuple[Node, Subst], ...]
    else_: Optional[Subst] = None


@dataclass(frozen=True, slots=True)
class LetSubst(Subst):
    ids: tuple[str, ...]
    pred: Node
    body: Subst


@dataclass(frozen=True, slots=True)
class SubstRef(Subst):
    """A substitution written as a name: a use of a substitution definition."""

    name: "Name"
    args: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Choice(Subst):
    items: tuple[Subst, ...]


@dataclass(frozen=True, slots=True)
class VarSubst(Subst):
    """``VAR x, y IN S END``: local variables, without a value until S assigns them."""

    ids: tuple[str, ...]
    body: Subst


@dataclass(frozen=True, slots=True)
class While(Subst):
    """``WHILE P DO S INVARIANT I VARIANT V END``."""

    cond: Node
    body: Subst
    invariant: Node
    variant: Node


def pair_of(args: tuple[Node, ...]) -> Node:
    """``a |-> b |-> …`` of the nodes ``args`` (left-nested pairs, as B writes f(a, b))."""
    node = args[0]
    for a in args[1:]:
        node = Pair(node, a, pos=a.pos)
    return node


def depth(node: Node) -> int:
    """How many levels ``node`` nests (1 for a leaf), counted without recursing."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        node, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in children(node))
    return deepest


def children(node: Node) -> list[Node]:
    """The direct sub-nodes of ``node``, in source order."""
    out: list[Node] = []
    for name in node.__dataclass_fields__:
        if name == "pos":
            continue
        _collect(getattr(node, name), out)
    return out


def _collect(value: object, out: list[Node]) -> None:
    if isinstance(value, Node):
        out.append(value)
    elif isinstance(value, tuple):
        for item in value:
            _collect(item, out)


def map_children(node: Node, fn) -> Node:
    """A copy of ``node`` with ``fn`` applied to each direct sub-node (position kept)."""
    changes = {}
    for name in node.__dataclass_fields__:
        if name == "pos":
            continue
        value = getattr(node, name)
        new = _map_value(value, fn)
        if new is not value:
            changes[name] = new
    if not changes:
        return node
    import dataclasses

    return dataclasses.replace(node, **changes)


def _map_value(value, fn):
    if isinstance(value, Node):
        return fn(value)
    if isinstance(value, tuple):
        items = tuple(_map_value(v, fn) for v in value)
        return items if any(a is not b for a, b in zip(items, value)) else value
    return value


def binders(node: Node) -> tuple[str, ...]:
    """The names that ``node`` binds for its sub-formulas (quantified variables)."""
    return getattr(node, "ids", ()) if isinstance(
        node, (Quant, Comprehension, Lambda, QuantExpr, Let, Any, LetSubst)
    ) else ()


def free_names(node: Node, cache: Optional[dict] = None) -> frozenset[str]:
    """Names used in ``node`` and not bound inside it (``cache``: results by node identity,
    shared between calls on the sub-nodes of one formula, so a walk over a formula that asks
    at every node stays linear)."""
    if isinstance(node, Name):
        return frozenset({node.id})
    if cache is not None:
        hit = cache.get(id(node))
        if hit is not None and hit[0] is node:
            return hit[1]
    inner: set[str] = set()
    for child in children(node):
        inner |= free_names(child, cache)
    if isinstance(node, SubstRef):
        inner.add(node.name.id)
    names = frozenset(inner - set(binders(node)))
    if cache is not None:
        cache[id(node)] = (node, names)  # the node is kept, so its id stays its own
    return names


_DESCRIBED = {"Quant": "a quantifier (! or #)", "Comprehension": "a set comprehension",
              "QuantExpr": "a SIGMA, PI, UNION or INTER", "Lambda": "a lambda",
              "Apply": "a function applied", "IfExpr": "an IF … THEN … ELSE … END"}


def described(node: Node) -> str:
    """What a message calls ``node``'s kind of formula (the user's words, not the class's):
    ``a quantifier (! or #)``."""
    name = type(node).__name__
    return _DESCRIBED.get(name, f"a {name}")


def conjuncts(node: Node) -> list[Node]:
    """The conjuncts of ``node`` (itself where it is not ``&``), left to right."""
    if isinstance(node, And):
        return conjuncts(node.left) + conjuncts(node.right)
    return [node]


def membership_of(pred: Node, var: str) -> Optional[Rel]:
    """The conjunct ``var : S`` of ``pred`` that gives ``var`` its values."""
    return next((c for c in conjuncts(pred) if isinstance(c, Rel) and c.op == ":"
                 and isinstance(c.left, Name) and c.left.id == var
                 and var not in free_names(c.right)), None)
