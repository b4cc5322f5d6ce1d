"""Scalar evaluation: a formula is compiled once into Python closures, then called per state.

``compile_formula(node)`` returns a function ``env -> value`` where ``env`` maps names to
values (constants, variables and bound variables). Compiling walks the AST once; calling
does no dispatch on node types, which keeps a guard over a 5-vehicle state in the
microseconds. No text is ever run as Python.
"""

from __future__ import annotations

import math
import operator
import re
from contextlib import contextmanager
from typing import Any, Callable, Optional

from ..errors import BTypeError, EvaluationError, TracecheckError, UnsupportedError, WellDefinednessError
from . import ast
from .scope import render
from .bindings import Binders
from .records import Records, element_hint, element_set, set_element
from .relations import Relations
from .sequences import Sequences
from ..limits import DEEP, MAX_INT_BITS, deep_recursion, deeply
from .memo import constant_number, folded, memoised
from .builtins import BUILTINS as _BUILTINS, UNSUPPORTED_HINTS as _UNSUPPORTED_HINTS, iterate as _iterate
from .library import FUNCTIONS as _LIBRARY, compile_call as _library_call
from .combined import SYMBOLS, combine
from .finite import finite as _finite
from .spaces import FunctionSpace, Projection
from .values import (BUILTIN_SET_VALUES, Interval, Product, SymbolicSet, brief, format_value, hashable, is_set, is_subset,
                     make_set, set_equal)

__all__ = ["Compiler", "compile_formula", "evaluate", "Env"]

Env = dict
Fn = Callable[[Env], Any]


