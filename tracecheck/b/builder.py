"""Lark's parse tree to tracecheck's frozen AST (:mod:`tracecheck.b.ast`).

The :class:`Builder` only builds nodes; it checks nothing the grammar cannot say but that
binder lists are names (semantic checks live in scope and typecheck).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable, Optional

from lark import Token, Transformer, v_args

from ..errors import BSyntaxError
from . import ast
from ..limits import read_int
from .notation import ESCAPES as _ESCAPES, unescape

__all__ = ["Builder", "OperationSource", "tok_pos", "unquote", "ident"]


@dataclass(frozen=True)
class OperationSource:
    name: str
    params: tuple[str, ...]
    outputs: tuple[str, ...]
    body: ast.Subst
    pos: Optional[ast.Pos] = None


def unquote(s: str) -> str:
    """The text of a string literal: ``\\"``, ``\\\\``, ``\\n``, ``\\t``, ``\\r`` and ``\\'``
    are escapes, as in ProB; any other backslash is kept (``"a /\\ b"`` keeps its ``/\\``)."""
    return unescape(s[1:-1])


_ID_ESCAPES = {**_ESCAPES, "`": "`"}


def ident(tok) -> str:
    """The identifier a NAME token stands for: ```my name``` (ProB's back-quoted identifier,
    with ``\\``` and ``\\\\`` escapes) is ``my name``, so ```x``` and ``x`` are one name."""
    text = str(tok)
    if not text.startswith("`"):
        return text
    return re.sub(r"\\(.)", lambda m: _ID_ESCAPES.get(m.group(1), m.group(0)), text[1:-1])


def tok_pos(tok: Token) -> ast.Pos:
    return ast.Pos(tok.line, tok.column, tok.end_line, tok.end_column, tok.start_pos, tok.end_pos)


_OPS = {
    "EQ": "=", "NEQ": "/=", "LT": "<", "LE": "<=", "GT": ">", "GE": ">=", "IN": ":",
    "NOTIN": "/:", "SUBSET": "<:", "STRICT_SUBSET": "<<:", "NOT_SUBSET": "/<:",
    "NOT_STRICT_SUBSET": "/<<:", "TOTAL_FUN": "-->", "PARTIAL_FUN": "+->", "RELATION": "<->",
    "TOTAL_INJ": ">->", "PARTIAL_INJ": ">+>", "TOTAL_SURJ": "-->>", "PARTIAL_SURJ": "+->>",
    "TOTAL_BIJ": ">->>", "PARTIAL_BIJ": ">+>>", "DIRECT_PRODUCT": "><", "CONCAT": "^",
    "PREPEND": "->", "APPEND": "<-", "TAKE": "/|\\", "DROP": "\\|/",
    "MAPLET": "|->", "UNION": "\\/", "INTER": "/\\", "SETMINUS": "\\",
    "DOM_RES": "<|", "RAN_RES": "|>", "DOM_SUB": "<<|", "RAN_SUB": "|>>", "OVERRIDE": "<+",
    "INTERVAL": "..", "PLUS": "+", "MINUS": "-", "TIMES": "*", "DIVIDE": "/", "MOD": "mod",
    "POWER": "**",
}
_UNI_SETS = {"ℕ": "NATURAL", "ℕ₁": "NATURAL1", "ℤ": "INTEGER", "ℝ": "REAL", "𝔹": "BOOL"}
_QUANT_EXPR = {"SIGMA": "SIGMA", "∑": "SIGMA", "PI": "PI", "∏": "PI", "UNION": "UNION",
               "⋃": "UNION", "INTER": "INTER", "⋂": "INTER"}


_HOLE = re.compile(r"\$(?:\[([^\]]*)\])?\{")


def _template(tok: Token, parse_hole: Callable[[str], ast.Node]) -> ast.Template:
    """Split a template string into its text and its ``${…}`` / ``$[fmt]{…}`` holes; each
    hole is parsed as a formula by ``parse_hole`` at its own place in the source (errors
    point into it)."""
    raw = str(tok)[3:-3]
    texts, formats, holes = [], [], []
    i = 0
    while True:
        m = _HOLE.search(raw, i)
        if m is None:
            texts.append(raw[i:])
            break
        texts.append(raw[i:m.start()])
        depth, j = 1, m.end()
        while j < len(raw) and depth:
            depth += {"{": 1, "}": -1}.get(raw[j], 0)
            j += 1
        if depth:
            raise BSyntaxError("unclosed ${ in a template string", line=tok.line,
                               column=tok.column)
        before = tok.line - 1 + raw.count("\n", 0, m.end())
        col = (m.end() - raw.rfind("\n", 0, m.end()) - 1) if "\n" in raw[:m.end()] \
            else tok.column - 1 + 3 + m.end()
        padded = "\n" * before + " " * col + raw[m.end():j - 1]
        formats.append(m.group(1) or "")
        holes.append(parse_hole(padded))
        i = j
    return ast.Template(tuple(texts), tuple(formats), tuple(holes), pos=tok_pos(tok))


def _pos(meta) -> Optional[ast.Pos]:
    if getattr(meta, "empty", True):
        return None
    return ast.Pos(meta.line, meta.column, meta.end_line, meta.end_column, meta.start_pos,
                 meta.end_pos)


def _strip(children):
    return [c for c in children if not isinstance(c, Token)
            or c.type not in ("AND", "OR", "OR_U", "NOT", "NOT_U", "IMPLIES", "EQUIV", "DOT",
                              "BAR", "FORALL", "EXISTS", "LAMBDA", "SEMI", "PARALLEL",
                              "ASSIGN", "BECOMES_IN", "BECOMES_SUCH", "IN", "EQ", "OUTPUT",
                              "CHOICE_OR", "MINUS", "TILDE", "DEF_EQ")]


def _error(message: str, meta) -> BSyntaxError:
    return BSyntaxError(message, line=getattr(meta, "line", None),
                        column=getattr(meta, "column", None))


@v_args(meta=True)
class Builder(Transformer):
    """Builds AST nodes; checks only what the grammar cannot say (binder lists are names).

    ``parse_hole`` parses the formula in a template string's ``${…}`` (the parser passes
    its own ``parse_formula``, so that this module does not import the parser).
    """

    def __init__(self, parse_hole: Callable[[str], ast.Node]) -> None:
        super().__init__()
        self.parse_hole = parse_hole

    # -- predicates
    def implies(self, meta, c):
        l, r = _strip(c)
        return ast.Implies(l, r, pos=_pos(meta))

    def and_(self, meta, c):
        l, r = _strip(c)
        return ast.And(l, r, pos=_pos(meta))

    def or_(self, meta, c):
        l, r = _strip(c)
        return ast.Or(l, r, pos=_pos(meta))

    def equiv(self, meta, c):
        l, r = _strip(c)
        return ast.Equiv(l, r, pos=_pos(meta))

    def not_(self, meta, c):
        (x,) = _strip(c)
        return ast.Not(x, pos=_pos(meta))

    def relation(self, meta, c):
        l, op, r = c
        return ast.Rel(op, l, r, pos=_pos(meta))

    def rel_op(self, meta, c):
        return _OPS[c[0].type]

    arrow_op = rel_op
    set_op = rel_op

    # -- expressions
    def binop(self, meta, c):
        l, op, r = c
        if isinstance(op, Token):
            op = _OPS[op.type]
        if op == "|->":
            return ast.Pair(l, r, pos=_pos(meta))
        return ast.BinOp(op, l, r, pos=_pos(meta))

    def neg(self, meta, c):
        (x,) = _strip(c)
        return ast.Neg(x, pos=_pos(meta))

    def apply(self, meta, c):
        fn, args = c
        if isinstance(fn, ast.Name) and fn.id in ast.BUILTIN_FUNCTIONS:
            return ast.Call(fn.id, args, pos=_pos(meta))
        return ast.Apply(fn, args, pos=_pos(meta))

    def image(self, meta, c):
        return ast.Image(c[0], c[1], pos=_pos(meta))

    def inverse(self, meta, c):
        return ast.Inverse(_strip(c)[0], pos=_pos(meta))

    def name(self, meta, c):
        return ast.Name(ident(c[0]), pos=tok_pos(c[0]))

    def primed(self, meta, c):
        """``x'``: the value of x before the step, in ``x : (P)``."""
        if not isinstance(c[0], ast.Name) or c[0].id.endswith(("'", "$0")):
            raise _error("only a name may be primed (x'); a record's field is r'name", meta)
        return ast.Name(c[0].id + "'", pos=_pos(meta))

    def field(self, meta, c):
        return ast.Field(c[0], ident(c[2]), pos=_pos(meta))

    def record(self, meta, c):
        return ast.Record(c[0], pos=_pos(meta))

    def struct(self, meta, c):
        return ast.Struct(c[0], pos=_pos(meta))

    def rec_fields(self, meta, c):
        names = [n for n, _ in c]
        for i, (name, value) in enumerate(c):
            if name in names[:i]:
                raise _error(f"the field {name} appears twice", value.pos or meta)
        return tuple(c)

    def rec_field(self, meta, c):
        name, _, value = c
        return (ident(name), value)

    def int_lit(self, meta, c):
        try:
            return ast.IntLit(read_int(str(c[0])), pos=tok_pos(c[0]))
        except ValueError as exc:
            pos = tok_pos(c[0])
            raise BSyntaxError(str(exc), line=pos.line, column=pos.column) from None

    def real_lit(self, meta, c):
        value = float(c[0])
        if not math.isfinite(value):
            raise _error(f"the real {c[0]} is out of range (at most about 1.8E308)", c[0])
        return ast.RealLit(value, pos=tok_pos(c[0]))

    def string_lit(self, meta, c):
        return ast.StrLit(unquote(str(c[0])), pos=tok_pos(c[0]))

    def true_(self, meta, c):
        return ast.BoolLit(True, pos=_pos(meta))

    def false_(self, meta, c):
        return ast.BoolLit(False, pos=_pos(meta))

    def uni_set(self, meta, c):
        return ast.Name(_UNI_SETS[str(c[0])], pos=_pos(meta))

    def uni_pow(self, meta, c):
        kind = "POW1" if str(c[0]) == "ℙ₁" else "POW"
        return ast.Call(kind, (c[1],), pos=_pos(meta))

    def tuple_(self, meta, c):
        first, rest = c
        node = first
        for item in rest:
            node = ast.Pair(node, item, pos=_pos(meta))
        return node

    def empty_set(self, meta, c):
        return ast.SetExt((), pos=_pos(meta))

    def empty_seq(self, meta, c):
        return ast.SetExt((), pos=_pos(meta))

    def seq_ext(self, meta, c):
        """``[a, b]`` is the function ``{1|->a, 2|->b}``."""
        return ast.SetExt(tuple(ast.Pair(ast.IntLit(i, pos=item.pos), item, pos=item.pos)
                              for i, item in enumerate(c[0], start=1)), pos=_pos(meta))

    def composition(self, meta, c):
        items = [x for x in c if not isinstance(x, Token)]
        node = items[0]
        for item in items[1:]:
            node = ast.BinOp(";", node, item, pos=_pos(meta))
        return node

    def parallel_product(self, meta, c):
        left, right = [x for x in c if not isinstance(x, Token)]
        return ast.BinOp("||", left, right, pos=_pos(meta))

    def template(self, meta, c):
        return _template(c[0], self.parse_hole)

    def set_ext(self, meta, c):
        return ast.SetExt(c[0], pos=_pos(meta))

    def comprehension(self, meta, c):
        ids, pred = _strip(c)
        return ast.Comprehension(_binder_names(ids, meta), pred, None, pos=_pos(meta))

    def comprehension_expr(self, meta, c):
        ids, pred, expr = _strip(c)
        return ast.Comprehension(_binder_names(ids, meta), pred, expr, pos=_pos(meta))

    def forall(self, meta, c):
        ids, body = _strip(c)
        return ast.Quant("!", ids, body, pos=_pos(meta))

    def exists(self, meta, c):
        ids, body = _strip(c)
        return ast.Quant("#", ids, body, pos=_pos(meta))

    def lambda_(self, meta, c):
        ids, pred, expr = _strip(c)
        return ast.Lambda(ids, pred, expr, pos=_pos(meta))

    def quant_kw(self, meta, c):
        return _QUANT_EXPR[str(c[0])]

    def quant_expr(self, meta, c):
        op, ids, pred, expr = _strip(c)
        return ast.QuantExpr(op, ids, pred, expr, pos=_pos(meta))

    def if_expr(self, meta, c):
        cond, then, *rest = c
        *elsifs, else_ = rest
        return ast.IfExpr(((cond, then), *elsifs), else_, pos=_pos(meta))

    def elsif_expr(self, meta, c):
        return (c[0], c[1])

    def let_formula(self, meta, c):
        ids, pred, body = c
        return ast.Let(ids, pred, body, pos=_pos(meta))

    def formula_list(self, meta, c):
        return tuple(c)

    def binder(self, meta, c):
        return tuple(ident(t) for t in c)

    def name_list(self, meta, c):
        return tuple(ident(t) for t in c)

    # -- substitutions
    def seq(self, meta, c):
        l, r = _strip(c)
        items = (l.items if isinstance(l, ast.Sequence) else (l,)) + (r,)
        return ast.Sequence(items, pos=_pos(meta))

    def par(self, meta, c):
        l, r = _strip(c)
        items = (l.items if isinstance(l, ast.Parallel) else (l,)) + (r,)
        return ast.Parallel(items, pos=_pos(meta))

    def skip(self, meta, c):
        return ast.Skip(pos=_pos(meta))

    def block(self, meta, c):
        return c[0]

    def assign(self, meta, c):
        targets, values = _strip(c)
        if len(targets) != len(values):
            raise _error(f"{len(targets)} variable(s) on the left of ':=' but "
                         f"{len(values)} value(s) on the right", meta)
        return ast.Assign(targets, values, pos=_pos(meta))

    def becomes_in(self, meta, c):
        targets, value = _strip(c)
        return ast.BecomesIn(_target_names(targets, meta, "::"), value, pos=_pos(meta))

    def becomes_such(self, meta, c):
        targets, pred = _strip(c)
        return ast.BecomesSuchThat(_target_names(targets, meta, ": (P)"), pred, pos=_pos(meta))

    def pre(self, meta, c):
        return ast.Pre(c[0], c[1], pos=_pos(meta))

    def assert_(self, meta, c):
        return ast.Assert(c[0], c[1], pos=_pos(meta))

    def select(self, meta, c):
        branches, else_ = _branches(c)
        return ast.Select(branches, else_, pos=_pos(meta))

    def if_subst(self, meta, c):
        branches, else_ = _branches(c)
        return ast.IfSubst(branches, else_, pos=_pos(meta))

    def when_branch(self, meta, c):
        return (c[0], c[1])

    elsif_branch = when_branch

    def else_branch(self, meta, c):
        return ("else", c[0])

    def any_(self, meta, c):
        return ast.Any(c[0], c[1], c[2], pos=_pos(meta))

    def let_subst(self, meta, c):
        return ast.LetSubst(c[0], c[1], c[2], pos=_pos(meta))

    def choice(self, meta, c):
        return ast.Choice(tuple(c), pos=_pos(meta))

    def or_branch(self, meta, c):
        return _strip(c)[0]

    def case_subst(self, meta, c):
        """``CASE E OF EITHER v THEN S OR … ELSE T END END``: a SELECT on ``E : {v, …}``
        (the B book's meaning: without ELSE, a value in no branch is not a possible step)."""
        c = _strip(c)
        expr, items = c[0], [(c[1], c[2])] + [i for i in c[3:] if i[0] != "else"]
        else_ = next((i[1] for i in c[3:] if i[0] == "else"), None)
        at = expr.pos.point() if expr.pos else None
        branches = tuple((ast.Rel(":", expr, ast.SetExt(tuple(values), pos=at), pos=at), body)
                         for values, body in items)
        return ast.Select(branches, else_, pos=_pos(meta))

    def case_or(self, meta, c):
        c = _strip(c)
        return (c[0], c[1])

    def var_subst(self, meta, c):
        return ast.VarSubst(c[0], c[1], pos=_pos(meta))

    def while_subst(self, meta, c):
        return ast.While(c[0], c[1], c[2], c[3], pos=_pos(meta))

    def subst_call(self, meta, c):
        name = ast.Name(ident(c[0]), pos=tok_pos(c[0]))
        return ast.SubstRef(name, c[1] if len(c) > 1 else (), pos=_pos(meta))

    def lhs_list(self, meta, c):
        return tuple(c)

    def lhs(self, meta, c):
        return ast.Name(ident(c[0]), pos=tok_pos(c[0]))

    def lhs_apply(self, meta, c):
        return ast.Apply(ast.Name(ident(c[0]), pos=tok_pos(c[0])), c[1], pos=_pos(meta))

    # -- clauses
    def machine_header(self, meta, c):
        if len(c) > 1:
            raise _error("machine parameters are not supported", meta)
        return ident(c[0])

    def def_header(self, meta, c):
        c = _strip(c)
        return ident(c[0]), (c[1] if len(c) > 1 else ())

    def sets_clause(self, meta, c):
        return [x for x in c if not isinstance(x, Token)]

    def deferred_set(self, meta, c):
        return (ident(c[0]), None, tok_pos(c[0]))

    def enumerated_set(self, meta, c):
        c = _strip(c)
        return (ident(c[0]), c[1], tok_pos(c[0]))

    def assertions_clause(self, meta, c):
        return [x for x in c if not isinstance(x, Token)]

    def operations_clause(self, meta, c):
        ops = [x for x in c if not isinstance(x, Token)]
        seen: set[str] = set()
        for op in ops:
            if op.name in seen:
                raise _error(f"the operation {op.name} is defined twice", op.pos)
            seen.add(op.name)
        return ops

    def operation(self, meta, c):
        (name, params, outputs, hpos), body = _strip(c)
        return OperationSource(name, params, outputs, body, hpos)

    def op_plain(self, meta, c):
        return (ident(c[0]), (), (), tok_pos(c[0]))

    def op_params(self, meta, c):
        return (ident(c[0]), c[1], (), tok_pos(c[0]))

    def op_outputs(self, meta, c):
        c = _strip(c)
        return (ident(c[1]), (), c[0], tok_pos(c[1]))

    def op_outputs_params(self, meta, c):
        c = _strip(c)
        return (ident(c[1]), c[2], c[0], tok_pos(c[1]))


def _branches(c):
    branches = [c[0:2]]
    else_ = None
    for item in c[2:]:
        if item[0] == "else":
            else_ = item[1]
        else:
            branches.append(item)
    return tuple((a, b) for a, b in branches), else_


def _binder_names(items, meta) -> tuple[str, ...]:
    if len(items) == 1 and isinstance(items[0], ast.Pair):  # {(x, y) | P} is {x, y | P}
        flat, node = [], items[0]
        while isinstance(node, ast.Pair):  # left-nested, as x, y, z make (x |-> y) |-> z
            flat.insert(0, node.right)
            node = node.left
        items = [node] + flat
    names = []
    for item in items:
        if not isinstance(item, ast.Name) or item.id.endswith(("'", "$0")):
            raise _error("the variables before '|' in a set comprehension must be names",
                         item.pos or meta)
        names.append(item.id)
    return tuple(names)


def _target_names(targets, meta, what) -> tuple[str, ...]:
    for t in targets:
        if not isinstance(t, ast.Name):
            raise _error(f"only variables may stand left of '{what}'", t.pos or meta)
    return tuple(t.id for t in targets)
