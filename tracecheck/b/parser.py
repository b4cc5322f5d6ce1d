"""Parse B text into the frozen AST of :mod:`tracecheck.b.ast`.

The whole text is lexed once; a machine is split into its clauses at the clause keywords
and each clause is parsed by the LALR parser from its own start symbol. DEFINITIONS are
split at their top-level ``;`` and each body is parsed as a formula or, failing that, as a
substitution. Lark's errors become :class:`BSyntaxError` with the line, column and a caret.
"""

from __future__ import annotations

import functools
import math
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken, VisitError
from lark.lexer import Lexer

from ..errors import BSyntaxError, TracecheckError
from . import ast as A

__all__ = [
    "parse_formula", "parse_substitution", "parse_machine_source", "MachineSource",
    "Definition", "OperationSource", "tokens",
]

# Formulas up to MAX_DEPTH levels take a few Python frames per level to build, check and
# evaluate (all Python-level recursion, which does not grow the C stack in Python 3.11+).
sys.setrecursionlimit(max(sys.getrecursionlimit(), 20_000))

_GRAMMAR = (Path(__file__).with_name("grammar.lark")).read_text(encoding="utf-8")
_STARTS = [
    "formula", "substitution", "sets_clause", "assertions_clause", "operations_clause",
    "machine_header", "name_list", "def_header",
]

CLAUSES = (
    "MACHINE", "SETS", "CONSTANTS", "CONCRETE_CONSTANTS", "ABSTRACT_CONSTANTS", "PROPERTIES",
    "VARIABLES", "CONCRETE_VARIABLES", "ABSTRACT_VARIABLES", "INVARIANT", "ASSERTIONS",
    "DEFINITIONS", "INITIALISATION", "OPERATIONS",
)
_UNSUPPORTED_CLAUSES = (
    "MODEL", "SYSTEM", "REFINEMENT", "IMPLEMENTATION", "INCLUDES", "SEES", "EXTENDS",
    "USES", "PROMOTES", "IMPORTS", "REFINES", "CONSTRAINTS", "LOCAL_OPERATIONS", "VALUES",
    "INITIALIZATION", "EVENTS",
)
_OPENERS = {"LPAR", "LSQB", "LBRACE", "BEGIN", "IF", "SELECT", "PRE", "ANY", "LET",
            "CHOICE", "ASSERT", "VAR", "CASE"}
_CLOSERS = {"RPAR", "RSQB", "RBRACE", "END"}

#: Definitions that only tools read; their bodies may use syntax tracecheck does not parse.
TOOL_DEFINITION_PREFIXES = (
    "VISB_", "ANIMATION_", "ASSERT_LTL", "ASSERT_CTL", "SET_PREF_", "CUSTOM_GRAPH",
    "GOAL", "HEURISTIC_FUNCTION", "SCOPE", "GAME_", "DESCRIPTION_FOR_", "FORCE_SYMMETRY",
    "SIMB_", "VISB", "LTL_",
)

_READABLE = {
    "NAME": "a name", "INT": "an integer", "REAL_LIT": "a real number",
    "STRING": "a string", "$END": "the end",
}


class _TokenFeed(Lexer):
    """Lets the LALR parser take tokens that were lexed beforehand."""

    def __init__(self, lexer_conf) -> None:  # noqa: D107 - lark's interface
        pass

    def lex(self, data) -> Iterator[Token]:  # type: ignore[override]
        yield from data


@functools.lru_cache(maxsize=1)
def _lexer() -> Lark:
    return Lark(_GRAMMAR, parser="lalr", lexer="basic", start=_STARTS,
                lexer_callbacks={"COMMENT": _comment_sink})


@functools.lru_cache(maxsize=1)
def _parser() -> Lark:
    return Lark(_GRAMMAR, parser="lalr", lexer=_TokenFeed, start=_STARTS,
                propagate_positions=True)


_COMMENTS: list[Token] = []


def _comment_sink(tok: Token) -> None:
    _COMMENTS.append(tok)


_FIRST_LITERAL = {m.group(1): m.group(2).replace("\\\\", "\\")
                  for m in re.finditer(r'^([A-Z_]+):\s*"((?:\\.|[^"])*)"', _GRAMMAR, re.M)}


