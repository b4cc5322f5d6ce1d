"""Parse B text into the frozen AST of :mod:`tracecheck.b.ast`.

The whole text is lexed once; a machine is split into its clauses at the clause keywords
and each clause is parsed by the LALR parser from its own start symbol. DEFINITIONS are
split at their top-level ``;`` and each body is parsed as a formula or, failing that, as a
substitution. Lark's errors become :class:`BSyntaxError` with the line, column and a caret.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken, VisitError
from lark.lexer import Lexer

from ..errors import BSyntaxError, TracecheckError, UnsupportedError
from . import ast
from .builder import Builder, OperationSource, ident, tok_pos, unquote
from .clauses import CLAUSES, CLOSERS, OPENERS, UNSUPPORTED_CLAUSES, merge_dotted
from .composition import compose
from .library import LIBRARY_FILES, NOT_IMPLEMENTED, library_bodies
from ..limits import deep_recursion

__all__ = [
    "parse_formula", "parse_substitution", "parse_machine_source", "MachineSource",
    "Definition", "OperationSource", "tokens",
]

_GRAMMAR = (Path(__file__).with_name("grammar.lark")).read_text(encoding="utf-8")
_GRAMMAR_SHA = hashlib.sha256(_GRAMMAR.encode()).hexdigest()
_STARTS = [
    "formula", "substitution", "sets_clause", "assertions_clause", "operations_clause",
    "machine_header", "name_list", "def_header",
]

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
                lexer_callbacks={"COMMENT": _comment_sink}, cache=grammar_cache("lexer"))


@functools.lru_cache(maxsize=1)
def _parser() -> Lark:
    return Lark(_GRAMMAR, parser="lalr", lexer=_TokenFeed, start=_STARTS,
                propagate_positions=True, cache=grammar_cache("parser"))


def grammar_cache(kind: str) -> str | bool:
    """Where lark keeps the analysed grammar between runs (building it takes most of a short
    command's time), or ``False`` for no cache.

    Lark's cache files are pickles, so only a private folder is used: ``$XDG_CACHE_HOME`` or
    ``~/.cache``, then ``tracecheck/``, owned by this user and writable by no one else, and
    only a cache file owned by this user and writable by no one else — never the shared
    temporary folder. ``TRACECHECK_NO_CACHE=1`` turns it off.
    """
    if os.environ.get("TRACECHECK_NO_CACHE") or not hasattr(os, "getuid"):
        return False
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = Path(base) / "tracecheck"
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        if not _private(folder):
            return False
        path = folder / f"grammar-{kind}-{_GRAMMAR_SHA[:16]}.lark"
        if path.exists() and not _private(path):
            return False
    except OSError:
        return False
    return str(path)


def _private(path: Path) -> bool:
    st = path.lstat()
    return st.st_uid == os.getuid() and not st.st_mode & 0o022 and not path.is_symlink()


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
        with deep_recursion():  # the builder recurses once per level of the tree
            return Builder(parse_formula).transform(tree)
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
MAX_DEPTH = 2000


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


def parse_formula(text: str, *, file: Optional[str] = None,
                  dotted: frozenset[str] = frozenset()) -> ast.Node:
    """Parse a predicate or expression of classical B.

    Args:
        text: the formula (ASCII or Unicode notation).
        file: where it comes from, for error messages.
        dotted: names written ``r.x`` (of a machine included with renaming), read as one.

    Returns:
        Its syntax tree (:mod:`tracecheck.b.ast`).

    Raises:
        TracecheckError: a located syntax error (line, column, what was expected).

    >>> parse_formula("x + 1 > 2")
    Rel(op='>', left=BinOp(op='+', left=Name(id='x'), right=IntLit(value=1)), right=IntLit(value=2))
    """
    _check_length(text, file, "formula")
    toks, _ = tokens(text, file=file)
    if dotted:
        toks = merge_dotted(toks, lambda a, b: f"{a}.{b}" in dotted)
    return _parse_tokens(toks, "formula", text, file, "the formula")


def parse_substitution(text: str, *, file: Optional[str] = None) -> ast.Subst:
    """Parse a substitution such as ``x := x + 1 || y :: BOOL``.

    Args:
        text: the substitution.
        file: where it comes from, for error messages.

    Returns:
        Its syntax tree (an :class:`~tracecheck.b.ast.Subst`).

    >>> type(parse_substitution("x := x + 1")).__name__
    'Assign'
    """
    _check_length(text, file, "substitution")
    toks, _ = tokens(text, file=file)
    return _parse_tokens(toks, "substitution", text, file, "the substitution")


#: The longest formula or substitution read on its own (a machine's clauses have the
#: machine's limit): checked before lexing — a 340 KB formula takes about 3 s and 100 MB
#: to parse, and a 1.5 MB predicate from a script took 800 MB before the nesting limit
MAX_FORMULA_CHARS = 262_144


def _check_length(text: str, file: Optional[str], what: str) -> None:
    if len(text) > MAX_FORMULA_CHARS:
        raise BSyntaxError(f"the {what} is {len(text):,} characters long; tracecheck reads "
                           f"formulas of up to {MAX_FORMULA_CHARS:,} characters",
                           file=file, line=1, column=1,
                           hint="split it with definitions, or give the values as a state "
                                "file")


# ------------------------------------------------------------------ machines


@dataclass(frozen=True)
class Definition:
    name: str
    params: tuple[str, ...]
    kind: str  # "formula", "substitution", "string" or "unparsed"
    body: object  # Node, Subst, str, or the BSyntaxError of an unparsed tool definition
    line: int = 0


@dataclass
class MachineSource:
    """A machine as written: each clause parsed, nothing evaluated yet."""

    name: str
    file: Optional[str]
    text: str
    sets: list[tuple[str, Optional[tuple[str, ...]], Optional[ast.Pos]]] = field(
        default_factory=list)
    constants: list[tuple[str, ast.Pos]] = field(default_factory=list)
    variables: list[tuple[str, ast.Pos]] = field(default_factory=list)
    properties: Optional[ast.Node] = None
    invariant: Optional[ast.Node] = None
    assertions: tuple[ast.Node, ...] = ()
    definitions: dict[str, Definition] = field(default_factory=dict)
    initialisation: Optional[ast.Subst] = None
    operations: list[OperationSource] = field(default_factory=list)
    descriptions: dict[int, str] = field(default_factory=dict)  # end offset -> text

    def description_after(self, pos: Optional[ast.Pos]) -> Optional[str]:
        """The ``/*@desc …*/`` pragma written right after the element at ``pos``."""
        return self.descriptions.get(pos.end) if pos is not None else None


def _split_clauses(toks: list[Token], text: str, file: Optional[str]):
    if not toks:
        raise BSyntaxError("the file is empty; a machine starts with MACHINE", file=file,
                           line=1, column=1, source=text)
    first = toks[0]
    if first.type == "NAME" and first.value in UNSUPPORTED_CLAUSES:
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
    depth = 0  # a WHILE's INVARIANT inside an operation is no clause
    for tok in toks[:-1]:
        if tok.type == "NAME" and tok.value == "INITIALIZATION":  # the US spelling, as ProB
            tok = Token.new_borrow_pos("NAME", "INITIALISATION", tok)
        depth += (tok.type in OPENERS) - (tok.type in CLOSERS)
        if depth > 0 or tok.type not in ("NAME", tok.value):
            clauses[-1][1].append(tok)
            continue
        if tok.value in UNSUPPORTED_CLAUSES:
            raise BSyntaxError(f"the clause {tok.value} is not supported by tracecheck",
                               file=file, line=tok.line, column=tok.column, source=text,
                               hint="put everything the shield needs into one machine")
        if tok.value in CLAUSES:
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
    flat = compose(text, toks, file, lambda t, f: tokens(t, file=f))
    if flat is not None:  # SEES, INCLUDES, …: one machine of several (composition.py)
        text, toks, comments = flat
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


def _names_with_pos(body: list[Token]) -> list[tuple[str, ast.Pos]]:
    return [(ident(t), tok_pos(t)) for t in body if t.type == "NAME"]


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
        if tok.type in OPENERS:
            depth += 1
        elif tok.type in CLOSERS:
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
            for name, d in _library_definitions(part, text, file).items():
                if name in defs:
                    raise BSyntaxError(f"the definition {name} appears twice (also in "
                                       f"{part[0].value})", file=file, line=part[0].line,
                                       column=part[0].column, source=text)
                defs[name] = d
            continue
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
    return _externals(defs, text, file)


_EXTERNAL = ("EXTERNAL_FUNCTION_", "EXTERNAL_PREDICATE_", "EXTERNAL_SUBSTITUTION_")


def _externals(defs: dict[str, Definition], text, file) -> dict[str, Definition]:
    """A definition that ProB calls as an external function (an ``EXTERNAL_FUNCTION_NAME``
    declares it) has a placeholder body, not its value (``PROB_INFO_STR(x) == ""``): where
    tracecheck implements the function, its own implementation; else using it is refused."""
    native = {}
    for lib in LIBRARY_FILES:
        native.update(library_bodies(lib) or {})
    for key in list(defs):
        prefix = next((p for p in _EXTERNAL if key.startswith(p)), None)
        name = key[len(prefix):] if prefix else None
        if name is None or name not in defs:
            continue
        d = defs[name]
        if name in native and len(native[name][0]) == len(d.params):
            params, body = native[name]
            defs[name] = Definition(name, params, "formula", body, d.line)
        elif name in ast.BUILTIN_FUNCTIONS:
            del defs[name]  # built in everywhere: the call is tracecheck's own (its arity too)
        else:  # unknown, or with other parameters than tracecheck's own: refused
            which = (f"which tracecheck implements with {len(native[name][0])} parameter(s), "
                     f"not {len(d.params)}" if name in native else
                     "which tracecheck does not implement")
            why = UnsupportedError(f"{name} is one of ProB's external functions "
                               f"({key}), {which}; its DEFINITIONS body is ProB's "
                               "placeholder, not its value",
                               file=file, line=d.line, source=text,
                               hint="write the value it stands for in the formula instead")
            defs[name] = Definition(name, d.params, "unparsed", why, d.line)
    return defs


def library_definitions(file_name: str) -> Optional[dict[str, Definition]]:
    """The definitions ``DEFINITIONS "file_name"`` brings: one of ProB's standard library
    files, whose functions tracecheck implements natively (:mod:`.library`); ``None`` for
    any other file. ``library_definitions("*")``: every library function, as ProB's console
    offers them without an include."""
    names = LIBRARY_FILES if file_name == "*" else [file_name]
    defs: dict[str, Definition] = {}
    for name in names:
        bodies = library_bodies(name)
        if bodies is None:
            return None
        defs.update({n: Definition(n, params, "formula", body, 0)
                     for n, (params, body) in bodies.items()})
    return defs


def _library_definitions(part: list[Token], text, file) -> dict[str, Definition]:
    tok = part[0]
    name = unquote(tok.value)
    defs = library_definitions(name) if len(part) == 1 and name != "*" else None
    if defs is None:
        why = (f"ProB's {name} is not implemented: {NOT_IMPLEMENTED[name]}"
               if name in NOT_IMPLEMENTED else
               f"{tok.value} is no definition file (a name ending in .def, found beside "
               f"the machine) and not one of ProB's library files tracecheck implements")
        raise BSyntaxError(f"not supported: DEFINITIONS {tok.value}: {why}", file=file,
                           line=tok.line, column=tok.column, source=text,
                           hint="tracecheck knows " + ", ".join(LIBRARY_FILES)
                           + "; copy the definitions you need into the machine")
    return defs


def _parse_definition_body(name, params, body, eq_tok, text, file) -> Definition:
    line = eq_tok.line
    if len(body) == 1 and body[0].type == "STRING":
        return Definition(name, params, "string", unquote(body[0].value), line)
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
