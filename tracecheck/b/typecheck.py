"""Type inference for B, as ProB does it: every name gets one type, found by unification.

Types are ``INTEGER``, ``REAL``, ``BOOL``, ``STRING``, a deferred or enumerated set's
elements (``Vehicles``), ``POW(T)`` and ``T1*T2``; a function is a set of pairs. INTEGER and
REAL never mix (write ``0.0``, not ``0``, beside a real). Variables are typed by the
INVARIANT, constants by the PROPERTIES.
"""

from __future__ import annotations

import re
from typing import Optional

from ..errors import BScopeError, BTypeError, TracecheckError, UnsupportedError, did_you_mean
from . import ast
from ..limits import deeply
from .btypes import (BOOL, INTEGER, REAL, STRING, Base, TypeClash, Pow, Prod, Rec, Type, Var,
                     resolve, show, unify)
from .scope import check_kind, expand, kind_of, render
from .library import FUNCTIONS as _LIBRARY, call_type as _library_type

__all__ = ["typecheck_machine", "typecheck_formula", "check_formula", "Typer",
           "type_of_value", "describe_value_type", "unify_quiet", "untyped_real_parameters"]


_BUILTIN_TYPES = {
    "INTEGER": Pow(INTEGER), "NATURAL": Pow(INTEGER), "NATURAL1": Pow(INTEGER),
    "INT": Pow(INTEGER), "NAT": Pow(INTEGER), "NAT1": Pow(INTEGER), "REAL": Pow(REAL),
    "FLOAT": Pow(REAL), "BOOL": Pow(BOOL), "STRING": Pow(STRING), "MAXINT": INTEGER,
    "MININT": INTEGER,
}


#: B keywords tracecheck does not evaluate, with what they are (ProB's parser reads them).
UNSUPPORTED_KEYWORDS = {
    "tree": "trees", "btree": "trees", "bin": "trees", "left": "trees", "right": "trees",
    "sons": "trees", "father": "trees", "rank": "trees", "const": "trees", "top": "trees",
    "prefix": "trees", "postfix": "trees", "sizet": "trees", "mirror": "trees",
    "infix": "trees", "arity": "trees", "subtree": "trees", "son": "trees",
    "closure": "the reflexive closure over the whole type; write closure1(r) \\/ id(S)",
}


