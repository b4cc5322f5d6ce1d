"""Definitions, names and kinds: what happens between parsing and evaluation.

* :func:`expand` replaces every use of a definition by its body (B definitions are macros),
  with the arguments put in for the parameters.
* :func:`check_kind` makes sure predicates stand where predicates belong and expressions
  where expressions belong, with a located message otherwise.
"""

from __future__ import annotations

from typing import Mapping, Optional

from ..errors import (BScopeError, BSyntaxError, BTypeError, JoinedText, TracecheckError,
                      UnsupportedError)
from . import ast
from .parser import Definition

__all__ = ["expand", "expand_subst", "check_kind", "check_subst", "kind_of", "render"]

PRED, EXPR = "predicate", "expression"


def render(node: ast.Node, source: Optional[str]) -> str:
    """The source text of ``node`` (or its printed form when no source is known)."""
    if source is not None and node.pos is not None and node.pos.end > node.pos.start and \
            not _across_files(source, node.pos):
        text = source[node.pos.start:node.pos.end]
        return " ".join(text.split())
    from .printer import to_b

    return to_b(node)


def _across_files(source: str, pos: ast.Pos) -> bool:
    """Whether ``pos`` spans two files of a machine made of several (a parameter's value
    put into the included machine's text): its text is then printed, not cut out."""
    return isinstance(source, JoinedText) and \
        source.where(pos.line)[0] != source.where(pos.end_line)[0]


def _located(exc: TracecheckError, node: ast.Node) -> TracecheckError:
    if exc.line is None and node.pos is not None:
        exc.line, exc.column = node.pos.line, node.pos.column
    return exc


class _Expander:
    def __init__(self, defs: Mapping[str, Definition]) -> None:
        self.defs = defs
        self.stack: list[str] = []

    def definition(self, name: str, node: ast.Node) -> Definition:
        d = self.defs[name]
        if d.kind == "unparsed":
            err = d.body
            if isinstance(err, UnsupportedError):  # an external function, see the parser
                raise UnsupportedError(err.message, hint=err.hint)
            raise BSyntaxError(f"the definition {name} is used but could not be parsed: "
                               f"{err.message}", line=err.line, column=err.column)
        if name in self.stack:
            cycle = " -> ".join(self.stack[self.stack.index(name):] + [name])
            raise _located(BScopeError(f"the definitions are cyclic: {cycle}"), node)
        return d

    def body_with(self, d: Definition, args: tuple[ast.Node, ...], node: ast.Node) -> ast.Node:
        if len(args) != len(d.params):
            raise _located(BScopeError(
                f"the definition {d.name} takes {len(d.params)} argument(s) "
                f"({', '.join(d.params) or 'none'}) but is given {len(args)}"), node)
        if d.kind == "string":
            return ast.StrLit(d.body, pos=node.pos)
        body = d.body
        if d.params:
            body = _substitute(body, dict(zip(d.params, args)))
        self.stack.append(d.name)
        try:
            return self.expr(body, frozenset())
        finally:
            self.stack.pop()

    def expr(self, node: ast.Node, bound: frozenset[str]) -> ast.Node:
        if isinstance(node, ast.Name) and node.id in self.defs and node.id not in bound:
            d = self.definition(node.id, node)
            if d.params:
                raise _located(BScopeError(
                    f"the definition {d.name} needs {len(d.params)} argument(s): "
                    f"{d.name}({', '.join(d.params)})"), node)
            return self.body_with(d, (), node)
        if (isinstance(node, ast.Apply) and isinstance(node.fn, ast.Name)
                and node.fn.id in self.defs and node.fn.id not in bound):
            d = self.definition(node.fn.id, node)
            args = tuple(self.expr(a, bound) for a in node.args)
            if not d.params:
                return ast.Apply(self.body_with(d, (), node.fn), args, pos=node.pos)
            return self.body_with(d, args, node)
        if isinstance(node, ast.SubstRef):
            name = node.name.id
            if name not in self.defs or name in bound:
                raise _located(BScopeError(
                    f"{name} is not a substitution definition; to assign, write "
                    f"{name} := value"), node)
            d = self.definition(name, node)
            if d.kind != "substitution":
                raise _located(BTypeError(
                    f"the definition {name} is a {d.kind}, not a substitution"), node)
            args = tuple(self.expr(a, bound) for a in node.args)
            return self.body_with(d, args, node)
        inner = bound | frozenset(ast.binders(node))
        return ast.map_children(node, lambda child: self.expr(child, inner))


