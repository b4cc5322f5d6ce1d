"""Machines made of machines, flattened as ProB flattens them: ``SEES``, ``USES``,
``INCLUDES``, ``IMPORTS``, ``EXTENDS`` and ``PROMOTES``, renaming (``INCLUDES r.M``) and
machine parameters (``INCLUDES M(3, COLOURS)``, with the included machine's
``CONSTRAINTS``).

The machines named are read from the folder of the machine that names them, then from the
folders of ``TRACECHECK_MACHINE_PATH`` (separated as ``PATH`` is), as ``M.mch``. Each is
lexed, never run; the flat machine is built from their tokens:

* sets, constants and their PROPERTIES (with the CONSTRAINTS of included machines, their
  parameters replaced by the values given) once per machine file; variables, INVARIANT,
  ASSERTIONS, INITIALISATION and operations once per inclusion, renamed ``r.x`` for
  ``INCLUDES r.M`` (sets and constants are never renamed, as in B);
* the INITIALISATION of the included machines first, then the machine's own;
* a call of an included operation in an operation (``r.Inc(2)``, ``v <-- Get``) is its
  body, the parameters replaced by the arguments and the outputs by the variables given;
* the operations of the machine, and those it PROMOTES (all of them for EXTENDS).

The flat text joins the files (:class:`~tracecheck.errors.JoinedText`), so an error in an
included machine is told in its own file and line. A machine with parameters of its own is
read with each scalar parameter a constant (its CONSTRAINTS among the PROPERTIES) and each
set parameter (upper case) a deferred set, as ProB reads it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from lark import Token

from ..errors import BScopeError, BSyntaxError, JoinedText
from ..inputs import read_text
from .builder import unquote
from .clauses import (CLAUSES, CLOSERS as _CLOSERS, OPENERS as _OPENERS, UNSUPPORTED_CLAUSES,
                      merge_dotted)
from .library import LIBRARY_FILES, NOT_IMPLEMENTED

__all__ = ["COMPOSITION_CLAUSES", "compose", "search_folders"]

#: The clauses that name other machines, and a machine's own parameters' constraints.
COMPOSITION_CLAUSES = ("SEES", "USES", "INCLUDES", "IMPORTS", "EXTENDS", "PROMOTES",
                       "CONSTRAINTS")
_NAMING = ("SEES", "USES", "INCLUDES", "IMPORTS", "EXTENDS")
_CONSTANT_CLAUSES = ("CONSTANTS", "CONCRETE_CONSTANTS", "ABSTRACT_CONSTANTS")
_VARIABLE_CLAUSES = ("VARIABLES", "CONCRETE_VARIABLES", "ABSTRACT_VARIABLES")
#: machines nested deeper than this are refused (a cycle is found before)
MAX_NESTING = 32


def search_folders(file: Optional[str]) -> list[Path]:
    """Where the machines a machine names are looked for: its own folder, then each folder
    of ``TRACECHECK_MACHINE_PATH``."""
    out = [Path(file).resolve().parent] if file else [Path.cwd()]
    out += [Path(p) for p in os.environ.get("TRACECHECK_MACHINE_PATH", "").split(os.pathsep)
            if p]
    return out


@dataclass
class _Op:
    name: str
    params: list[str]
    outputs: list[str]
    header: list[Token]
    body: list[Token]


@dataclass
class _Unit:
    """One machine, flattened (its own inclusions done), its tokens placed in the joint
    text."""

    name: str
    file: str
    params: list[str]
    clauses: dict[str, list[Token]] = field(default_factory=dict)
    # what the including machine gets: the sets/constants part once per file
    context: dict[str, list[list[Token]]] = field(default_factory=dict)
    variables: list[str] = field(default_factory=list)
    operations: dict[str, _Op] = field(default_factory=dict)
    inits: list[tuple[list[Token], frozenset]] = field(default_factory=list)


class _Composer:
    def __init__(self, lex) -> None:
        self.lex = lex  # text -> tokens (the parser's lexer)
        self.parts: list[tuple[Optional[str], str]] = []
        self.comments: list[Token] = []
        self.offset = self.lines = 0
        self.seen_files: set[str] = set()  # whose sets and constants are in already

    def place(self, text: str, file: Optional[str]) -> list[Token]:
        """Lex ``text`` and place its tokens (and comments) after the texts placed before."""
        toks, comments = self.lex(text, file)
        offset, lines = self.offset, self.lines
        self.parts.append((file, text))
        self.offset += len(text) + 1
        self.lines += text.count("\n") + 1

        def moved(t: Token) -> Token:
            return Token(t.type, t.value, t.start_pos + offset, t.line + lines, t.column,
                         t.end_line + lines, t.end_column, t.end_pos + offset)
        self.comments += [moved(c) for c in comments]
        return [moved(t) for t in toks]

    def error(self, cls, message: str, tok: Optional[Token], hint: Optional[str] = None):
        joined = JoinedText(self.parts)
        return cls(message, line=tok.line if tok else None, column=tok.column if tok else None,
                   source=joined, hint=hint)

    # -- one machine
    def unit(self, toks: list[Token], file: str, folders: list[Path], chain: tuple) -> _Unit:
        clauses = _clauses(toks)
        _check_clauses(toks, clauses, self)
        header = clauses.pop("MACHINE")
        name, params = header[0].value, [t.value for t in header[1:] if t.type == "NAME"]
        unit = _Unit(name, file, params)
        prefixes: dict[str, _Unit] = {}
        included: list[tuple[Optional[str], _Unit, str]] = []
        for kw in _NAMING:
            for item in _split(clauses.pop(kw, []), "COMMA"):
                prefix, mname, args = _reference(item, self)
                sub = self.load(mname, item[0], folders, chain)
                if args and len(args) != len(sub.params):
                    raise self.error(BScopeError, f"{mname} has {len(sub.params)} "
                                     f"parameter(s), {len(args)} given", item[0])
                if sub.params and not args and kw not in ("SEES", "USES"):
                    raise self.error(BScopeError, f"{mname} has parameters "
                                     f"({', '.join(sub.params)}); give their values: "
                                     f"{mname}({', '.join(sub.params)})", item[0])
                sub = _instantiated(sub, dict(zip(sub.params, args)), prefix)
                if prefix:
                    prefixes[prefix] = sub
                included.append((prefix, sub, kw))
        promoted = [t for t in clauses.pop("PROMOTES", []) if t.type != "COMMA"]
        own = {k: merge_dotted(v, lambda r, _: r in prefixes) for k, v in clauses.items()}
        promoted = merge_dotted(promoted, lambda r, _: r in prefixes)
        callable_ops: dict[str, _Op] = {}
        for _, sub, kw in included:
            for key, part in sub.context.items():
                unit.context.setdefault(key, []).extend(part)
            if kw in ("INCLUDES", "IMPORTS", "EXTENDS"):
                callable_ops.update(sub.operations)
            unit.variables += sub.variables
            for key in ("INVARIANT", "ASSERTIONS"):
                if sub.clauses.get(key):
                    unit.clauses.setdefault(key + "*", []).append(sub.clauses[key])
            unit.inits += sub.inits
            if kw == "EXTENDS":
                unit.operations.update(sub.operations)
        for tok in promoted:
            if tok.value not in callable_ops:
                raise self.error(BScopeError, f"PROMOTES {tok.value}: no included machine "
                                 "has this operation", tok)
            unit.operations[tok.value] = callable_ops[tok.value]
        if own.get("DEFINITIONS"):
            own["DEFINITIONS"] = self.definitions(own["DEFINITIONS"], folders, chain)
        # the machine's own part
        if file not in self.seen_files:
            self.seen_files.add(file)
            for key in ("SETS", *_CONSTANT_CLAUSES, "PROPERTIES", "DEFINITIONS"):
                if own.get(key):
                    unit.context.setdefault(key, []).append(own[key])
        for key in _VARIABLE_CLAUSES:
            unit.variables += [t.value for t in own.get(key, []) if t.type == "NAME"]
        for key in ("INVARIANT", "ASSERTIONS"):
            if own.get(key):
                unit.clauses.setdefault(key + "*", []).append(own[key])
        if own.get("CONSTRAINTS"):
            unit.clauses["CONSTRAINTS"] = own["CONSTRAINTS"]
        if own.get("INITIALISATION"):
            mine = frozenset(t.value for k in _VARIABLE_CLAUSES for t in own.get(k, []))
            unit.inits.append((_inline(own["INITIALISATION"], callable_ops, self), mine))
        for op in _operations(own.get("OPERATIONS", []), self):
            op.body = _inline(op.body, callable_ops, self)
            if op.name in unit.operations:
                raise self.error(BScopeError, f"the operation {op.name} is also promoted "
                                 "from an included machine", op.header[0])
            unit.operations[op.name] = op
        return unit

    def find(self, file_name: str, what: str, at: Token, folders: list[Path]) -> Path:
        for folder in folders:
            path = folder / file_name
            if path.is_file():
                return path
        raise self.error(BScopeError, f"no {what}: {file_name} is in none of "
                         f"{', '.join(str(f) for f in folders)}", at,
                         hint="put it beside the machine, or name its folder in "
                              "TRACECHECK_MACHINE_PATH")

    def definitions(self, toks: list[Token], folders: list[Path], chain: tuple
                    ) -> list[Token]:
        """A DEFINITIONS clause with each file of the user's own (``"defs.def"``) in place
        of its name: the definitions that file's own DEFINITIONS clause holds."""
        parts = []
        for part in _split(toks, "SEMI"):
            name = _own_definition_files(part)
            if not name or len(part) != 1:
                parts.append(part)
                continue
            path = self.find(name[0], f"definition file {name[0]}", part[0], folders)
            key = str(path.resolve())
            if key in chain or len(chain) > MAX_NESTING:
                raise self.error(BScopeError, f"{name[0]} includes itself", part[0])
            placed = self.place(read_text(path, "definition file"), str(path))
            if not placed or placed[0].value != "DEFINITIONS":
                raise self.error(BSyntaxError, f"{path} does not start with DEFINITIONS (a "
                                 "definition file holds one DEFINITIONS clause)",
                                 placed[0] if placed else part[0])
            body = placed[1:-1] if placed[-1].type == "END" else placed[1:]
            if body:
                parts.append(self.definitions(body, [path.resolve().parent] + folders[1:],
                                              chain + (key,)))
        return _join(parts, "SEMI", toks[0]) if parts else []

    def load(self, name: str, at: Token, folders: list[Path], chain: tuple) -> _Unit:
        path = self.find(f"{name}.mch", f"machine {name}", at, folders)
        key = str(path.resolve())
        if key in chain or len(chain) > MAX_NESTING:
            raise self.error(BScopeError, f"{name} includes itself (through "
                             f"{' -> '.join(Path(c).stem for c in chain)})", at)
        toks = self.place(read_text(path, "machine file"), str(path))
        if not toks or toks[0].value != "MACHINE":
            raise self.error(BSyntaxError, f"{path} is no MACHINE (tracecheck reads "
                             "abstract machines only)", toks[0] if toks else at)
        return self.unit(toks, key, [path.resolve().parent] + folders[1:], chain + (key,))