class Typer:
    """Infers types over formulas and substitutions in one scope of names."""

    def __init__(self, names: dict[str, Type], *, source: Optional[str] = None,
                 file: Optional[str] = None,
                 unknown_hint: str = "declare it as a constant or variable, or bind it") -> None:
        self.scopes: list[dict[str, Type]] = [names]
        self.source, self.file = source, file
        self.unknown_hint = unknown_hint

    # -- helpers
    def lookup(self, node: ast.Name) -> Type:
        name = node.id
        base = name[:-1] if name.endswith("'") else name[:-2] if name.endswith("$0") else name
        for scope in reversed(self.scopes):
            if base in scope:
                return scope[base]
        if base in _BUILTIN_TYPES:
            return _BUILTIN_TYPES[base]
        if base in UNSUPPORTED_KEYWORDS:
            raise UnsupportedError(f"not supported: {name} ({UNSUPPORTED_KEYWORDS[base]})",
                                   file=self.file, source=self.source,
                                   line=node.pos.line if node.pos else None,
                                   column=node.pos.column if node.pos else None)
        near = did_you_mean(base, {n for scope in self.scopes for n in scope})
        raise BScopeError(f"unknown identifier {name}", file=self.file, source=self.source,
                          line=node.pos.line if node.pos else None,
                          column=node.pos.column if node.pos else None,
                          hint=self.element_hint(base) or (f"{near} (else {self.unknown_hint})"
                                                           if near else self.unknown_hint))

    def element_hint(self, name: str) -> Optional[str]:
        """What to say of ``S7`` where S is a set with fewer elements (ProB names a deferred
        set's elements S1, S2, … up to its size)."""
        m = re.fullmatch(r"(.+?)([0-9]+)", name)
        if m is None:
            return None
        set_name = m.group(1)
        for scope in self.scopes:
            if scope.get(set_name) == Pow(Base(set_name)):
                names = sorted((n for n, t in scope.items() if t == Base(set_name)),
                               key=_natural)  # elements, not the variables typed by the set
                shown = ", ".join(names if len(names) <= 4 else [*names[:2], "…", names[-1]])
                return (f"the elements of {set_name} named here are {shown or 'none'} (ProB "
                        f"names a deferred set's elements {set_name}1, {set_name}2, … up to its"
                        f" size, from card({set_name}) = n or scope_{set_name}, else 2; a "
                        f"constant c : {set_name} takes the place of one)")
        return None

    def same(self, node: ast.Node, a: Type, b: Type, what: str = "") -> None:
        try:
            unify(a, b)
        except TypeClash:
            hint = None
            pair = {show(a), show(b)}
            if pair == {"INTEGER", "REAL"}:
                hint = ("INTEGER and REAL do not mix in B: write 1 for an integer and 1.0 for a "
                        "real, or convert with real(n) or floor(x)")
            raise BTypeError(
                f"type mismatch in `{render(node, self.source)}`: {what}{show(a)} vs {show(b)}",
                file=self.file, source=self.source, hint=hint,
                line=node.pos.line if node.pos else None,
                column=node.pos.column if node.pos else None) from None

    def numeric(self, node: ast.Node, t: Type) -> Type:
        self.same(node, t, Var(numeric=True), "expected a number: ")
        return t

    def bound(self, ids: tuple[str, ...]) -> dict[str, Type]:
        scope = {i: Var() for i in ids}
        self.scopes.append(scope)
        return scope

    # -- predicates and expressions
    def pred(self, node: ast.Node) -> None:
        if isinstance(node, (ast.And, ast.Or, ast.Implies, ast.Equiv)):
            self.pred(node.left)
            self.pred(node.right)
        elif isinstance(node, ast.Not):
            self.pred(node.operand)
        elif isinstance(node, ast.Rel):
            self.rel(node)
        elif isinstance(node, ast.Quant):
            if node.op == "!" and not isinstance(node.body, ast.Implies):
                raise BTypeError(
                    f"the body of `!{','.join(node.ids)}.(…)` must be an implication",
                    file=self.file, source=self.source,
                    line=node.pos.line if node.pos else None,
                    column=node.pos.column if node.pos else None,
                    hint=f"write !{','.join(node.ids)}.(x : S => P), as ProB's type checker "
                         "requires")
            self.bound(node.ids)
            try:
                self.pred(node.body)
            finally:
                self.scopes.pop()
        elif isinstance(node, ast.IfExpr):
            for c, v in node.branches:
                self.pred(c)
                self.pred(v)
            self.pred(node.else_)
        elif isinstance(node, ast.Let):
            self.bound(node.ids)
            try:
                self.pred(node.pred)
                self.pred(node.body)
            finally:
                self.scopes.pop()

    def rel(self, node: ast.Rel) -> None:
        left, right = self.expr(node.left), self.expr(node.right)
        op = node.op
        if op in ("=", "/="):
            self.same(node, left, right)
        elif op in ("<", "<=", ">", ">="):
            self.numeric(node.left, left)
            self.same(node, left, right)
        elif op in (":", "/:"):
            self.same(node, Pow(left), right)
        else:
            elem = Var()
            self.same(node.left, left, Pow(elem))
            self.same(node, left, right)

    def expr(self, node: ast.Node) -> Type:  # noqa: C901 - one branch per node type
        t = type(node)
        if t is ast.Name:
            return self.lookup(node)
        if t is ast.IntLit:
            return INTEGER
        if t is ast.RealLit:
            return REAL
        if t is ast.BoolLit:
            return BOOL
        if t is ast.StrLit:
            return STRING
        if t is ast.Pair:
            return Prod(self.expr(node.left), self.expr(node.right))
        if t is ast.Neg:
            return self.numeric(node, self.expr(node.operand))
        if t is ast.BinOp:
            return self.binop(node)
        if t is ast.Template:
            for hole in node.holes:
                self.expr(hole)
            return STRING
        if t is ast.SetExt:
            elem: Type = Var()
            for item in node.items:
                self.same(item, elem, self.expr(item), "set elements differ: ")
            return Pow(elem)
        if t is ast.Apply:
            fn = self.expr(node.fn)
            arg = self.expr(node.args[0])
            for a in node.args[1:]:
                arg = Prod(arg, self.expr(a))
            result = Var()
            self.same(node, fn, Pow(Prod(arg, result)), "function and argument: ")
            return result
        if t is ast.Call:
            return self.call(node)
        if t is ast.Image:
            a, b = Var(), Var()
            self.same(node.rel, self.expr(node.rel), Pow(Prod(a, b)))
            self.same(node.arg, self.expr(node.arg), Pow(a))
            return Pow(b)
        if t is ast.Inverse:
            a, b = Var(), Var()
            self.same(node.rel, self.expr(node.rel), Pow(Prod(a, b)))
            return Pow(Prod(b, a))
        if t in (ast.Comprehension, ast.Lambda, ast.QuantExpr):
            return self.binder_expr(node)
        if t in (ast.Record, ast.Struct, ast.Field):
            return self.record(node)
        if t is ast.IfExpr:
            result = Var()
            for c, v in node.branches:
                self.pred(c)
                self.same(v, result, self.expr(v), "IF branches differ: ")
            self.same(node.else_, result, self.expr(node.else_), "IF branches differ: ")
            return result
        if t is ast.Let:
            self.bound(node.ids)
            try:
                self.pred(node.pred)
                return self.expr(node.body)
            finally:
                self.scopes.pop()
        if t in (ast.And, ast.Or, ast.Implies, ast.Equiv, ast.Not, ast.Rel, ast.Quant):
            self.pred(node)
            return BOOL
        raise BTypeError(f"cannot type {t.__name__}")  # pragma: no cover

    def record(self, node) -> Type:
        """``rec(a: 1)`` (a record), ``struct(a: INTEGER)`` (a set of them), ``r'a``."""
        if isinstance(node, ast.Field):
            found = resolve(self.expr(node.record))
            if isinstance(found, Var):
                raise self.type_error(node, f"the type of `{render(node.record, self.source)}` "
                                      f"must be known before its field {node.name} is taken",
                                      hint="type the record first, e.g. r : struct(a: INTEGER)")
            if not isinstance(found, Rec):
                raise self.type_error(node, f"`{render(node.record, self.source)}` is not a "
                                      f"record but {show(found)}")
            fields = dict(found.fields)
            if node.name not in fields:
                raise self.type_error(node, f"the record type {show(found)} has no field "
                                      f"{node.name}")
            return fields[node.name]
        fields = []
        for name, value in node.fields:
            t = self.expr(value)
            if isinstance(node, ast.Struct):
                elem = Var()
                self.same(value, t, Pow(elem), "a struct field is a set: ")
                t = elem
            fields.append((name, t))
        rec = Rec(tuple(sorted(fields, key=lambda f: f[0])))
        return rec if isinstance(node, ast.Record) else Pow(rec)

    def type_error(self, node: ast.Node, message: str, hint: Optional[str] = None):
        return BTypeError(message, file=self.file, source=self.source, hint=hint,
                          line=node.pos.line if node.pos else None,
                          column=node.pos.column if node.pos else None)

    def binder_expr(self, node) -> Type:
        scope = self.bound(node.ids)
        try:
            self.pred(node.pred)
            key: Type = scope[node.ids[0]]
            for i in node.ids[1:]:
                key = Prod(key, scope[i])
            if isinstance(node, ast.Comprehension):
                return Pow(key if node.expr is None else self.expr(node.expr))
            value = self.expr(node.expr)
            if isinstance(node, ast.Lambda):
                return Pow(Prod(key, value))
            if node.op in ("SIGMA", "PI"):
                return self.numeric(node.expr, value)
            self.same(node.expr, value, Pow(Var()))
            return value
        finally:
            self.scopes.pop()

    def binop(self, node: ast.BinOp) -> Type:
        op = node.op
        left, right = self.expr(node.left), self.expr(node.right)
        if op in ("-->", "+->", "<->", ">->", ">+>", "-->>", "+->>", ">->>", ">+>>"):
            a, b = Var(), Var()
            self.same(node.left, left, Pow(a))
            self.same(node.right, right, Pow(b))
            return Pow(Pow(Prod(a, b)))
        if op == "..":
            self.same(node.left, left, INTEGER)
            self.same(node.right, right, INTEGER)
            return Pow(INTEGER)
        if op in ("-", "*") and isinstance(resolve(left), Pow):
            if op == "-":
                self.same(node, left, right)
                return left
            b = Var()
            self.same(node.right, right, Pow(b))
            return Pow(Prod(resolve(left).elem, b))
        if op in ("+", "-", "*", "/", "mod"):
            self.numeric(node.left, left)
            self.same(node, left, right)
            if op == "mod":
                self.same(node, left, INTEGER)
            return left
        if op == "**":
            self.numeric(node.left, left)
            self.same(node.right, right, INTEGER, "the exponent must be an INTEGER (ProB allows "
                      "only INTEGER ** INTEGER and REAL ** INTEGER): ")
            return left
        if op in (";", "><", "||"):  # r : a <-> b, s : (b, a or c) <-> d
            a, b, c, d = Var(), Var(), Var(), Var()
            self.same(node.left, left, Pow(Prod(a, b)))
            self.same(node.right, right, Pow(Prod({";": b, "><": a}.get(op, c), d)))
            return Pow({";": Prod(a, d), "><": Prod(a, Prod(b, d))}.get(
                op, Prod(Prod(a, c), Prod(b, d))))
        if op == "^":
            self.same(node.left, left, Pow(Prod(INTEGER, Var())))
            self.same(node, left, right)
            return left
        if op in ("->", "<-"):
            a = Var()
            seq, elem = (node.right, right), (node.left, left)
            if op == "<-":
                seq, elem = elem, seq
            self.same(seq[0], seq[1], Pow(Prod(INTEGER, a)))
            self.same(elem[0], elem[1], a)
            return seq[1]
        if op in ("/|\\", "\\|/"):
            self.same(node.left, left, Pow(Prod(INTEGER, Var())))
            self.same(node.right, right, INTEGER)
            return left
        if op in ("\\/", "/\\", "\\"):
            self.same(node.left, left, Pow(Var()))
            self.same(node, left, right)
            return left
        if op in ("<|", "<<|"):
            a, b = Var(), Var()
            self.same(node.right, right, Pow(Prod(a, b)))
            self.same(node.left, left, Pow(a))
            return right
        if op in ("|>", "|>>"):
            a, b = Var(), Var()
            self.same(node.left, left, Pow(Prod(a, b)))
            self.same(node.right, right, Pow(b))
            return left
        if op == "<+":
            self.same(node.left, left, Pow(Prod(Var(), Var())))
            self.same(node, left, right)
            return left
        raise BTypeError(f"cannot type the operator {op}")  # pragma: no cover

    def call(self, node: ast.Call) -> Type:
        name = node.name
        if name in _LIBRARY:  # ProB's library files (DEFINITIONS "LibraryReals.def")
            return _library_type(self, node)
        if name == "bool":
            self.pred(node.args[0])
            return BOOL
        if name in ("prj1", "prj2") and len(node.args) == 2:
            s, t = Var(), Var()
            self.same(node.args[0], self.expr(node.args[0]), Pow(s))
            self.same(node.args[1], self.expr(node.args[1]), Pow(t))
            return Pow(Prod(Prod(s, t), s if name == "prj1" else t))
        arg = self.expr(node.args[0])
        a, b = Var(), Var()
        if name == "iterate" and len(node.args) != 2:
            raise BTypeError(f"iterate takes two arguments (a relation, how many times), not "
                             f"{len(node.args)}", file=self.file, source=self.source,
                             line=node.pos.line, column=node.pos.column)
        if name == "iterate":
            self.same(node.args[0], arg, Pow(Prod(a, a)))
            self.same(node.args[1], self.expr(node.args[1]), INTEGER)
            return arg
        if name in ("fnc", "rel"):  # S <-> T to S +-> POW(T), and back
            self.same(node.args[0], arg, Pow(Prod(a, b if name == "fnc" else Pow(b))))
            return Pow(Prod(a, Pow(b) if name == "fnc" else b))
        if name in ("prj1", "prj2"):
            self.same(node.args[0], arg, Prod(a, b))
            return a if name == "prj1" else b
        if name in ("closure1", "closure"):
            self.same(node.args[0], arg, Pow(Prod(a, a)))
            return arg
        if name == "size":
            self.same(node.args[0], arg, Pow(Prod(INTEGER, a)))
            return INTEGER
        if name in ("first", "last"):
            self.same(node.args[0], arg, Pow(Prod(INTEGER, a)))
            return a
        if name in ("front", "tail", "rev"):
            self.same(node.args[0], arg, Pow(Prod(INTEGER, a)))
            return arg
        if name in ("seq", "seq1", "iseq", "iseq1", "perm"):
            self.same(node.args[0], arg, Pow(a))
            return Pow(Pow(Prod(INTEGER, a)))
        if name == "conc":
            self.same(node.args[0], arg, Pow(Prod(INTEGER, Pow(Prod(INTEGER, a)))))
            return Pow(Prod(INTEGER, a))
        if name == "card":
            self.same(node.args[0], arg, Pow(a))
            return INTEGER
        if name in ("dom", "ran"):
            self.same(node.args[0], arg, Pow(Prod(a, b)))
            return Pow(a if name == "dom" else b)
        if name in ("min", "max"):
            self.same(node.args[0], arg, Pow(Var(numeric=True)))
            return resolve(arg).elem
        if name in ("POW", "POW1", "FIN", "FIN1"):
            self.same(node.args[0], arg, Pow(a))
            return Pow(arg)
        if name in ("floor", "ceiling"):
            self.same(node.args[0], arg, REAL)
            return INTEGER
        if name == "real":
            self.same(node.args[0], arg, INTEGER)
            return REAL
        if name in ("RSQRT", "RABS"):
            self.same(node.args[0], arg, REAL)
            return REAL
        if name in ("abs", "succ", "pred"):
            self.same(node.args[0], arg, INTEGER)
            return INTEGER
        if name in ("union", "inter"):
            self.same(node.args[0], arg, Pow(Pow(a)))
            return Pow(a)
        if name == "id":
            self.same(node.args[0], arg, Pow(a))
            return Pow(Prod(a, a))
        raise BTypeError(f"cannot type {name}")  # pragma: no cover

    # -- substitutions
    def subst(self, s: ast.Subst) -> None:  # noqa: C901
        if isinstance(s, ast.Assign):
            for target, value in zip(s.targets, s.values):
                self.same(s, self.expr(target), self.expr(value), "assignment: ")
        elif isinstance(s, ast.BecomesIn):
            new: Type = self.lookup(ast.Name(s.ids[0], pos=s.pos))
            for i in s.ids[1:]:
                new = Prod(new, self.lookup(ast.Name(i, pos=s.pos)))
            self.same(s, Pow(new), self.expr(s.set), "'::' ")
        elif isinstance(s, ast.BecomesSuchThat):
            for i in s.ids:
                self.lookup(ast.Name(i, pos=s.pos))
            self.pred(s.pred)
        elif isinstance(s, (ast.Pre, ast.Assert)):
            self.pred(s.guard if isinstance(s, ast.Pre) else s.cond)
            self.subst(s.body)
        elif isinstance(s, (ast.Select, ast.IfSubst)):
            for c, b in s.branches:
                self.pred(c)
                self.subst(b)
            if s.else_ is not None:
                self.subst(s.else_)
        elif isinstance(s, (ast.Any, ast.LetSubst)):
            self.bound(s.ids)
            try:
                self.pred(s.pred)
                self.subst(s.body)
            finally:
                self.scopes.pop()
        elif isinstance(s, (ast.Parallel, ast.Sequence, ast.Choice)):
            for item in s.items:
                self.subst(item)
        elif isinstance(s, ast.VarSubst):
            self.bound(s.ids)
            try:
                self.subst(s.body)
            finally:
                self.scopes.pop()
        elif isinstance(s, ast.While):
            self.pred(s.cond)
            self.subst(s.body)
            self.pred(s.invariant)
            self.same(s.variant, self.expr(s.variant), INTEGER, "a VARIANT: ")