def _terminal_text(name: str) -> str:
    if name in _READABLE:
        return _READABLE[name]
    if name in _FIRST_LITERAL:
        return f"'{_FIRST_LITERAL[name]}'"
    for term in _lexer().terminals:
        if term.name == name and term.pattern.type == "str":
            return f"'{term.pattern.value}'"
    return name


def _describe_expected(expected: set[str]) -> str:
    if {"NAME", "INT"} <= expected:
        return "a predicate or expression (a name, a number, '(', '{', …)"
    names = sorted({_terminal_text(e) for e in expected if not e.startswith("__")})
    if len(names) > 10:
        names = names[:10] + ["…"]
    return ", ".join(names)


def tokens(text: str, *, file: Optional[str] = None) -> tuple[list[Token], list[Token]]:
    """Lex ``text``: the tokens and the comments (for ``/*@desc`` pragmas)."""
    _COMMENTS.clear()
    try:
        toks = list(_lexer().lex(text))
    except UnexpectedCharacters as exc:
        char = text[exc.pos_in_stream] if exc.pos_in_stream < len(text) else "?"
        raise BSyntaxError(
            f"unexpected character {char!r}", file=file, line=exc.line, column=exc.column,
            source=text,
        ) from None
    comments = list(_COMMENTS)
    _COMMENTS.clear()
    return toks, comments


def _parse_tokens(toks: list[Token], start: str, text: str, file: Optional[str],
                  what: str, end_token: Optional[Token] = None):
    if not toks:
        line, col = _after(end_token) if end_token is not None else (1, 1)
        raise BSyntaxError(f"{what} is empty", file=file, line=line, column=col, source=text)
    try:
        tree = _parser().parse(toks, start=start)
        _check_depth(tree, text, file)
        return _Builder().transform(tree)
    except UnexpectedToken as exc:
        tok = exc.token
        if tok.type == "$END":
            line, col = _after(toks[-1])
            found = f"end of {what}"
        else:
            line, col = tok.line, tok.column
            found = repr(str(tok.value))
        raise BSyntaxError(
            f"unexpected {found}; expected {_describe_expected(exc.expected)}",
            file=file, line=line, column=col, source=text,
        ) from None
    except UnexpectedInput as exc:  # pragma: no cover - other lark input errors
        raise BSyntaxError(str(exc).splitlines()[0], file=file,
                           line=getattr(exc, "line", None), column=getattr(exc, "column", None),
                           source=text) from None
    except VisitError as exc:
        if isinstance(exc.orig_exc, TracecheckError):
            raise exc.orig_exc.located(file=file, source=text) from None
        raise


#: How deeply a formula may nest (parentheses, operators, quantifiers); deeper ones are
#: refused with a located error instead of exhausting Python's stack.
MAX_DEPTH = 400


def _check_depth(tree, text: str, file: Optional[str]) -> None:
    from lark import Tree

    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            meta = node.meta
            raise BSyntaxError(
                f"the formula nests more than {MAX_DEPTH} levels deep here; tracecheck reads "
                f"formulas up to {MAX_DEPTH} levels (a sum of {MAX_DEPTH} terms nests that deep)",
                file=file, line=getattr(meta, "line", None),
                column=getattr(meta, "column", None), source=text,
                hint="split the formula with definitions or intermediate variables")
        stack.extend((c, depth + 1) for c in node.children if isinstance(c, Tree))


def _after(tok: Token) -> tuple[int, int]:
    return tok.end_line or tok.line, (tok.end_column or tok.column)


def parse_formula(text: str, *, file: Optional[str] = None) -> A.Node:
    """Parse a predicate or expression.

    >>> parse_formula("x + 1 > 2")
    Rel(op='>', left=BinOp(op='+', left=Name(id='x'), right=IntLit(value=1)), right=IntLit(value=2))
    """
    toks, _ = tokens(text, file=file)
    return _parse_tokens(toks, "formula", text, file, "the formula")


def parse_substitution(text: str, *, file: Optional[str] = None) -> A.Subst:
    """Parse a substitution such as ``x := x + 1 || y :: BOOL``."""
    toks, _ = tokens(text, file=file)
    return _parse_tokens(toks, "substitution", text, file, "the substitution")


