"""Print AST nodes back as ASCII B text; ``parse_formula(to_b(t)) == t`` for any formula."""

from __future__ import annotations

from . import ast as A
from .limits import int_text
from .values import format_real

__all__ = ["to_b"]

_ATOMS = (A.Name, A.IntLit, A.RealLit, A.StrLit, A.BoolLit, A.SetExt, A.Apply, A.Call, A.Template,
          A.Image, A.Inverse, A.Comprehension, A.Lambda, A.QuantExpr, A.Quant, A.IfExpr,
          A.Let)


def _sub(node: A.Node) -> str:
    text = to_b(node)
    return text if isinstance(node, _ATOMS) else f"({text})"


def _ids(ids: tuple[str, ...]) -> str:
    return ids[0] if len(ids) == 1 else "(" + ",".join(ids) + ")"


def to_b(node: A.Node) -> str:  # noqa: C901 - one branch per node type
    """ASCII B text for ``node``, parenthesised so that it parses back to the same tree."""
    t = type(node)
    if t is A.Name:
        return node.id
    if t is A.IntLit:
        return int_text(node.value)
    if t is A.RealLit:
        return format_real(node.value)
    if t is A.StrLit:
        return '"' + node.value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if t is A.BoolLit:
        return "TRUE" if node.value else "FALSE"
    if t is A.BinOp and node.op == ";":
        return f"({_sub(node.left)} ; {_sub(node.right)})"
    if t is A.Template:
        parts = [node.texts[0]]
        for fmt, hole, text in zip(node.formats, node.holes, node.texts[1:]):
            parts.append(("$[" + fmt + "]{" if fmt else "${") + to_b(hole) + "}" + text)
        return "```" + "".join(parts) + "```"
    if t is A.BinOp:
        op = f" {node.op} " if node.op.isalpha() else node.op
        return f"{_sub(node.left)}{op}{_sub(node.right)}"
    if t is A.Neg:
        return f"-{_sub(node.operand)}"
    if t is A.Apply:
        return f"{_sub(node.fn)}({','.join(to_b(a) for a in node.args)})"
    if t is A.Call:
        return f"{node.name}({','.join(to_b(a) for a in node.args)})"
    if t is A.Image:
        return f"{_sub(node.rel)}[{to_b(node.arg)}]"
    if t is A.Inverse:
        return f"{_sub(node.rel)}~"
    if t is A.SetExt:
        return "{" + ",".join(to_b(i) for i in node.items) + "}"
    if t is A.Pair:
        return f"{_sub(node.left)}|->{_sub(node.right)}"
    if t is A.Comprehension:
        if node.expr is None:
            return "{" + ",".join(node.ids) + "|" + to_b(node.pred) + "}"
        return "{" + ",".join(node.ids) + "." + to_b(node.pred) + "|" + to_b(node.expr) + "}"
    if t is A.Lambda:
        return f"%{_ids(node.ids)}.({to_b(node.pred)}|{to_b(node.expr)})"
    if t is A.QuantExpr:
        return f"{node.op}({','.join(node.ids)}).({to_b(node.pred)}|{to_b(node.expr)})"
    if t is A.IfExpr:
        (c, v), *rest = node.branches
        text = f"IF {to_b(c)} THEN {to_b(v)}"
        for c, v in rest:
            text += f" ELSIF {to_b(c)} THEN {to_b(v)}"
        return text + f" ELSE {to_b(node.else_)} END"
    if t is A.Let:
        return f"LET {','.join(node.ids)} BE {to_b(node.pred)} IN {to_b(node.body)} END"
    if t in (A.And, A.Or, A.Implies, A.Equiv):
        op = {A.And: "&", A.Or: "or", A.Implies: "=>", A.Equiv: "<=>"}[t]
        return f"{_sub(node.left)} {op} {_sub(node.right)}"
    if t is A.Not:
        return f"not({to_b(node.operand)})"
    if t is A.Rel:
        return f"{_sub(node.left)} {node.op} {_sub(node.right)}"
    if t is A.Quant:
        return f"{node.op}{_ids(node.ids)}.({to_b(node.body)})"
    return _subst(node)


def _subst(node: A.Node) -> str:  # noqa: C901
    t = type(node)
    if t is A.Skip:
        return "skip"
    if t is A.Assign:
        return f"{','.join(to_b(x) for x in node.targets)} := " \
               f"{','.join(to_b(v) for v in node.values)}"
    if t is A.BecomesIn:
        return f"{','.join(node.ids)} :: {to_b(node.set)}"
    if t is A.BecomesSuchThat:
        return f"{','.join(node.ids)} : ({to_b(node.pred)})"
    if t is A.Parallel:
        return " || ".join(_block(i) for i in node.items)
    if t is A.Sequence:
        return " ; ".join(_block(i) for i in node.items)
    if t is A.Pre:
        return f"PRE {to_b(node.guard)} THEN {to_b(node.body)} END"
    if t is A.Assert:
        return f"ASSERT {to_b(node.cond)} THEN {to_b(node.body)} END"
    if t in (A.Select, A.IfSubst):
        kw, sep = ("SELECT", "WHEN") if t is A.Select else ("IF", "ELSIF")
        (c, b), *rest = node.branches
        text = f"{kw} {to_b(c)} THEN {to_b(b)}"
        for c, b in rest:
            text += f" {sep} {to_b(c)} THEN {to_b(b)}"
        if node.else_ is not None:
            text += f" ELSE {to_b(node.else_)}"
        return text + " END"
    if t is A.Any:
        return f"ANY {','.join(node.ids)} WHERE {to_b(node.pred)} THEN {to_b(node.body)} END"
    if t is A.LetSubst:
        return f"LET {','.join(node.ids)} BE {to_b(node.pred)} IN {to_b(node.body)} END"
    if t is A.Choice:
        return "CHOICE " + " OR ".join(to_b(i) for i in node.items) + " END"
    if t is A.SubstRef:
        args = f"({','.join(to_b(a) for a in node.args)})" if node.args else ""
        return node.name.id + args
    raise TypeError(f"cannot print {t.__name__}")


def _block(node: A.Node) -> str:
    text = to_b(node)
    return f"BEGIN {text} END" if isinstance(node, (A.Parallel, A.Sequence)) else text