class Compiler(Binders, Records, Sequences, Relations):
    """Turns AST nodes into closures; knows the source text for located messages."""

    def __init__(self, *, source: Optional[str] = None, file: Optional[str] = None) -> None:
        self.source = source
        self.file = file
        self.bound: list[str] = []
        self._free: dict = {}  # free names by node, see ast.free_names
        self._sizes: dict = {}  # sizes by node, see _size
        self._compiling = False  # inside compile: the calls for sub-formulas
        #: ``solver(pred, names, env, problem, one=False)``: every solution of ``pred`` for
        #: bound variables nothing walks (a list of {name: value}), or raises (``tracecheck
        #: eval`` gives one; without it such variables are refused); with ``one``, one
        #: solution or none, where ``pred`` is defined for every value of them
        self.solver: Optional[Callable] = None
        #: the machine's constants without a value, and why (Machine.unset_constants)
        self.unset: dict[str, str] = {}

    @contextmanager
    def binding(self, ids: tuple[str, ...]):
        """Compile inside the scope of bound variables ``ids``."""
        self.bound.extend(ids)
        try:
            yield
        finally:
            del self.bound[len(self.bound) - len(ids):]

    # -- errors
    def error(self, cls, node: ast.Node, message: str, hint: Optional[str] = None):
        pos = node.pos
        return cls(message, file=self.file, source=self.source, hint=hint,
                   line=pos.line if pos else None, column=pos.column if pos else None)

    def text(self, node: ast.Node) -> str:
        return render(node, self.source)

    def too_large(self, node: ast.Node, op: str) -> EvaluationError:
        """A limit, not an undefined value: an integer result over :data:`_MAX_INT_BITS`
        bits is refused before it is computed (its time and memory are the user's)."""
        return self.error(EvaluationError, node,
                          f"the integer result of {op} in `{self.text(node)}` has more than "
                          f"{_MAX_INT_BITS:,} bits; tracecheck does not compute it")

    def wd(self, node: ast.Node, message: str) -> WellDefinednessError:
        return self.error(WellDefinednessError, node, f"{message} in `{self.text(node)}`")

    # -- entry
    def compile(self, node: ast.Node, wrap: bool = True) -> Fn:
        """``node`` as a function of an environment; one for a formula nesting deeper than
        :data:`~tracecheck.limits.DEEP` runs with the recursion limit it needs (``wrap``
        false: the caller calls it with that limit raised)."""
        if self._compiling:
            return self._compile(node)
        self._compiling = True
        try:
            with deep_recursion():
                fn = self._compile(node)
        finally:
            self._compiling = False
        return deeply(fn) if wrap and ast.depth(node) > DEEP else fn

    def _compile(self, node: ast.Node) -> Fn:
        method = getattr(self, "c_" + type(node).__name__, None)
        if method is None:
            raise self.error(UnsupportedError, node,
                             f"tracecheck cannot evaluate {type(node).__name__} here")
        fn = method(node)
        if isinstance(node, _FOLDED) and (
                not isinstance(node, ast.Call) or node.name in ("prj1", "prj2")) and \
                ast.free_names(node, self._free) <= _CONSTANT_NAMES:
            return folded(fn)  # on literals and built-in sets (REAL * REAL, prj1(REAL, REAL))
        if (isinstance(node, _MEMO_TYPES)
                or (isinstance(node, ast.BinOp) and node.op in _SET_OPS)) \
                and not (ast.free_names(node, self._free) & set(self.bound)):
            return memoised(fn, node)
        if self.bound and isinstance(node, _HOISTED) and self._size(node) >= _HOISTED_SIZE:
            free = ast.free_names(node, self._free)
            bound = set(self.bound)
            # (a name like V10 may be an element of the set V: it reads V too)
            if free and not (free & bound) and not ({element_set(n) for n in free} & bound):
                # inside a binder, a formula of the state alone (the lander's reach in
                # {i | i : dom(surface) & … 1.5 * x - 200.0 - REACH …}): once per state,
                # not once per value bound (the binder binds in the same dict)
                return memoised(fn, node)
        return fn

    def _size(self, node: ast.Node) -> int:
        """How many nodes ``node`` has (remembered by node: asked at every level)."""
        hit = self._sizes.get(id(node))
        if hit is not None and hit[0] is node:
            return hit[1]
        size = 1 + sum(self._size(c) for c in ast.children(node))
        self._sizes[id(node)] = (node, size)
        return size

    # -- atoms
    def c_Name(self, node: ast.Name) -> Fn:
        name = node.id
        if name in BUILTIN_SET_VALUES:
            value = BUILTIN_SET_VALUES[name]
            return lambda env: value

        def get(env: Env) -> Any:
            try:
                return env[name]
            except KeyError:
                found = set_element(name, env)  # S3: an element of a deferred set S
                if found is not None:
                    return found
                if name in self.unset:
                    raise self.error(EvaluationError, node, f"the constant {name} has no "
                                     f"value: {self.unset[name]}",
                                     hint=f"fix it in the PROPERTIES ({name} = value)") \
                        from None
                raise self.error(EvaluationError, node, f"{name} has no value here",
                                 hint=element_hint(name, env) or "give it in the state, or "
                                 "declare it in the machine") from None
        return get

    def c_IntLit(self, node: ast.IntLit) -> Fn:
        value = node.value
        return lambda env: value

    c_RealLit = c_StrLit = c_BoolLit = c_IntLit

    def c_SetExt(self, node: ast.SetExt) -> Fn:
        items = [self.compile(i) for i in node.items]
        if all(isinstance(i, (ast.IntLit, ast.RealLit, ast.StrLit, ast.BoolLit))
               for i in node.items):
            value = make_set([i.value for i in node.items])
            return lambda env: value
        return lambda env: make_set([f(env) for f in items])

    def c_Template(self, node: ast.Template) -> Fn:
        holes = [(fmt, h, self.compile(h)) for fmt, h in zip(node.formats, node.holes)]
        for fmt, h, _ in holes:
            if fmt and not _TEMPLATE_FORMAT.fullmatch(fmt):
                raise self.error(UnsupportedError, h,
                                 f"not supported: the template option [{fmt}]",
                                 hint="tracecheck formats ${e} and $[Nf]{e} (N decimals)")
        texts = node.texts

        def template(env: Env) -> str:
            out = [texts[0]]
            for (fmt, h, fn), text in zip(holes, texts[1:]):
                v = fn(env)
                if fmt:
                    if type(v) is not float:
                        raise self.type_error(h, v, f"a real (for the option [{fmt}])")
                    out.append(f"{v:.{int(fmt[:-1])}f}")
                else:
                    out.append(v if type(v) is str else format_value(v))
                out.append(text)
            return "".join(out)
        return template

    def c_Pair(self, node: ast.Pair) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        return lambda env: (l(env), r(env))

    # -- arithmetic and set operators
    def c_Neg(self, node: ast.Neg) -> Fn:
        f = self.compile(node.operand)

        def neg(env: Env) -> Any:
            v = f(env)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.type_error(node.operand, v, "a number")
            return -v
        return neg

    def at(self, node: ast.Node, exc: TracecheckError) -> TracecheckError:
        """``exc`` located at ``node`` where it has no location yet."""
        if exc.line is None and node.pos is not None:
            exc.line, exc.column = node.pos.line, node.pos.column
            exc.located(file=self.file, source=self.source)
        return exc

    def equal(self, node: ast.Node, a: Any, b: Any) -> bool:
        """B equality: sets by their elements, however they are represented."""
        try:
            return a == b
        except TracecheckError as exc:
            raise self.at(node, exc) from None

    def type_error(self, node: ast.Node, value: Any, wanted: str) -> BTypeError:
        return self.error(BTypeError, node,
                          f"`{self.text(node)}` must be {wanted}, but its value is "
                          f"{brief(value)}")

    def c_BinOp(self, node: ast.BinOp) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        op = node.op
        if op in _ARROWS:
            return lambda env: FunctionSpace(op, l(env), r(env))
        if op == "..":
            return lambda env: Interval(self.int_of(node.left, l(env)),
                                        self.int_of(node.right, r(env)))
        impl = getattr(self, "op_" + _OP_NAMES[op])
        return impl(node, l, r)

    def int_of(self, node: ast.Node, v: Any) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.type_error(node, v, "an integer")
        return v

    def nums(self, node: ast.BinOp, a: Any, b: Any) -> None:
        for side, v in ((node.left, a), (node.right, b)):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.type_error(side, v, "a number")

    def real(self, node: ast.Node, v: Any) -> Any:
        """``v`` unless it is a real that overflowed (inf) or is not a number (NaN)."""
        if type(v) is float and not math.isfinite(v):
            raise self.wd(node, "the real result is not a number (NaN)" if v != v else
                          "the real result is out of range (overflow)")
        return v

    def op_add(self, node, l, r) -> Fn:
        def add(env: Env) -> Any:
            a, b = l(env), r(env)
            ta, tb = type(a), type(b)
            if ta is int and tb is int:
                return a + b
            if ta in _NUMBER and tb in _NUMBER:  # the common case first: two numbers
                v = a + b
                return v if v - v == 0.0 else self.real(node, v)  # finite, else refused
            self.nums(node, a, b)
            return self.real(node, a + b)
        return add

    def op_sub(self, node, l, r) -> Fn:
        def sub(env: Env) -> Any:
            a, b = l(env), r(env)
            if type(a) in _NUMBER and type(b) in _NUMBER:
                v = a - b
                return v if v - v == 0 else self.real(node, v)
            if isinstance(a, frozenset) and isinstance(b, frozenset):
                return a - b
            if is_set(a) and is_set(b):  # NATURAL - {3}: held symbolically
                try:
                    return combine("\\", a, b)
                except TracecheckError as exc:
                    raise self.at(node, exc) from None
            self.nums(node, a, b)
            return self.real(node, a - b)
        return sub

    def op_mul(self, node, l, r) -> Fn:
        def mul(env: Env) -> Any:
            a, b = l(env), r(env)
            if type(a) in _NUMBER and type(b) in _NUMBER:
                if type(a) is int and type(b) is int and \
                        a.bit_length() + b.bit_length() > _MAX_INT_BITS:
                    raise self.too_large(node, "*")
                v = a * b
                return v if v - v == 0 else self.real(node, v)
            if is_set(a) and is_set(b):
                if isinstance(a, SymbolicSet) or isinstance(b, SymbolicSet):
                    return Product(a, b)
                return make_set([(x, y) for x in a for y in b])
            self.nums(node, a, b)
            return self.real(node, a * b)
        return mul

    def op_div(self, node, l, r) -> Fn:
        def div(env: Env) -> Any:
            a, b = l(env), r(env)
            self.nums(node, a, b)
            if b == 0:
                raise self.wd(node, "division by zero")
            if type(a) is int and type(b) is int:
                q = abs(a) // abs(b)
                return q if (a >= 0) == (b > 0) else -q
            return self.real(node, a / b)
        return div

    def op_mod(self, node, l, r) -> Fn:
        def mod(env: Env) -> Any:
            a, b = self.int_of(node.left, l(env)), self.int_of(node.right, r(env))
            if a < 0 or b <= 0:
                raise self.wd(node, f"mod needs a ≥ 0 and b > 0 (here {a} mod {b})")
            return a % b
        return mod

    def op_pow(self, node, l, r) -> Fn:
        def power(env: Env) -> Any:
            a, b = l(env), r(env)
            self.nums(node, a, b)
            if type(b) is not int:
                raise self.type_error(node.right, b, "an integer (the exponent)")
            if type(a) is int:
                if b < 0:
                    raise self.wd(node, f"negative exponent {b} for an integer power")
                if abs(a) > 1 and b * math.log2(abs(a)) > _MAX_INT_BITS:
                    raise self.too_large(node, "**")
            try:
                return self.real(node, a ** b)
            except OverflowError:
                raise self.wd(node, "the real result is out of range (overflow)") from None
            except ZeroDivisionError:
                raise self.wd(node, "0.0 raised to a negative power") from None
        return power

    def op_union(self, node, l, r) -> Fn:
        return self.set_op(node, l, r, lambda a, b: a | b)

    def op_inter(self, node, l, r) -> Fn:
        return self.set_op(node, l, r, lambda a, b: a & b)

    def op_minus(self, node, l, r) -> Fn:
        return self.set_op(node, l, r, lambda a, b: a - b)

    def op_domres(self, node, l, r) -> Fn:
        return self.set_op(node, l, r, lambda s, rel: frozenset(p for p in rel if p[0] in s))

    def op_ranres(self, node, l, r) -> Fn:
        return self.set_op(node, l, r, lambda rel, s: frozenset(p for p in rel if p[1] in s))

    def op_domsub(self, node, l, r) -> Fn:
        return self.set_op(node, l, r,
                           lambda s, rel: frozenset(p for p in rel if p[0] not in s))

    def op_ransub(self, node, l, r) -> Fn:
        return self.set_op(node, l, r,
                           lambda rel, s: frozenset(p for p in rel if p[1] not in s))

    def op_override(self, node, l, r) -> Fn:
        def override(a, b):
            dom_b = {p[0] for p in b}
            return make_set([p for p in a if p[0] not in dom_b] + list(b))
        return self.set_op(node, l, r, override)

    def set_op(self, node, l, r, fn) -> Fn:
        def apply(env: Env) -> Any:
            a, b = l(env), r(env)
            if isinstance(a, frozenset) and isinstance(b, frozenset):
                return fn(a, b)
            if is_set(a) and is_set(b) and node.op in SYMBOLS:
                # a small side walked (NATURAL /\ (-2..2), (1..5) \ NATURAL1), else held
                # symbolically: NATURAL \ {3}, NAT \/ {-1}
                try:
                    return combine(node.op, a, b)
                except TracecheckError as exc:
                    raise self.at(node, exc) from None
            return fn(_finite(self, node.left, a), _finite(self, node.right, b))
        return apply

    # -- predicates
    def c_And(self, node: ast.And) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        return lambda env: l(env) and r(env)

    def c_Or(self, node: ast.Or) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        return lambda env: l(env) or r(env)

    def c_Implies(self, node: ast.Implies) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        return lambda env: (not l(env)) or bool(r(env))

    def c_Equiv(self, node: ast.Equiv) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        return lambda env: bool(l(env)) == bool(r(env))

    def c_Not(self, node: ast.Not) -> Fn:
        f = self.compile(node.operand)
        return lambda env: not f(env)

    def c_Rel(self, node: ast.Rel) -> Fn:
        l, r = self.compile(node.left), self.compile(node.right)
        op = node.op
        if op in ("<", "<=", ">", ">="):
            cmp = _CMP[op]
            constant = constant_number(node.right, r)
            if constant is not None:
                kind = type(constant)
                fn_arg = _name_applied_to_name(node.left)
                if fn_arg is not None:
                    fname, aname = fn_arg

                    def compare_applied(env: Env) -> bool:
                        # f(v) > c, the commonest guard shape: one closure, two dict lookups
                        try:
                            a = env[fname].map[env[aname]]
                        except (KeyError, AttributeError, TypeError):
                            a = l(env)  # the general path says what is wrong
                        if type(a) is not kind:
                            self.nums(node, a, constant)
                        return cmp(a, constant)
                    return compare_applied

                def compare_constant(env: Env) -> bool:
                    a = l(env)
                    if type(a) is not kind:
                        self.nums(node, a, constant)
                    return cmp(a, constant)
                return compare_constant

            def compare(env: Env) -> bool:
                a, b = l(env), r(env)
                if type(a) not in (int, float) or type(b) not in (int, float):
                    self.nums(node, a, b)
                return cmp(a, b)
            return compare
        if op == "=":
            return lambda env: self.equal(node, l(env), r(env))
        if op == "/=":
            return lambda env: not self.equal(node, l(env), r(env))
        if op in (":", "/:"):
            positive = op == ":"

            def member(env: Env) -> bool:
                a, s = l(env), r(env)
                if isinstance(s, frozenset):
                    try:
                        return (a in s) == positive
                    except TypeError:
                        return (hashable(a) in s) == positive
                if isinstance(s, SymbolicSet):
                    try:
                        return s.contains(a) == positive
                    except TracecheckError as exc:
                        raise self.at(node, exc) from None
                raise self.type_error(node.right, s, "a set")
            return member
        positive = not op.startswith("/")
        strict = "<<:" in op

        def subset(env: Env) -> bool:
            a, b = l(env), r(env)
            if not is_set(a):
                raise self.type_error(node.left, a, "a set")
            if not is_set(b):
                raise self.type_error(node.right, b, "a set")
            try:
                result = is_subset(a, b)
                if strict:
                    result = result and not set_equal(a, b)
            except TracecheckError as exc:
                raise self.at(node, exc) from None
            return result == positive
        return subset

    # -- quantifiers and binders
    def c_IfExpr(self, node: ast.IfExpr) -> Fn:
        branches = [(self.compile(c), self.compile(v)) for c, v in node.branches]
        other = self.compile(node.else_)

        def choose(env: Env) -> Any:
            for cond, value in branches:
                if cond(env):
                    return value(env)
            return other(env)
        return choose

    # -- application
    def c_Call(self, node: ast.Call) -> Fn:
        if node.name in _LIBRARY:  # ProB's library files (DEFINITIONS "LibraryReals.def")
            return _library_call(self, node)
        if node.name == "iterate" and len(node.args) == 2:
            r, n = self.compile(node.args[0]), self.compile(node.args[1])
            return lambda env: _iterate(self, node, r(env), n(env))
        impl = _BUILTINS.get(node.name)
        if impl is None:
            raise self.error(UnsupportedError, node, f"not supported: {node.name}",
                             hint=_UNSUPPORTED_HINTS.get(node.name))
        if node.name in ("prj1", "prj2") and len(node.args) == 2:
            s, t = self.compile(node.args[0]), self.compile(node.args[1])
            which = int(node.name[-1])
            return lambda env: Projection(which, s(env), t(env))
        if len(node.args) != 1 or node.name == "iterate":
            raise self.error(BTypeError, node, f"{node.name} takes "
                             f"{'two arguments' if node.name == 'iterate' else 'one argument'}"
                             f", not {len(node.args)}")
        arg = self.compile(node.args[0])
        return lambda env: impl(self, node, arg(env))