# ------------------------------------------------------------------ machines


@dataclass(frozen=True)
class Definition:
    name: str
    params: tuple[str, ...]
    kind: str  # "formula", "substitution", "string" or "unparsed"
    body: object  # Node, Subst, str, or the BSyntaxError of an unparsed tool definition
    line: int = 0


@dataclass(frozen=True)
class OperationSource:
    name: str
    params: tuple[str, ...]
    outputs: tuple[str, ...]
    body: A.Subst
    pos: Optional[A.Pos] = None


@dataclass
class MachineSource:
    """A machine as written: each clause parsed, nothing evaluated yet."""

    name: str
    file: Optional[str]
    text: str
    sets: list[tuple[str, Optional[tuple[str, ...]], Optional[A.Pos]]] = field(default_factory=list)
    constants: list[tuple[str, A.Pos]] = field(default_factory=list)
    variables: list[tuple[str, A.Pos]] = field(default_factory=list)
    properties: Optional[A.Node] = None
    invariant: Optional[A.Node] = None
    assertions: tuple[A.Node, ...] = ()
    definitions: dict[str, Definition] = field(default_factory=dict)
    initialisation: Optional[A.Subst] = None
    operations: list[OperationSource] = field(default_factory=list)
    descriptions: dict[int, str] = field(default_factory=dict)  # end offset -> text

    def description_after(self, pos: Optional[A.Pos]) -> Optional[str]:
        """The ``/*@desc …*/`` pragma written right after the element at ``pos``."""
        return self.descriptions.get(pos.end) if pos is not None else None


def _split_clauses(toks: list[Token], text: str, file: Optional[str]):
    if not toks:
        raise BSyntaxError("the file is empty; a machine starts with MACHINE", file=file,
                           line=1, column=1, source=text)
    first = toks[0]
    if first.type == "NAME" and first.value in _UNSUPPORTED_CLAUSES:
        raise BSyntaxError(f"{first.value} is not supported: tracecheck reads classical B "
                           "machines (MACHINE … END)", file=file, line=first.line,
                           column=first.column, source=text)
    if not (first.type == "NAME" and first.value == "MACHINE"):
        raise BSyntaxError(f"unexpected {first.value!r}; a machine starts with MACHINE",
                           file=file, line=first.line, column=first.column, source=text)
    last = toks[-1]
    if last.type != "END":
        line, col = _after(last)
        raise BSyntaxError("the machine does not end with END", file=file, line=line,
                           column=col, source=text)
    clauses: list[tuple[Token, list[Token]]] = []
    for tok in toks[:-1]:
        if tok.type == "NAME" and tok.value in _UNSUPPORTED_CLAUSES:
            raise BSyntaxError(f"the clause {tok.value} is not supported by tracecheck",
                               file=file, line=tok.line, column=tok.column, source=text,
                               hint="put everything the shield needs into one machine")
        if tok.type == "NAME" and tok.value in CLAUSES:
            if any(k.value == tok.value for k, _ in clauses):
                raise BSyntaxError(f"the clause {tok.value} appears twice", file=file,
                                   line=tok.line, column=tok.column, source=text)
            clauses.append((tok, []))
        else:
            clauses[-1][1].append(tok)
    return clauses


def parse_machine_source(text: str, *, file: Optional[str] = None) -> MachineSource:
    """Parse a whole machine into its clauses (see :class:`MachineSource`)."""
    toks, comments = tokens(text, file=file)
    clauses = _split_clauses(toks, text, file)
    header_kw, header = clauses[0]
    name_tree = _parse_tokens(header, "machine_header", text, file, "the MACHINE clause",
                              header_kw)
    src = MachineSource(name=name_tree, file=file, text=text)
    src.descriptions = _descriptions(toks, comments)
    for kw, body in clauses[1:]:
        _fill_clause(src, kw, body, text, file)
    return src