def _substitute(node: ast.Node, mapping: dict[str, ast.Node]) -> ast.Node:
    if isinstance(node, ast.Name) and node.id in mapping:
        return mapping[node.id]
    names = set(ast.binders(node))
    if names & mapping.keys():
        mapping = {k: v for k, v in mapping.items() if k not in names}
        if not mapping:
            return node
    return ast.map_children(node, lambda child: _substitute(child, mapping))


def expand(node: ast.Node, defs: Mapping[str, Definition]) -> ast.Node:
    """``node`` with every use of a definition replaced by the definition's body."""
    if not defs:
        return node
    return _Expander(defs).expr(node, frozenset())


expand_subst = expand


# ------------------------------------------------------------------ kinds

_PRED_NODES = (ast.And, ast.Or, ast.Implies, ast.Equiv, ast.Not, ast.Rel, ast.Quant)


def kind_of(node: ast.Node) -> str:
    """``"predicate"`` or ``"expression"``."""
    if isinstance(node, _PRED_NODES):
        return PRED
    if isinstance(node, ast.IfExpr):
        return kind_of(node.branches[0][1])
    if isinstance(node, ast.Let):
        return kind_of(node.body)
    return EXPR


def _require(node: ast.Node, kind: str, source: Optional[str], context: str) -> None:
    found = kind_of(node)
    if found != kind:
        text = render(node, source)
        hint = None
        if kind == PRED and found == EXPR:
            hint = "compare it, e.g. x = TRUE, or use a predicate definition"
        elif kind == EXPR and found == PRED:
            hint = "to use a predicate as a value write bool(...)"
        raise _located(BTypeError(f"{context} must be a {kind}, but `{text}` is an {found}"
                                  if found == EXPR else
                                  f"{context} must be an {kind}, but `{text}` is a {found}",
                                  hint=hint), node)


_CHILD_KINDS = {
    ast.And: (PRED, PRED), ast.Or: (PRED, PRED), ast.Implies: (PRED, PRED),
    ast.Equiv: (PRED, PRED), ast.Not: (PRED,), ast.Rel: (EXPR, EXPR), ast.BinOp: (EXPR, EXPR),
    ast.Neg: (EXPR,), ast.Image: (EXPR, EXPR), ast.Inverse: (EXPR,), ast.Pair: (EXPR, EXPR),
}


def check_kind(node: ast.Node, kind: str = PRED, *, source: Optional[str] = None,
               context: str = "this formula") -> None:
    """Raise :class:`BTypeError` where a predicate and an expression are mixed up."""
    _require(node, kind, source, context)
    _check_children(node, source)