# ------------------------------------------------------------------ helpers

#: Nodes worth remembering per state: evaluated once even where definitions repeat them.
_NUMBER = frozenset({int, float})  # the types arithmetic takes as they are (not bool)
#: inside a binder, what is computed once per state where it reads no variable bound there
#: and has at least _HOISTED_SIZE nodes (smaller ones cost less than looking them up)
_HOISTED = (ast.BinOp, ast.Neg, ast.Call, ast.Apply, ast.IfExpr)
_HOISTED_SIZE = 6
#: what is computed once when compiling where it names nothing but built-in sets
_FOLDED = (ast.BinOp, ast.Neg, ast.Call)
_CONSTANT_NAMES = frozenset(BUILTIN_SET_VALUES)
_MEMO_TYPES = (ast.Comprehension, ast.QuantExpr, ast.Image, ast.Quant, ast.Lambda)
_SET_OPS = frozenset({"\\", "\\/", "/\\", "<|", "|>", "<<|", "|>>", "<+"})


def _name_applied_to_name(node: ast.Node) -> Optional[tuple[str, str]]:
    """(f, v) when ``node`` is ``f(v)`` with f and v plain names."""
    if (isinstance(node, ast.Apply) and isinstance(node.fn, ast.Name) and len(node.args) == 1
            and isinstance(node.args[0], ast.Name) and node.fn.id not in BUILTIN_SET_VALUES):
        return node.fn.id, node.args[0].id
    return None