def _fill_clause(src: MachineSource, kw: Token, body: list[Token], text: str,
                 file: Optional[str]) -> None:
    what = f"the {kw.value} clause"
    name = kw.value
    if name == "DEFINITIONS":
        src.definitions = _parse_definitions(body, text, file, kw)
        return
    start = {
        "SETS": "sets_clause", "PROPERTIES": "formula", "INVARIANT": "formula",
        "ASSERTIONS": "assertions_clause", "INITIALISATION": "substitution",
        "OPERATIONS": "operations_clause",
    }.get(name, "name_list")
    value = _parse_tokens(body, start, text, file, what, kw)
    if name == "SETS":
        src.sets = list(value)
    elif name in ("CONSTANTS", "CONCRETE_CONSTANTS", "ABSTRACT_CONSTANTS"):
        src.constants += _names_with_pos(body)
    elif name in ("VARIABLES", "CONCRETE_VARIABLES", "ABSTRACT_VARIABLES"):
        src.variables += _names_with_pos(body)
    elif name == "PROPERTIES":
        src.properties = value
    elif name == "INVARIANT":
        src.invariant = value
    elif name == "ASSERTIONS":
        src.assertions = tuple(value)
    elif name == "INITIALISATION":
        src.initialisation = value
    elif name == "OPERATIONS":
        src.operations = list(value)


def _names_with_pos(body: list[Token]) -> list[tuple[str, A.Pos]]:
    return [(t.value, _tok_pos(t)) for t in body if t.type == "NAME"]


def _descriptions(toks: list[Token], comments: list[Token]) -> dict[int, str]:
    """Map the end offset of the token before each ``/*@desc`` pragma to its text."""
    out: dict[int, str] = {}
    ends = [t.end_pos for t in toks]
    import bisect

    for com in comments:
        match = re.match(r'/\*@desc\s+(.*?)\s*\*/\Z', com.value, re.S)
        if not match:
            continue
        desc = match.group(1).strip()
        if len(desc) >= 2 and desc[0] == desc[-1] == '"':
            desc = desc[1:-1]
        idx = bisect.bisect_right(ends, com.start_pos) - 1
        if idx >= 0:
            out[ends[idx]] = desc
    return out


def _split_definitions(body: list[Token]) -> list[list[Token]]:
    parts: list[list[Token]] = [[]]
    depth = 0
    for tok in body:
        if tok.type in _OPENERS:
            depth += 1
        elif tok.type in _CLOSERS:
            depth -= 1
        if tok.type == "SEMI" and depth == 0:
            parts.append([])
        else:
            parts[-1].append(tok)
    return [p for p in parts if p]


def _parse_definitions(body, text, file, kw) -> dict[str, Definition]:
    defs: dict[str, Definition] = {}
    for part in _split_definitions(body):
        if part[0].type == "STRING":
            raise BSyntaxError("definition files (DEFINITIONS \"file.def\") are not supported",
                               file=file, line=part[0].line, column=part[0].column, source=text)
        try:
            eq_at = next(i for i, t in enumerate(part) if t.type == "DEF_EQ")
        except StopIteration:
            raise BSyntaxError(f"a definition needs '==' after its name (found {part[0].value!r})",
                               file=file, line=part[0].line, column=part[0].column,
                               source=text) from None
        name, params = _parse_tokens(part[: eq_at + 1], "def_header", text, file,
                                     "the definition's name")
        if name in defs:
            raise BSyntaxError(f"the definition {name} appears twice", file=file,
                               line=part[0].line, column=part[0].column, source=text)
        defs[name] = _parse_definition_body(name, params, part[eq_at + 1:], part[eq_at],
                                            text, file)
    return defs


def _parse_definition_body(name, params, body, eq_tok, text, file) -> Definition:
    line = eq_tok.line
    if len(body) == 1 and body[0].type == "STRING":
        return Definition(name, params, "string", _unquote(body[0].value), line)
    try:
        try:
            node = _parse_tokens(body, "formula", text, file, f"the definition {name}", eq_tok)
            return Definition(name, params, "formula", node, line)
        except BSyntaxError as as_formula:
            try:
                node = _parse_tokens(body, "substitution", text, file,
                                     f"the definition {name}", eq_tok)
                return Definition(name, params, "substitution", node, line)
            except BSyntaxError as as_subst:
                raise _furthest(as_formula, as_subst) from None
    except BSyntaxError as exc:
        if name.startswith(TOOL_DEFINITION_PREFIXES):
            return Definition(name, params, "unparsed", exc, line)
        raise


