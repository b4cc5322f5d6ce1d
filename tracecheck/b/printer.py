"""Print AST nodes back as ASCII B text; ``parse_formula(to_b(t)) == t`` for any formula."""

from __future__ import annotations

from . import ast
from ..limits import deep_recursion, int_text
from .names import name_text
from .values import format_real

__all__ = ["to_b", "name_text"]

_ATOMS = (ast.Name, ast.IntLit, ast.RealLit, ast.StrLit, ast.BoolLit, ast.SetExt, ast.Apply,
          ast.Call, ast.Template, ast.Image, ast.Inverse, ast.Comprehension, ast.Lambda,
          ast.QuantExpr, ast.Quant, ast.IfExpr, ast.Let, ast.Record, ast.Struct, ast.Field)


def _sub(node: ast.Node) -> str:
    text = _text(node)
    return text if isinstance(node, _ATOMS) else f"({text})"


def _ids(ids: tuple[str, ...]) -> str:
    return name_text(ids[0]) if len(ids) == 1 else "(" + ",".join(map(name_text, ids)) + ")"


def to_b(node: ast.Node) -> str:
    """ASCII B text for ``node``, parenthesised so that it parses back to the same tree (as
    deeply nested as the parser reads: the recursion limit is raised while it prints).

    Args:
        node: a syntax tree.

    Returns:
        Its B text.

    >>> from tracecheck.b.parser import parse_formula
    >>> to_b(parse_formula("x+1>2"))
    '(x+1) > 2'
    """
    with deep_recursion():
        return _text(node)


def _text(node: ast.Node) -> str:  # noqa: C901 - one branch per node type
    t = type(node)
    if t is ast.Name:
        return name_text(node.id)
    if t in (ast.Record, ast.Struct):
        fields = ",".join(f"{name_text(n)}:{_text(v)}" for n, v in node.fields)
        return f"{'rec' if t is ast.Record else 'struct'}({fields})"
    if t is ast.Field:
        return f"{_sub(node.record)}'{name_text(node.name)}"
    if t is ast.IntLit:
        return int_text(node.value)
    if t is ast.RealLit:
        return format_real(node.value)
    if t is ast.StrLit:
        return '"' + node.value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if t is ast.BoolLit:
        return "TRUE" if node.value else "FALSE"
    if t is ast.BinOp and node.op in (";", "||"):
        return f"({_sub(node.left)} {node.op} {_sub(node.right)})"
    if t is ast.Template:
        parts = [node.texts[0]]
        for fmt, hole, text in zip(node.formats, node.holes, node.texts[1:]):
            parts.append(("$[" + fmt + "]{" if fmt else "${") + _text(hole) + "}" + text)
        return "```" + "".join(parts) + "```"
    if t is ast.BinOp:
        op = f" {node.op} " if node.op.isalpha() else node.op
        return f"{_sub(node.left)}{op}{_sub(node.right)}"
    if t is ast.Neg:
        return f"-{_sub(node.operand)}"
    if t is ast.Apply:
        return f"{_sub(node.fn)}({','.join(_text(a) for a in node.args)})"
    if t is ast.Call:
        return f"{node.name}({','.join(_text(a) for a in node.args)})"
    if t is ast.Image:
        return f"{_sub(node.rel)}[{_text(node.arg)}]"
    if t is ast.Inverse:
        return f"{_sub(node.rel)}~"
    if t is ast.SetExt:
        return "{" + ",".join(_text(i) for i in node.items) + "}"
    if t is ast.Pair:
        return f"{_sub(node.left)}|->{_sub(node.right)}"
    if t is ast.Comprehension:
        if node.expr is None:
            return "{" + ",".join(map(name_text, node.ids)) + "|" + _text(node.pred) + "}"
        return "{" + ",".join(map(name_text, node.ids)) + "." + _text(node.pred) + "|" + _text(node.expr) + "}"
    if t is ast.Lambda:
        return f"%{_ids(node.ids)}.({_text(node.pred)}|{_text(node.expr)})"
    if t is ast.QuantExpr:
        return f"{node.op}({','.join(map(name_text, node.ids))}).({_text(node.pred)}|{_text(node.expr)})"
    if t is ast.IfExpr:
        (c, v), *rest = node.branches
        text = f"IF {_text(c)} THEN {_text(v)}"
        for c, v in rest:
            text += f" ELSIF {_text(c)} THEN {_text(v)}"
        return text + f" ELSE {_text(node.else_)} END"
    if t in (ast.Let, ast.LetSubst):
        return f"LET {','.join(map(name_text, node.ids))} BE {_text(node.pred)} IN {_text(node.body)} END"
    if t in (ast.And, ast.Or, ast.Implies, ast.Equiv):
        op = {ast.And: "&", ast.Or: "or", ast.Implies: "=>", ast.Equiv: "<=>"}[t]
        return f"{_sub(node.left)} {op} {_sub(node.right)}"
    if t is ast.Not:
        return f"not({_text(node.operand)})"
    if t is ast.Rel:
        return f"{_sub(node.left)} {node.op} {_sub(node.right)}"
    if t is ast.Quant:
        return f"{node.op}{_ids(node.ids)}.({_text(node.body)})"
    return _subst(node)


def _subst(node: ast.Node) -> str:  # noqa: C901
    t = type(node)
    if t is ast.Skip:
        return "skip"
    if t is ast.Assign:
        return f"{','.join(_text(x) for x in node.targets)} := " \
               f"{','.join(_text(v) for v in node.values)}"
    if t is ast.BecomesIn:
        return f"{','.join(map(name_text, node.ids))} :: {_text(node.set)}"
    if t is ast.BecomesSuchThat:
        return f"{','.join(map(name_text, node.ids))} : ({_text(node.pred)})"
    if t is ast.Parallel:
        return " || ".join(_block(i) for i in node.items)
    if t is ast.Sequence:
        return " ; ".join(_block(i) for i in node.items)
    if t is ast.Pre:
        return f"PRE {_text(node.guard)} THEN {_text(node.body)} END"
    if t is ast.Assert:
        return f"ASSERT {_text(node.cond)} THEN {_text(node.body)} END"
    if t in (ast.Select, ast.IfSubst):
        kw, sep = ("SELECT", "WHEN") if t is ast.Select else ("IF", "ELSIF")
        (c, b), *rest = node.branches
        text = f"{kw} {_text(c)} THEN {_text(b)}"
        for c, b in rest:
            text += f" {sep} {_text(c)} THEN {_text(b)}"
        if node.else_ is not None:
            text += f" ELSE {_text(node.else_)}"
        return text + " END"
    if t is ast.Any:
        return f"ANY {','.join(map(name_text, node.ids))} WHERE {_text(node.pred)} THEN {_text(node.body)} END"
    if t is ast.Choice:
        return "CHOICE " + " OR ".join(_text(i) for i in node.items) + " END"
    if t is ast.VarSubst:
        return f"VAR {','.join(map(name_text, node.ids))} IN {_text(node.body)} END"
    if t is ast.While:
        return (f"WHILE {_text(node.cond)} DO {_text(node.body)} INVARIANT "
                f"{_text(node.invariant)} VARIANT {_text(node.variant)} END")
    if t is ast.SubstRef:
        args = f"({','.join(_text(a) for a in node.args)})" if node.args else ""
        return node.name.id + args
    raise TypeError(f"cannot print {t.__name__}")


def _block(node: ast.Node) -> str:
    text = _text(node)
    return f"BEGIN {text} END" if isinstance(node, (ast.Parallel, ast.Sequence)) else text