def typecheck_machine(machine) -> dict[str, str]:
    """Type every formula of ``machine``; the variables' and constants' types in B notation.

    Raises :class:`BTypeError` (or :class:`BScopeError`) with the location of the first
    problem, like ProB's type checker.
    """
    names: dict[str, Type] = {}
    for set_name, elems in machine.sets.items():
        names[set_name] = Pow(Base(set_name))
        if set_name in machine.enumerated:
            names.update({str(e): Base(set_name) for e in elems})
    for set_name, elems in machine.sets.items():  # ProB's S1, S2, … of a deferred set S
        if set_name not in machine.enumerated:
            names.update({str(e): Base(set_name) for e in elems if str(e) not in names
                          and re.fullmatch(re.escape(set_name) + "[0-9]+", str(e))})
    for c in machine.constants_declared:
        names[c] = Var()
    for v in machine.variables:
        names[v] = Var()
    typer = Typer(names, source=machine.source, file=machine.file)
    for node in (machine.properties_node, machine.invariant_node, *machine.assertion_nodes):
        if node is not None:
            typer.pred(node)
    if machine.initialisation is not None:
        typer.subst(machine.initialisation)
    for op in machine.operations.values():
        typer.bound(op.params + op.outputs)
        try:
            typer.subst(op.body)
        finally:
            typer.scopes.pop()
    machine.type_objects = names
    result = {}
    for name in (*machine.constants_declared, *machine.variables):
        t = show(names[name])
        if "?" in t:
            what = "constant" if name in machine.constants_declared else "variable"
            clause = "PROPERTIES" if what == "constant" else "INVARIANT"
            raise BTypeError(f"cannot infer the type of the {what} {name}", file=machine.file,
                             hint=f"add a typing predicate to the {clause}, e.g. {name} : REAL")
        result[name] = t
    return result