def compose(text: str, toks: list[Token], file: Optional[str], lex
            ) -> Optional[tuple[JoinedText, list[Token], list[Token]]]:
    """The flat machine of a machine that names others or has parameters, as (its joint
    text, its tokens, the comments); None for a machine that does neither (read as it is).

    Args:
        text: the machine's text.
        toks: its tokens.
        file: its path.
        lex: ``(text, file) -> (tokens, comments)``, the parser's lexer.
    """
    clauses = _clauses(toks)
    header = clauses.get("MACHINE", [])
    if not any(k in clauses for k in COMPOSITION_CLAUSES) and len(header) <= 1 and \
            not _own_definition_files(clauses.get("DEFINITIONS", [])):
        return None
    composer = _Composer(lex)
    placed = composer.place(text, file)
    unit = composer.unit(placed, file or "<model>", search_folders(file), (file or "",))
    return JoinedText(composer.parts), _flat(unit, placed), composer.comments


# ------------------------------------------------------------------ building the flat machine


def _flat(unit: _Unit, placed: list[Token]) -> list[Token]:
    at = placed[0]
    out: list[Token] = [at, Token("NAME", unit.name, at.start_pos, at.line, at.column,
                                  at.end_line, at.end_column, at.end_pos)]
    sets = list(unit.context.get("SETS", []))
    constants = [p for k in _CONSTANT_CLAUSES for p in unit.context.get(k, [])]
    properties = list(unit.context.get("PROPERTIES", []))
    for name in unit.params:  # the machine's own parameters: ProB's way
        tok = _named(at, name)
        (sets if name.isupper() else constants).append([tok])
    if unit.clauses.get("CONSTRAINTS"):
        properties.append(unit.clauses["CONSTRAINTS"])
    _clause(out, at, "SETS", _join(sets, "SEMI", at))
    _clause(out, at, "CONSTANTS", _join(constants, "COMMA", at))
    _clause(out, at, "PROPERTIES", _conjunction(properties, at))
    _clause(out, at, "DEFINITIONS", _join(unit.context.get("DEFINITIONS", []), "SEMI", at))
    _clause(out, at, "VARIABLES", _join([[_named(at, v)] for v in unit.variables], "COMMA", at))
    _clause(out, at, "INVARIANT", _conjunction(unit.clauses.get("INVARIANT*", []), at))
    _clause(out, at, "ASSERTIONS", _join(unit.clauses.get("ASSERTIONS*", []), "SEMI", at))
    _clause(out, at, "INITIALISATION", _sequence(unit.inits, at))
    ops = [op.header + [_sym(op.header[-1], "EQ", "=")] + _block(op.body, op.header[0])
           for op in unit.operations.values()]
    _clause(out, at, "OPERATIONS", _join(ops, "SEMI", at))
    out.append(_sym(placed[-1], "END", "END"))
    return out