def _check_children(node: ast.Node, source: Optional[str]) -> None:
    def req(child: ast.Node, kind: str, context: str) -> None:
        check_kind(child, kind, source=source, context=context)

    t = type(node)
    if t in _CHILD_KINDS:
        for child, kind in zip(ast.children(node), _CHILD_KINDS[t]):
            req(child, kind, f"each operand of {_op_name(node)}")
    elif isinstance(node, ast.Quant):
        req(node.body, PRED, "the body of a quantifier")
    elif isinstance(node, (ast.Comprehension, ast.Lambda, ast.QuantExpr)):
        req(node.pred, PRED, "the condition after the bound variables")
        if node.expr is not None:
            req(node.expr, EXPR, "the value of a comprehension")
    elif isinstance(node, ast.Apply):
        req(node.fn, EXPR, "a function")
        for a in node.args:
            req(a, EXPR, "a function argument")
    elif isinstance(node, ast.Call):
        want = PRED if node.name == "bool" else EXPR
        for a in node.args:
            req(a, want, f"the argument of {node.name}")
    elif isinstance(node, ast.SetExt):
        for a in node.items:
            req(a, EXPR, "a set element")
    elif isinstance(node, ast.Template):
        for a in node.holes:
            req(a, EXPR, "a template hole")
    elif isinstance(node, (ast.Record, ast.Struct, ast.Field)):
        for a in ast.children(node):
            req(a, EXPR, "a record" if isinstance(node, ast.Field) else "a record field")
    elif isinstance(node, ast.IfExpr):
        kind = kind_of(node)
        for cond, value in node.branches:
            req(cond, PRED, "an IF condition")
            req(value, kind, "each branch of IF")
        req(node.else_, kind, "each branch of IF")
    elif isinstance(node, ast.Let):
        req(node.pred, PRED, "the LET condition")
        req(node.body, kind_of(node), "the LET body")


def _op_name(node: ast.Node) -> str:
    op = getattr(node, "op", None)
    names = {ast.And: "&", ast.Or: "or", ast.Implies: "=>", ast.Equiv: "<=>", ast.Not: "not",
             ast.Neg: "unary -", ast.Image: "relational image", ast.Inverse: "~", ast.Pair: "|->"}
    return f"'{op}'" if op else names.get(type(node), type(node).__name__)


def check_subst(subst: ast.Subst, *, source: Optional[str] = None) -> None:
    """Check the kinds of every formula inside a substitution."""
    if isinstance(subst, ast.Assign):
        for t in subst.targets:
            if isinstance(t, ast.Apply):
                for a in t.args:
                    check_kind(a, EXPR, source=source, context="a function argument")
        for v in subst.values:
            check_kind(v, EXPR, source=source, context="an assigned value")
    elif isinstance(subst, ast.BecomesIn):
        check_kind(subst.set, EXPR, source=source, context="the set after '::'")
    elif isinstance(subst, ast.BecomesSuchThat):
        check_kind(subst.pred, PRED, source=source, context="the condition of ': (P)'")
    elif isinstance(subst, (ast.Pre, ast.Assert)):
        check_kind(subst.guard if isinstance(subst, ast.Pre) else subst.cond, PRED,
                   source=source, context="a guard")
        check_subst(subst.body, source=source)
    elif isinstance(subst, (ast.Select, ast.IfSubst)):
        for cond, body in subst.branches:
            check_kind(cond, PRED, source=source, context="a guard")
            check_subst(body, source=source)
        if subst.else_ is not None:
            check_subst(subst.else_, source=source)
    elif isinstance(subst, (ast.Any, ast.LetSubst)):
        check_kind(subst.pred, PRED, source=source, context="the WHERE/BE condition")
        check_subst(subst.body, source=source)
    elif isinstance(subst, (ast.Parallel, ast.Sequence, ast.Choice)):
        for item in subst.items:
            check_subst(item, source=source)
    elif isinstance(subst, ast.VarSubst):
        check_subst(subst.body, source=source)
    elif isinstance(subst, ast.SubstRef):  # left after the definitions were expanded
        raise BScopeError(f"unknown operation or substitution {subst.name.id}: neither an "
                          "operation of an included machine nor a substitution definition",
                          source=source, line=subst.pos.line if subst.pos else None,
                          column=subst.pos.column if subst.pos else None,
                          hint="an included machine's operation is called by its name, "
                               "renamed r.Op for INCLUDES r.M")
    elif isinstance(subst, ast.While):
        check_kind(subst.cond, PRED, source=source, context="the WHILE condition")
        check_kind(subst.invariant, PRED, source=source, context="a loop's INVARIANT")
        check_kind(subst.variant, EXPR, source=source, context="a loop's VARIANT")
        check_subst(subst.body, source=source)