_ARROWS = {"-->", "+->", "<->", ">->", ">+>", "-->>", "+->>", ">->>", ">+>>"}
_MAX_INT_BITS = MAX_INT_BITS
_OP_NAMES = {"+": "add", "-": "sub", "*": "mul", "/": "div", "mod": "mod", "**": "pow",
             ";": "comp", "><": "direct", "||": "parallel", "^": "concat", "->": "prepend", "<-": "append",
             "/|\\": "take", "\\|/": "drop",
             "\\/": "union", "/\\": "inter", "\\": "minus", "<|": "domres", "|>": "ranres",
             "<<|": "domsub", "|>>": "ransub", "<+": "override"}
_TEMPLATE_FORMAT = re.compile(r"\d{1,2}f")
_CMP = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


# ------------------------------------------------------------------ API


def compile_formula(node: ast.Node, *, source: Optional[str] = None,
                    file: Optional[str] = None) -> Fn:
    """Compile ``node`` into a function of an environment dict (evaluate it many times).

    Args:
        node: a parsed formula.
        source: its text, for located error messages.
        file: where it comes from.

    Returns:
        A function from an environment (names to values) to the formula's value.

    >>> from tracecheck.b.parser import parse_formula
    >>> f = compile_formula(parse_formula("x * x"))
    >>> f({"x": 3}), f({"x": 4})
    (9, 16)
    """
    return Compiler(source=source, file=file).compile(node)


def evaluate(node: ast.Node, env: dict, *, source: Optional[str] = None) -> Any:
    """Evaluate ``node`` once in ``env``.

    Args:
        node: a parsed formula (:func:`~tracecheck.b.parser.parse_formula`).
        env: the values of its free names.
        source: its text, for located error messages.

    Returns:
        Its value: a bool for a predicate, else a B value (int, float, set, …).

    Raises:
        EvaluationError: where it is not well-defined; UnsupportedError (a refusal, never a
            guess) where tracecheck cannot compute it exactly.

    >>> from tracecheck.b.parser import parse_formula
    >>> evaluate(parse_formula("card({x | x : 1..10 & x mod 3 = 0})"), {})
    3
    """
    return compile_formula(node, source=source)(dict(env))