def _clause(out: list[Token], at: Token, name: str, body: list[Token]) -> None:
    if body:
        out.append(_named(at, name))
        out.extend(body)


def _sym(at: Token, type_: str, value: str) -> Token:
    return Token(type_, value, at.start_pos, at.line, at.column, at.line, at.column,
                 at.start_pos)


def _named(at: Token, value: str) -> Token:
    return _sym(at, "NAME", value)


def _join(parts: list[list[Token]], sep: str, at: Token) -> list[Token]:
    out: list[Token] = []
    for part in parts:
        if out:
            out.append(_sym(part[0], sep, {"SEMI": ";", "COMMA": ","}[sep]))
        out += part
    return out


def _conjunction(parts: list[list[Token]], at: Token) -> list[Token]:
    out: list[Token] = []
    for part in parts:
        if out:
            out.append(_sym(part[0], "AND", "&"))
        out += [_sym(part[0], "LPAR", "(")] + part + [_sym(part[-1], "RPAR", ")")]
    return out


def _block(body: list[Token], at: Token) -> list[Token]:
    return [_sym(body[0] if body else at, "BEGIN", "BEGIN")] + body + [
        _sym(body[-1] if body else at, "END", "END")]


def _sequence(parts: list[tuple[list[Token], frozenset]], at: Token) -> list[Token]:
    """The initialisations in order: in parallel where none reads a variable an earlier
    one sets (``||`` takes any substitution), else in sequence."""
    set_before: set = set()
    parallel = True
    for toks, names in parts:
        parallel = parallel and not ({t.value for t in toks if t.type == "NAME"} & set_before)
        set_before |= names
    out: list[Token] = []
    for toks, _ in parts:
        if out:
            out.append(_sym(toks[0], "PARALLEL", "||") if parallel else
                       _sym(toks[0], "SEMI", ";"))
        out += _block(toks, at)
    return [_sym(at, "BEGIN", "BEGIN")] + out + [_sym(at, "END", "END")] if out else []