def _natural(name: str):
    m = re.fullmatch(r"(.*?)([0-9]+)", name)
    return (m.group(1), int(m.group(2))) if m else (name, -1)


# ------------------------------------------------------------------ values and states

_ELEMENTS = Base("ELEMENTS")  # elements of sets no machine declares (eval without a model)


def type_of_value(value, element_sets: Optional[dict] = None) -> Type:
    """The type of a concrete value (elements typed by the set that holds them)."""
    from .values import Elem, Record, SymbolicSet

    if type(value) is bool:
        return BOOL
    if type(value) is int:
        return INTEGER
    if type(value) is float:
        return REAL
    if isinstance(value, Elem):
        owner = (element_sets or {}).get(value)
        return Base(owner) if owner else _ELEMENTS
    if isinstance(value, str):
        return STRING
    if isinstance(value, tuple):
        return Prod(type_of_value(value[0], element_sets), type_of_value(value[1], element_sets))
    if isinstance(value, Record):
        return Rec(tuple((n, type_of_value(v, element_sets)) for n, v in value.fields))
    if isinstance(value, SymbolicSet):
        return Var()
    elem: Type = Var()
    for item in value:
        unify_quiet(elem, type_of_value(item, element_sets))
    return Pow(elem)


def unify_quiet(a: Type, b: Type) -> bool:
    try:
        unify(a, b)
        return True
    except TypeClash:
        return False