def _furthest(a: BSyntaxError, b: BSyntaxError) -> BSyntaxError:
    return a if (a.line or 0, a.column or 0) >= (b.line or 0, b.column or 0) else b


def _unquote(s: str) -> str:
    return re.sub(r'\\(.)', r'\1', s[1:-1])


def _tok_pos(tok: Token) -> A.Pos:
    return A.Pos(tok.line, tok.column, tok.end_line, tok.end_column, tok.start_pos, tok.end_pos)


# ------------------------------------------------------------------ tree -> AST

_OPS = {
    "EQ": "=", "NEQ": "/=", "LT": "<", "LE": "<=", "GT": ">", "GE": ">=", "IN": ":",
    "NOTIN": "/:", "SUBSET": "<:", "STRICT_SUBSET": "<<:", "NOT_SUBSET": "/<:",
    "NOT_STRICT_SUBSET": "/<<:", "TOTAL_FUN": "-->", "PARTIAL_FUN": "+->", "RELATION": "<->",
    "TOTAL_INJ": ">->", "PARTIAL_INJ": ">+>", "TOTAL_SURJ": "-->>", "PARTIAL_SURJ": "+->>",
    "TOTAL_BIJ": ">->>", "PARTIAL_BIJ": ">+>>", "DIRECT_PRODUCT": "><", "CONCAT": "^",
    "MAPLET": "|->", "UNION": "\\/", "INTER": "/\\", "SETMINUS": "\\",
    "DOM_RES": "<|", "RAN_RES": "|>", "DOM_SUB": "<<|", "RAN_SUB": "|>>", "OVERRIDE": "<+",
    "INTERVAL": "..", "PLUS": "+", "MINUS": "-", "TIMES": "*", "DIVIDE": "/", "MOD": "mod",
    "POWER": "**",
}
_UNI_SETS = {"ℕ": "NATURAL", "ℕ₁": "NATURAL1", "ℤ": "INTEGER", "ℝ": "REAL", "𝔹": "BOOL"}
_QUANT_EXPR = {"SIGMA": "SIGMA", "Σ": "SIGMA", "PI": "PI", "Π": "PI", "UNION": "UNION",
               "⋃": "UNION", "INTER": "INTER", "⋂": "INTER"}


_HOLE = re.compile(r"\$(?:\[([^\]]*)\])?\{")


def _template(tok: Token) -> A.Template:
    """Split a template string into its text and its ``${…}`` / ``$[fmt]{…}`` holes; each
    hole is parsed as a formula at its own place in the source (errors point into it)."""
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
        holes.append(parse_formula(padded))
        i = j
    return A.Template(tuple(texts), tuple(formats), tuple(holes), pos=_tok_pos(tok))