# ------------------------------------------------------------------ token helpers


def _clauses(toks: list[Token]) -> dict[str, list[Token]]:
    """The machine's clauses by keyword (the last END left out)."""
    known = set(CLAUSES) | set(COMPOSITION_CLAUSES) | set(UNSUPPORTED_CLAUSES)
    out: dict[str, list[Token]] = {}
    current, depth = None, 0
    for tok in toks[:-1]:
        depth += (tok.type in _OPENERS) - (tok.type in _CLOSERS)
        value = "INITIALISATION" if tok.value == "INITIALIZATION" else tok.value
        if depth == 0 and tok.type in ("NAME", tok.value) and value in known:
            current = value
            out.setdefault(current, [])
        elif current is not None:
            out[current].append(tok)
    return out


def _check_clauses(toks: list[Token], clauses: dict, composer: "_Composer") -> None:
    """A clause with nothing in it, or a header that is not ``M`` or ``M(p, …)``, is an error
    (as for a machine read on its own)."""
    header = clauses.get("MACHINE", [])
    kinds = [t.type for t in header]
    if not header or header[0].type != "NAME" or (len(header) > 1 and (
            kinds[1] != "LPAR" or kinds[-1] != "RPAR" or len(kinds) < 4
            or kinds[2:-1] != ["NAME", "COMMA"] * (len(kinds) // 2 - 2) + ["NAME"])):
        raise composer.error(BSyntaxError, "expected the machine's name, or M(p, …) with "
                             "its parameters, after MACHINE", header[0] if header else toks[0])
    for tok in toks[:-1]:
        if tok.value in clauses and tok.type in ("NAME", tok.value):
            if tok.value in UNSUPPORTED_CLAUSES:
                raise composer.error(BSyntaxError, f"the clause {tok.value} is not supported "
                                     "by tracecheck (it reads abstract machines)", tok)
            if not clauses[tok.value]:
                raise composer.error(BSyntaxError, f"the {tok.value} clause is empty", tok)


def _own_definition_files(toks: list[Token]) -> list[str]:
    """The definition files named in a DEFINITIONS clause that are not ProB's library
    files (those tracecheck implements itself)."""
    names = [unquote(t.value) for t in toks if t.type == "STRING"]
    return [n for n in names if n.endswith(".def") and n not in LIBRARY_FILES
            and n not in NOT_IMPLEMENTED]


def _split(toks: list[Token], sep: str) -> list[list[Token]]:
    parts: list[list[Token]] = [[]]
    depth = 0
    for tok in toks:
        depth += (tok.type in _OPENERS) - (tok.type in _CLOSERS)
        if tok.type == sep and depth == 0:
            parts.append([])
        else:
            parts[-1].append(tok)
    return [p for p in parts if p]


def _reference(item: list[Token], composer: _Composer):
    """``r.M(a, b)``: (r or None, M, [tokens of a, tokens of b])."""
    names = [item[0]]
    k = 1
    while k + 1 < len(item) and item[k].type == "DOT" and item[k + 1].type == "NAME":
        names.append(item[k + 1])
        k += 2
    if names[0].type != "NAME" or len(names) > 2:
        raise composer.error(BSyntaxError, "expected a machine's name, or r.M to rename it",
                             item[0])
    args: list[list[Token]] = []
    rest = item[k:]
    if rest:
        if rest[0].type != "LPAR" or rest[-1].type != "RPAR":
            raise composer.error(BSyntaxError, "expected M(value, …) after a machine's name",
                                 rest[0])
        args = _split(rest[1:-1], "COMMA")
    prefix = names[0].value if len(names) == 2 else None
    return prefix, names[-1].value, args


def _instantiated(sub: _Unit, values: dict[str, list[Token]], prefix: Optional[str]) -> _Unit:
    """``sub`` with its parameters replaced by ``values`` and, for ``r.M``, its variables
    and operations renamed ``r.x``."""
    renames = {}
    if prefix:
        renames = {v: f"{prefix}.{v}" for v in list(sub.variables) + list(sub.operations)}

    def fix(toks: list[Token]) -> list[Token]:
        out: list[Token] = []
        for tok in toks:
            if tok.type == "NAME" and tok.value in values:
                arg = values[tok.value]
                out += arg if len(arg) == 1 else \
                    [_sym(arg[0], "LPAR", "(")] + arg + [_sym(arg[-1], "RPAR", ")")]
            elif tok.type == "NAME" and (new_name := _renamed(tok.value, renames)):
                out.append(Token.new_borrow_pos("NAME", new_name, tok))
            else:
                out.append(tok)
        return out

    new = _Unit(sub.name, sub.file, [])
    new.context = {k: [fix(p) for p in parts] for k, parts in sub.context.items()}
    if sub.clauses.get("CONSTRAINTS"):
        new.context.setdefault("PROPERTIES", []).append(fix(sub.clauses["CONSTRAINTS"]))
    new.clauses = {k: [fix(p) for p in v] if k.endswith("*") else fix(v)
                   for k, v in sub.clauses.items() if k != "CONSTRAINTS"}
    new.variables = [renames.get(v, v) for v in sub.variables]
    new.inits = [(fix(p), frozenset(renames.get(v, v) for v in names))
                 for p, names in sub.inits]
    for name, op in sub.operations.items():
        header = fix(op.header)
        new.operations[renames.get(name, name)] = _Op(
            renames.get(name, name), op.params, op.outputs, header, fix(op.body))
    return new


def _renamed(name: str, renames: dict[str, str]) -> Optional[str]:
    """``name`` renamed, also as the value before a step (``x$0``, ``x′``)."""
    if name in renames:
        return renames[name]
    base = name.rstrip("\u2032\u2018\u2019")
    base = base[:-2] if base.endswith("$0") and base not in renames else base
    return renames[base] + name[len(base):] if base in renames else None


def _operations(toks: list[Token], composer: _Composer) -> list[_Op]:
    ops = []
    for part in _split(toks, "SEMI"):
        eq = next((i for i, t in enumerate(part) if t.type == "EQ"), None)
        if eq is None:
            raise composer.error(BSyntaxError, "an operation needs '=' after its header",
                                 part[0])
        header, body = part[:eq], part[eq + 1:]
        out_at = next((i for i, t in enumerate(header) if t.type == "OUTPUT"), None)
        outputs = [t.value for t in header[:out_at] if t.type == "NAME"] \
            if out_at is not None else []
        rest = header[out_at + 1:] if out_at is not None else header
        if not rest or rest[0].type != "NAME":
            raise composer.error(BSyntaxError, "an operation needs a name before its '='",
                                 (rest or part)[0])
        name = rest[0].value
        params = [t.value for t in rest[1:] if t.type == "NAME"]
        ops.append(_Op(name, params, outputs, header, body))
    return ops


def _inline(body: list[Token], ops: dict[str, _Op], composer: _Composer) -> list[Token]:
    """The calls of included operations in ``body`` replaced by their bodies."""
    if not ops:
        return body
    out: list[Token] = []
    k = 0
    while k < len(body):
        tok = body[k]
        if tok.type == "NAME" and tok.value in ops:
            op = ops[tok.value]
            args: list[list[Token]] = []
            end = k + 1
            if end < len(body) and body[end].type == "LPAR":
                depth, close = 0, end
                for close in range(end, len(body)):
                    depth += (body[close].type in _OPENERS) - (body[close].type in _CLOSERS)
                    if depth == 0:
                        break
                args = _split(body[end + 1:close], "COMMA")
                end = close + 1
            targets: list[Token] = []
            if out and out[-1].type == "OUTPUT":
                out.pop()
                while out and out[-1].type == "NAME":
                    targets.insert(0, out.pop())
                    if out and out[-1].type == "COMMA":
                        out.pop()
                    else:
                        break
            if len(args) != len(op.params) or len(targets) != len(op.outputs):
                raise composer.error(
                    BScopeError, f"{tok.value} takes {len(op.params)} argument(s) and gives "
                    f"{len(op.outputs)} output(s); called with {len(args)} and "
                    f"{len(targets)}", tok)
            values = dict(zip(op.params, args))
            values.update({o: [t] for o, t in zip(op.outputs, targets)})
            called = _Unit("", "", [])
            called.operations = {op.name: _Op(op.name, [], [], op.header, op.body)}
            inlined = _instantiated(called, values, None).operations[op.name].body
            out += _block(inlined, tok)
            k = end
        else:
            out.append(tok)
            k += 1
    return out