def describe_value_type(value, element_sets: Optional[dict] = None) -> str:
    return show(type_of_value(value, element_sets)).replace("?", "any")


@deeply
def typecheck_formula(node: ast.Node, names: dict[str, Type], *, kind: str = "predicate",
                      source: Optional[str] = None, file: Optional[str] = None,
                      unknown_hint: str = "give it a value in the state (--state FILE) or "
                                          "evaluate in a machine (--model MODEL)") -> Type:
    """Type ``node`` with ``names`` in scope; raises like :func:`typecheck_machine`."""
    typer = Typer(dict(names), source=source, file=file, unknown_hint=unknown_hint)
    if kind == "predicate":
        typer.pred(node)
        return BOOL
    return typer.expr(node)


@deeply
def check_formula(text: str, names: dict[str, Type], *, file: str,
                  definitions: Optional[dict] = None, kind: Optional[str] = None,
                  unknown_hint: Optional[str] = None) -> tuple[ast.Node, str]:
    """Parse ``text``, expand ``definitions``, check that predicates and expressions stand
    where they belong (``kind``: what the whole must be; None: either) and type it with
    ``names`` in scope — what every formula a user gives goes through (``eval``, and
    ``prove``'s assumptions and claims) before anything evaluates or translates it. Errors
    name ``file`` (a file, ``<expr>``, an option such as ``--assume``) and point into
    ``text``. Returns the node and its kind.

    >>> node, kind = check_formula("n + 1 > 2", {"n": INTEGER}, file="<expr>")
    >>> kind
    'predicate'
    """
    from .parser import parse_formula

    try:
        node = parse_formula(text, file=file, dotted=frozenset(n for n in names if "." in n))
        if definitions:
            node = expand(node, definitions)
        found = kind_of(node)
        check_kind(node, kind or found, source=text, context="the formula")
        hint = {"unknown_hint": unknown_hint} if unknown_hint else {}
        typecheck_formula(node, dict(names), kind=kind or found, source=text, file=file,
                          **hint)
    except TracecheckError as exc:
        raise exc.located(file=file, source=text) from None
    return node, kind or found