def _pos(meta) -> Optional[A.Pos]:
    if getattr(meta, "empty", True):
        return None
    return A.Pos(meta.line, meta.column, meta.end_line, meta.end_column, meta.start_pos,
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
class _Builder(Transformer):
    """Builds AST nodes; checks only what the grammar cannot say (binder lists are names)."""

    # -- predicates
    def implies(self, meta, c):
        l, r = _strip(c)
        return A.Implies(l, r, pos=_pos(meta))

    def and_(self, meta, c):
        l, r = _strip(c)
        return A.And(l, r, pos=_pos(meta))

    def or_(self, meta, c):
        l, r = _strip(c)
        return A.Or(l, r, pos=_pos(meta))

    def equiv(self, meta, c):
        l, r = _strip(c)
        return A.Equiv(l, r, pos=_pos(meta))

    def not_(self, meta, c):
        (x,) = _strip(c)
        return A.Not(x, pos=_pos(meta))

    def relation(self, meta, c):
        l, op, r = c
        return A.Rel(op, l, r, pos=_pos(meta))

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
            return A.Pair(l, r, pos=_pos(meta))
        return A.BinOp(op, l, r, pos=_pos(meta))

    def neg(self, meta, c):
        (x,) = _strip(c)
        return A.Neg(x, pos=_pos(meta))

    def apply(self, meta, c):
        fn, args = c
        if isinstance(fn, A.Name) and fn.id in A.BUILTIN_FUNCTIONS:
            return A.Call(fn.id, args, pos=_pos(meta))
        return A.Apply(fn, args, pos=_pos(meta))

    def image(self, meta, c):
        return A.Image(c[0], c[1], pos=_pos(meta))

    def inverse(self, meta, c):
        return A.Inverse(_strip(c)[0], pos=_pos(meta))

    def name(self, meta, c):
        return A.Name(str(c[0]), pos=_tok_pos(c[0]))

    def int_lit(self, meta, c):
        return A.IntLit(int(c[0]), pos=_tok_pos(c[0]))

    def real_lit(self, meta, c):
        value = float(c[0])
        if not math.isfinite(value):
            raise _error(f"the real {c[0]} is out of range (at most about 1.8E308)", c[0])
        return A.RealLit(value, pos=_tok_pos(c[0]))

    def string_lit(self, meta, c):
        return A.StrLit(_unquote(str(c[0])), pos=_tok_pos(c[0]))

    def true_(self, meta, c):
        return A.BoolLit(True, pos=_pos(meta))

    def false_(self, meta, c):
        return A.BoolLit(False, pos=_pos(meta))

    def uni_set(self, meta, c):
        return A.Name(_UNI_SETS[str(c[0])], pos=_pos(meta))

    def uni_pow(self, meta, c):
        kind = "POW1" if str(c[0]) == "ℙ₁" else "POW"
        return A.Call(kind, (c[1],), pos=_pos(meta))

    def tuple_(self, meta, c):
        first, rest = c
        node = first
        for item in rest:
            node = A.Pair(node, item, pos=_pos(meta))
        return node

    def empty_set(self, meta, c):
        return A.SetExt((), pos=_pos(meta))

    def empty_seq(self, meta, c):
        return A.SetExt((), pos=_pos(meta))

    def seq_ext(self, meta, c):
        """``[a, b]`` is the function ``{1|->a, 2|->b}``."""
        return A.SetExt(tuple(A.Pair(A.IntLit(i, pos=item.pos), item, pos=item.pos)
                              for i, item in enumerate(c[0], start=1)), pos=_pos(meta))

    def composition(self, meta, c):
        items = [x for x in c if not isinstance(x, Token)]
        node = items[0]
        for item in items[1:]:
            node = A.BinOp(";", node, item, pos=_pos(meta))
        return node

    def template(self, meta, c):
        return _template(c[0])

    def set_ext(self, meta, c):
        return A.SetExt(c[0], pos=_pos(meta))

    def comprehension(self, meta, c):
        ids, pred = _strip(c)
        return A.Comprehension(_binder_names(ids, meta), pred, None, pos=_pos(meta))

    def comprehension_expr(self, meta, c):
        ids, pred, expr = _strip(c)
        return A.Comprehension(_binder_names(ids, meta), pred, expr, pos=_pos(meta))

    def forall(self, meta, c):
        ids, body = _strip(c)
        return A.Quant("!", ids, body, pos=_pos(meta))

    def exists(self, meta, c):
        ids, body = _strip(c)
        return A.Quant("#", ids, body, pos=_pos(meta))

    def lambda_(self, meta, c):
        ids, pred, expr = _strip(c)
        return A.Lambda(ids, pred, expr, pos=_pos(meta))

    def quant_kw(self, meta, c):
        return _QUANT_EXPR[str(c[0])]

    def quant_expr(self, meta, c):
        op, ids, pred, expr = _strip(c)
        return A.QuantExpr(op, ids, pred, expr, pos=_pos(meta))

    def if_expr(self, meta, c):
        cond, then, *rest = c
        *elsifs, else_ = rest
        return A.IfExpr(((cond, then), *elsifs), else_, pos=_pos(meta))

    def elsif_expr(self, meta, c):
        return (c[0], c[1])

    def let_formula(self, meta, c):
        ids, pred, body = c
        return A.Let(ids, pred, body, pos=_pos(meta))

    def formula_list(self, meta, c):
        return tuple(c)

    def binder(self, meta, c):
        return tuple(str(t) for t in c)

    def name_list(self, meta, c):
        return tuple(str(t) for t in c)

    # -- substitutions
    def seq(self, meta, c):
        l, r = _strip(c)
        items = (l.items if isinstance(l, A.Sequence) else (l,)) + (r,)
        return A.Sequence(items, pos=_pos(meta))

    def par(self, meta, c):
        l, r = _strip(c)
        items = (l.items if isinstance(l, A.Parallel) else (l,)) + (r,)
        return A.Parallel(items, pos=_pos(meta))

    def skip(self, meta, c):
        return A.Skip(pos=_pos(meta))

    def block(self, meta, c):
        return c[0]

    def assign(self, meta, c):
        targets, values = _strip(c)
        if len(targets) != len(values):
            raise _error(f"{len(targets)} variable(s) on the left of ':=' but "
                         f"{len(values)} value(s) on the right", meta)
        return A.Assign(targets, values, pos=_pos(meta))

    def becomes_in(self, meta, c):
        targets, value = _strip(c)
        return A.BecomesIn(_target_names(targets, meta, "::"), value, pos=_pos(meta))

    def becomes_such(self, meta, c):
        targets, pred = _strip(c)
        return A.BecomesSuchThat(_target_names(targets, meta, ": (P)"), pred, pos=_pos(meta))

    def pre(self, meta, c):
        return A.Pre(c[0], c[1], pos=_pos(meta))

    def assert_(self, meta, c):
        return A.Assert(c[0], c[1], pos=_pos(meta))

    def select(self, meta, c):
        branches, else_ = _branches(c)
        return A.Select(branches, else_, pos=_pos(meta))

    def if_subst(self, meta, c):
        branches, else_ = _branches(c)
        return A.IfSubst(branches, else_, pos=_pos(meta))

    def when_branch(self, meta, c):
        return (c[0], c[1])

    elsif_branch = when_branch

    def else_branch(self, meta, c):
        return ("else", c[0])

    def any_(self, meta, c):
        return A.Any(c[0], c[1], c[2], pos=_pos(meta))

    def let_subst(self, meta, c):
        return A.LetSubst(c[0], c[1], c[2], pos=_pos(meta))

    def choice(self, meta, c):
        return A.Choice(tuple(c), pos=_pos(meta))

    def or_branch(self, meta, c):
        return _strip(c)[0]

    def subst_call(self, meta, c):
        name = A.Name(str(c[0]), pos=_tok_pos(c[0]))
        return A.SubstRef(name, c[1] if len(c) > 1 else (), pos=_pos(meta))

    def lhs_list(self, meta, c):
        return tuple(c)

    def lhs(self, meta, c):
        return A.Name(str(c[0]), pos=_tok_pos(c[0]))

    def lhs_apply(self, meta, c):
        return A.Apply(A.Name(str(c[0]), pos=_tok_pos(c[0])), c[1], pos=_pos(meta))

    # -- clauses
    def machine_header(self, meta, c):
        if len(c) > 1:
            raise _error("machine parameters are not supported", meta)
        return str(c[0])

    def def_header(self, meta, c):
        c = _strip(c)
        return str(c[0]), (c[1] if len(c) > 1 else ())

    def sets_clause(self, meta, c):
        return [x for x in c if not isinstance(x, Token)]

    def deferred_set(self, meta, c):
        return (str(c[0]), None, _tok_pos(c[0]))

    def enumerated_set(self, meta, c):
        c = _strip(c)
        return (str(c[0]), c[1], _tok_pos(c[0]))

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
        return (str(c[0]), (), (), _tok_pos(c[0]))

    def op_params(self, meta, c):
        return (str(c[0]), c[1], (), _tok_pos(c[0]))

    def op_outputs(self, meta, c):
        c = _strip(c)
        return (str(c[1]), (), c[0], _tok_pos(c[1]))

    def op_outputs_params(self, meta, c):
        c = _strip(c)
        return (str(c[1]), c[2], c[0], _tok_pos(c[1]))


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
    names = []
    for item in items:
        if not isinstance(item, A.Name) or item.id.endswith(("'", "$0")):
            raise _error("the variables before '|' in a set comprehension must be names",
                         item.pos or meta)
        names.append(item.id)
    return tuple(names)


def _target_names(targets, meta, what) -> tuple[str, ...]:
    for t in targets:
        if not isinstance(t, A.Name):
            raise _error(f"only variables may stand left of '{what}'", t.pos or meta)
    return tuple(t.id for t in targets)