def untyped_real_parameters(machine) -> list[tuple[str, str]]:
    """The parameters (operation, parameter) the type checker makes REAL but no conjunct
    ``p : REAL`` of the guard types: tracecheck takes an operation's parameters as
    continuous actions only when each is typed so (:func:`.linear.real_parameters`).

    >>> from tracecheck.b.machine import load_machine_text
    >>> m = load_machine_text("MACHINE M VARIABLES v INVARIANT v : REAL INITIALISATION "
    ...     "v := 0.0 OPERATIONS PUSH(u) = PRE v + u <= 1.0 THEN skip END END")
    >>> untyped_real_parameters(m)
    [('PUSH', 'u')]
    """
    def conjuncts(node):
        return conjuncts(node.left) + conjuncts(node.right) if isinstance(node, ast.And) \
            else [node]

    out = []
    for name, op in machine.operations.items():
        if not op.params or op.guard is None:
            continue
        fresh = {p: Var(numeric=False) for p in op.params}
        try:
            typecheck_formula(op.guard, {**machine.type_objects, **fresh})
        except TracecheckError:
            continue
        typed = {c.left.id for c in conjuncts(op.guard) if isinstance(c, ast.Rel)
                 and c.op == ":" and isinstance(c.left, ast.Name)}
        out += [(name, p) for p, t in fresh.items() if resolve(t) == REAL and p not in typed]
    return out
