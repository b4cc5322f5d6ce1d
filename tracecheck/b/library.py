"""ProB's standard library definition files, implemented natively.

``DEFINITIONS "LibraryReals.def"`` (or ``"CHOOSE.def"``, ``"SORT.def"``,
``"LibraryStrings.def"``) makes that file's functions available with ProB's names: each
becomes a definition whose body is a call of the function (``RSIN(x) == RSIN(x)``), typed,
evaluated and checked for well-definedness here, on the scalar and the batch path alike.
ProB's own ``.def`` files only declare external (Prolog) functions, so nothing is read from
them. A function whose exact meaning in ProB is not documented is listed but refused where
it is used (:class:`UnsupportedError`), never guessed.

Sources: ProB's wiki pages "Reals and Floats" and "External Functions" and the notebooks of
hhu-stups/prob2_jupyter_kernel (``notebooks/manual/FloatsReals.ipynb``,
``ExternalFunctions.ipynb``); their examples are in ``tests/b/corpus/expressions.txt``.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from decimal import ROUND_HALF_UP, Decimal
from typing import Any, Callable, Optional


from .regex import MAX_RESULT
from ..errors import BTypeError, UnsupportedError, WellDefinednessError
from . import ast
from .btypes import BOOL, INTEGER, REAL, STRING, Pow, Prod, Type, Var
from .values import FuncValue, SymbolicSet, explicit, format_value, sequence

__all__ = ["LIBRARY_FILES", "NOT_IMPLEMENTED", "FUNCTIONS", "library_bodies", "call_type",
           "compile_call", "vector_call"]


class Undefined(Exception):
    """The call is not well-defined (the message says why)."""


class Refused(Exception):
    """ProB's answer for these arguments is not documented (the message says why)."""


@dataclass(frozen=True)
class Function:
    name: str
    signature: Callable[[], tuple[tuple[Type, ...], Type]]  # fresh types at every use
    impl: Optional[Callable[..., Any]]  # None: known but refused (``why``)
    why: str = ""
    floats: bool = False  # REAL arguments to a REAL: the batch path runs it element-wise
    predicate: bool = False  # used as a predicate (its call is compared with TRUE)

    @property
    def arity(self) -> int:
        return len(self.signature()[0])


def _sig(*types: Type) -> Callable[[], tuple[tuple[Type, ...], Type]]:
    return lambda: (types[:-1], types[-1])


def _real(fn: Callable[..., float]) -> Callable[..., float]:
    """A function of reals whose result must be a finite real (else not well-defined)."""
    def real(*xs: float) -> float:
        try:
            r = fn(*xs)
        except (ValueError, ZeroDivisionError, OverflowError):
            r = math.nan
        if not math.isfinite(r):
            raise Undefined("the result is not a finite real")
        return float(r)
    return real


def _positive(fn: Callable[[float], float], what: str) -> Callable[[float], float]:
    def checked(x: float) -> float:
        if not x > 0.0:
            raise Undefined(f"{what} of the non-positive number {x!r}")
        return fn(x)
    return checked


def _log(b: float, x: float) -> float:
    if not (x > 0.0 and b > 0.0 and b != 1.0):
        raise Undefined(f"the logarithm of {x!r} to the base {b!r} (needs x > 0.0, b > 0.0 "
                        "and b /= 1.0)")
    return math.log(x) / math.log(b)  # SICStus' log(B, X), the same quotient


def _div(x: float, y: float) -> float:
    if y == 0.0:
        raise Undefined("division by zero")
    return x / y


def _sign(x: float) -> float:
    return 1.0 if x > 0.0 else -1.0 if x < 0.0 else x


_RR, _RRR, _RRB = _sig(REAL, REAL), _sig(REAL, REAL, REAL), _sig(REAL, REAL, BOOL)
_UNDOCUMENTED = "ProB's exact definition (rounding, result type) is not documented"


def _reals() -> dict[str, Function]:
    lib: dict[str, Function] = {}
    libm = {"RSIN": math.sin, "RCOS": math.cos, "RTAN": math.tan, "RSINH": math.sinh,
            "RCOSH": math.cosh, "RTANH": math.tanh, "RASIN": math.asin, "RACOS": math.acos,
            "RATAN": math.atan, "RASINH": math.asinh, "RACOSH": math.acosh,
            "RATANH": math.atanh, "REXP": math.exp}
    for name, fn in libm.items():
        lib[name] = Function(name, _RR, _real(fn), floats=True)
    lib["RLOGe"] = Function("RLOGe", _RR, _real(_positive(math.log, "RLOGe")), floats=True)
    lib["RSIGN"] = Function("RSIGN", _RR, _sign, floats=True)
    lib["RLOG"] = Function("RLOG", _RRR, _real(_log), floats=True)
    lib["RPOW"] = Function("RPOW", _RRR, _real(math.pow), floats=True)
    lib["RADD"] = Function("RADD", _RRR, _real(lambda x, y: x + y), floats=True)
    lib["RSUB"] = Function("RSUB", _RRR, _real(lambda x, y: x - y), floats=True)
    lib["RMUL"] = Function("RMUL", _RRR, _real(lambda x, y: x * y), floats=True)
    lib["RDIV"] = Function("RDIV", _RRR, _real(_div), floats=True)
    lib["RMAX"] = Function("RMAX", _RRR, max, floats=True)
    lib["RMIN"] = Function("RMIN", _RRR, min, floats=True)
    for name, op in (("RLT", float.__lt__), ("RLEQ", float.__le__), ("RGT", float.__gt__),
                     ("RGEQ", float.__ge__), ("REQ", float.__eq__), ("RNEQ", float.__ne__)):
        lib[name] = Function(name, _RRB, op, predicate=True)
    for name in ("RCOT", "RCOTH", "RACOT", "RACOTH", "RADIANS", "DEGREE", "RFRACTION"):
        lib[name] = Function(name, _RR, None, why=_UNDOCUMENTED)
    for name in ("ROUND", "RINTEGER"):
        lib[name] = Function(name, _sig(REAL, Var()), None, why=_UNDOCUMENTED)
    return lib


#: Constants of LibraryReals.def (definitions without parameters).
REAL_CONSTANTS = {"RPI": math.pi, "REULER": math.e, "RZERO": 0.0, "RONE": 1.0}


# ------------------------------------------------------------------ CHOOSE.def, SORT.def


def _order_key(v: Any) -> Any:
    """ProB's order of values where it is documented: integers by value, strings by their
    characters (``"1" < "10" < "2" < "a"``), pairs by their first then second component."""
    if type(v) is int or type(v) is str:
        return (0, v) if type(v) is int else (1, v)
    if type(v) is tuple and len(v) == 2:
        return (2, _order_key(v[0]), _order_key(v[1]))
    raise Refused(f"ProB's order of values like {_shown(v)} is not documented (integers, "
                  "strings and pairs of them are)")


def _finite_items(s: Any) -> list:
    if isinstance(s, FuncValue):
        return list(s.map.items())
    if isinstance(s, frozenset):
        return list(s)
    if isinstance(s, SymbolicSet):
        if s.finiteness() is not True:
            what = "infinite" if s.finiteness() is False else "not known to be finite"
            raise Refused(f"the set {s.name} ({what}; ProB: 'not guaranteed to work for "
                          "infinite sets')")
        return list(explicit(s))
    raise Refused(f"not a set: {_shown(s)}")


def _sorted(s: Any) -> list:
    items = _finite_items(s)
    keys = {i: _order_key(x) for i, x in enumerate(items)}
    return [items[i] for i in sorted(keys, key=keys.__getitem__)]


def _choose(s: Any) -> Any:
    items = _sorted(s)
    if not items:
        raise Undefined("CHOOSE of the empty set")
    return items[0]


def _mu(s: Any) -> Any:
    items = _finite_items(s)
    if len(items) != 1:
        raise Undefined(f"MU of a set of {len(items)} elements (it needs exactly one)")
    return items[0]


def _squash(s: Any) -> Any:
    pairs = _finite_items(s)
    if any(type(p[0]) is not int for p in pairs):
        raise Refused("SQUASH of a relation whose domain is not integers")
    if len({p[0] for p in pairs}) != len(pairs):
        raise Undefined("SQUASH of a relation that is not a function")
    return sequence([v for _, v in sorted(pairs, key=lambda p: p[0])])


def _choose_lib() -> dict[str, Function]:
    def poly(name, impl, result):
        def sig():
            t = Var()
            return (Pow(t),), result(t)
        return Function(name, sig, impl)
    return {"CHOOSE": poly("CHOOSE", _choose, lambda t: t),
            "MU": poly("MU", _mu, lambda t: t)}


def _sort_lib() -> dict[str, Function]:
    def sort_sig():
        t = Var()
        return (Pow(t),), Pow(Prod(INTEGER, t))

    def squash_sig():
        t = Var()
        return (Pow(Prod(INTEGER, t)),), Pow(Prod(INTEGER, t))
    return {"SORT": Function("SORT", sort_sig, lambda s: sequence(_sorted(s))),
            "SQUASH": Function("SQUASH", squash_sig, _squash),
            "REPLACE": Function("REPLACE", lambda: ((Var(), Var(), Var()), Var()), None,
                                why=_UNDOCUMENTED)}


# ------------------------------------------------------------------ LibraryStrings.def


def _seq(s: Any) -> list:
    items = _finite_items(s)
    idx = sorted(p[0] for p in items)
    if idx != list(range(1, len(items) + 1)):
        raise Undefined(f"{_shown(s)} is not a sequence")
    return [v for _, v in sorted(items, key=lambda p: p[0])]


def _split(s: str, sep: str) -> Any:
    return sequence([s] if sep == "" else s.split(sep))


def _sub_string(s: str, pos: int, n: int) -> str:
    if pos < 1 or n < 0:
        raise Refused("SUB_STRING with a position below 1 or a negative length")
    return s[pos - 1:pos - 1 + n]


def _codes_to_string(codes: Any) -> str:
    items = _seq(codes)
    if any(type(c) is not int or not 0 <= c <= 0x10FFFF or 0xD800 <= c <= 0xDFFF
           for c in items):
        raise Undefined("a code that is not a Unicode character")
    return "".join(map(chr, items))


_INT = re.compile(r"-?[0-9]+\Z")
_DEC = re.compile(r"\s*(-?[0-9]+(?:\.[0-9]+)?)\Z")


def _string_to_int(s: str) -> int:
    if not _INT.match(s):
        raise Refused(f"STRING_TO_INT of {s!r}: ProB's reading of anything but digits with "
                      "an optional leading '-' is not documented")
    return int(s)


def _dec_string_to_int(s: str, p: int) -> int:
    m = _DEC.match(s)
    if not m or abs(p) > 10_000:
        raise Refused(f"DEC_STRING_TO_INT of {s!r}, {p}: only decimal numbers (digits, an "
                      "optional '-' and decimal places) are read")
    scaled = Decimal(m.group(1)).scaleb(p)
    return int(scaled.to_integral_value(rounding=ROUND_HALF_UP))  # ties away from zero


def _int_to_dec_string(n: int, p: int) -> str:
    if p == 0 or abs(p) > 10_000:
        raise Refused("INT_TO_DEC_STRING with precision 0 (or beyond 10000)")
    if p < 0:
        return str(n * 10 ** -p)
    digits = str(abs(n)).rjust(p + 1, "0")
    return ("-" if n < 0 else "") + digits[:-p] + "." + digits[-p:]


def _ascii_case(fn: Callable[[str], str], name: str) -> Callable[[str], str]:
    def case(s: str) -> str:
        if not s.isascii():
            raise Refused(f"{name} of a string that is not ASCII (ProB also strips "
                          "diacritical marks, in a way not documented)")
        return fn(s)
    return case


def _to_string(v: Any) -> str:
    if type(v) is int or type(v) is str:
        return str(v)
    raise Refused(f"TO_STRING of {_shown(v)} (only integers and strings are rendered as "
                  "ProB documents)")


#: The longest string the string functions build (checked before they build it)
MAX_STRING = MAX_RESULT  # one limit for every string built (REGEX_REPLACE's too)


def _sized(n: int, name: str) -> None:
    if n > MAX_STRING:
        raise Refused(f"{name} would build a string of {n:,} characters; tracecheck builds "
                      f"strings of up to {MAX_STRING:,}")


def _append(a: str, b: str) -> str:
    _sized(len(a) + len(b), "STRING_APPEND")
    return a + b


def _join(s: Any, sep: str) -> str:
    items = _seq(s)
    if not all(type(x) is str for x in items):
        raise Undefined(f"{_shown(s)} is not a sequence of strings")
    _sized(sum(map(len, items)) + len(sep) * max(len(items) - 1, 0), "STRING_JOIN")
    return sep.join(items)


def _strings() -> dict[str, Function]:
    S, Z = STRING, INTEGER
    sq = Pow(Prod(INTEGER, STRING))
    lib = {
        "STRING_APPEND": Function("STRING_APPEND", _sig(S, S, S), _append),
        "STRING_LENGTH": Function("STRING_LENGTH", _sig(S, Z), len),
        "STRING_SPLIT": Function("STRING_SPLIT", _sig(S, S, sq), _split),
        "STRING_JOIN": Function("STRING_JOIN", _sig(sq, S, S), _join),
        "STRING_CHARS": Function("STRING_CHARS", _sig(S, sq), lambda s: sequence(list(s))),
        "STRING_CODES": Function("STRING_CODES", _sig(S, Pow(Prod(Z, Z))),
                                 lambda s: sequence([ord(ch) for ch in s])),
        "CODES_TO_STRING": Function("CODES_TO_STRING", _sig(Pow(Prod(Z, Z)), S),
                                    _codes_to_string),
        "STRING_TO_UPPER": Function("STRING_TO_UPPER", _sig(S, S),
                                    _ascii_case(str.upper, "STRING_TO_UPPER")),
        "STRING_TO_LOWER": Function("STRING_TO_LOWER", _sig(S, S),
                                    _ascii_case(str.lower, "STRING_TO_LOWER")),
        "SUB_STRING": Function("SUB_STRING", _sig(S, Z, Z, S), _sub_string),
        "STRING_TO_INT": Function("STRING_TO_INT", _sig(S, Z), _string_to_int),
        "INT_TO_STRING": Function("INT_TO_STRING", _sig(Z, S), str),
        "DEC_STRING_TO_INT": Function("DEC_STRING_TO_INT", _sig(S, Z, Z), _dec_string_to_int),
        "INT_TO_DEC_STRING": Function("INT_TO_DEC_STRING", _sig(Z, Z, S), _int_to_dec_string),
        "INT_TO_HEX_STRING": Function("INT_TO_HEX_STRING", _sig(Z, S), lambda n: format(n, "x")),
        "TO_STRING": Function("TO_STRING", lambda: ((Var(),), STRING), _to_string),
    }
    lib["STRING_IS_INT"] = Function("STRING_IS_INT", _sig(S, BOOL), None, predicate=True,
                                    why="ProB's reading of signs and spaces is not documented")
    lib["FORMAT_TO_STRING"] = Function("FORMAT_TO_STRING", lambda: ((S, Var()), S), None,
                                       why="SICStus' format directives")
    lib["STRINGIFY"] = Function("STRINGIFY", lambda: ((Var(),), S), None,
                                why="ProB's rewriting of the expression")
    return lib


# ------------------------------------------------------------------ LibraryProB.def


def _assert_expr(ok: bool, message: str, value: Any) -> Any:
    if ok is not True:
        raise Undefined(f"the assertion failed: {message}")
    return value


def _assert_true(ok: bool, message: str) -> bool:
    if ok is not True:
        raise Undefined(f"the assertion failed: {message}")
    return True


def _prob_lib() -> dict[str, Function]:
    def expr_sig():
        t = Var()
        return (BOOL, STRING, t), t

    def same_sig():
        t = Var()
        return (t,), t

    def set_sig():
        t = Pow(Var())
        return (t,), t
    return {
        "ASSERT_EXPR": Function("ASSERT_EXPR", expr_sig, _assert_expr),
        "ASSERT_TRUE": Function("ASSERT_TRUE", _sig(BOOL, STRING, BOOL), _assert_true,
                                predicate=True),
        "COPY": Function("COPY", same_sig, lambda v: v),  # for ProB's solver: the value
        "FORCE": Function("FORCE", set_sig, lambda v: v),  # a set computed: it always is
    }


def _sccs(r: Any) -> frozenset:
    """The strongly connected components of a finite relation. A node on no cycle is
    refused: ProB's examples show components on cycles and nodes with a loop (``{53}``),
    not what it gives for the others."""
    from ..graphs import components

    succ: dict = {}
    for a, b in _finite_items(r):
        succ.setdefault(a, []).append(b)
        succ.setdefault(b, [])
    found = components(succ)
    for comp in found:
        if len(comp) == 1:
            (node,) = comp
            if node not in succ[node]:
                raise Refused(f"SCCS of a relation with a node on no cycle ({_shown(node)})")
    return frozenset(found)


def _sccs_lib() -> dict[str, Function]:
    def sig():
        t = Var()
        return (Pow(Prod(t, t)),), Pow(Pow(t))
    return {"SCCS": Function("SCCS", sig, _sccs)}


def _regex_lib() -> dict[str, Function]:
    from .regex import regex_functions

    return regex_functions(Function, _sig, Undefined, Refused)


#: The library files tracecheck knows, with their functions.
LIBRARY_FILES: dict[str, dict[str, Function]] = {
    "LibraryReals.def": _reals(),
    "CHOOSE.def": _choose_lib(),
    "SORT.def": _sort_lib(),
    "LibraryStrings.def": _strings(),
    "LibraryRegex.def": _regex_lib(),
    "LibraryProB.def": _prob_lib(),
    "SCCS.def": _sccs_lib(),
}

#: Files of ProB's standard library tracecheck does not implement (a clear refusal).
NOT_IMPLEMENTED = {
    "LibraryMath.def": "its integer functions' exact definitions are not documented",
    "LibraryIO.def": "it reads and writes files", "LibraryFiles.def": "it reads files",
    "LibraryMeta.def": "it describes ProB's state space",
    "LibraryXML.def": "records are not supported", "LibraryHash.def": "SICStus' term hash",
    "LibraryBits.def": "not implemented",
}

FUNCTIONS: dict[str, Function] = {n: f for lib in LIBRARY_FILES.values() for n, f in lib.items()}


# ------------------------------------------------------------------ definitions


def library_bodies(file_name: str) -> Optional[dict[str, tuple[tuple[str, ...], ast.Node]]]:
    """What ``DEFINITIONS "file_name"`` defines: each name's parameters and body (the
    parser makes them definitions), or ``None`` for a file tracecheck does not know
    (``NOT_IMPLEMENTED`` names ProB's files it refuses)."""
    lib = LIBRARY_FILES.get(file_name)
    if lib is None:
        return None
    out: dict[str, tuple[tuple[str, ...], ast.Node]] = {}
    for name, fn in lib.items():
        if name in ast.BUILTIN_FUNCTIONS:
            continue  # RSQRT, RABS: built in everywhere
        params = tuple(f"arg{i}" for i in range(1, fn.arity + 1))
        body: ast.Node = ast.Call(name, tuple(ast.Name(p) for p in params))
        if fn.predicate:
            body = ast.Rel("=", body, ast.BoolLit(True))
        out[name] = (params, body)
    if file_name == "LibraryReals.def":
        for name, value in REAL_CONSTANTS.items():
            out[name] = ((), ast.RealLit(value))
    return out


# ------------------------------------------------------------------ types


def call_type(typer, node: ast.Call) -> Type:
    fn = FUNCTIONS[node.name]
    args, result = fn.signature()
    if len(node.args) != len(args):
        raise BTypeError(f"{node.name} takes {len(args)} argument(s), not {len(node.args)}",
                         file=typer.file, source=typer.source,
                         line=_where(node).pos.line if _where(node).pos else None)
    for a, t in zip(node.args, args):
        typer.same(a, typer.expr(a), t, f"argument of {node.name}: ")
    return result


# ------------------------------------------------------------------ scalar path


def _where(node: ast.Call) -> ast.Call:
    """``node`` with a position: the span of its arguments where the call itself has none
    (a library function's body comes from no source)."""
    if node.pos is not None:
        return node
    spans = [a.pos for a in node.args if a.pos is not None]
    if not spans:
        return node
    first, last = spans[0], spans[-1]
    return dataclasses.replace(node, pos=ast.Pos(first.line, first.column, last.end_line,
                                                 last.end_column, first.start, last.end))


def _shown(v: Any) -> str:
    text = format_value(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _call_text(node: ast.Call) -> str:
    from .printer import to_b

    return to_b(node)


def _refusal(c, node: ast.Call, why: str):
    return c.error(UnsupportedError, _where(node), f"not supported: {node.name} "
                   f"({_file_of(node.name)}): {why}", hint="compute it another way, or "
                   "evaluate the machine in ProB")


def _file_of(name: str) -> str:
    return next(f for f, lib in LIBRARY_FILES.items() if name in lib)


_PY = {REAL: (float,), INTEGER: (int,), STRING: (str,)}


def compile_call(c, node: ast.Call) -> Callable[[dict], Any]:
    """The library call ``node`` as a function of an environment (the scalar path)."""
    fn = FUNCTIONS[node.name]
    if fn.impl is None:
        raise _refusal(c, node, fn.why)
    types, _ = fn.signature()
    if len(node.args) != len(types):
        raise c.error(BTypeError, _where(node),
                      f"{node.name} takes {len(types)} argument(s), not {len(node.args)}")
    args = [c.compile(a) for a in node.args]
    wanted = [_PY.get(t) for t in types]
    impl = fn.impl

    def call(env: dict) -> Any:
        values = [a(env) for a in args]
        for a, v, w in zip(node.args, values, wanted):
            if w is not None and type(v) not in w:
                raise c.type_error(a, v, {float: "a real", int: "an integer",
                                          str: "a string"}[w[0]])
        try:
            return impl(*values)
        except Undefined as exc:
            raise c.error(WellDefinednessError, _where(node),
                          f"{exc} in `{_call_text(node)}`") from None
        except Refused as exc:
            raise _refusal(c, node, str(exc)) from None
    return call


# ------------------------------------------------------------------ batch path


def vector_call(vc, node: ast.Call, not_vectorizable: type) -> Callable:
    """The library call ``node`` on columns: functions of reals element by element with the
    very function the scalar path uses (so every row agrees, bit for bit); a row where the
    call is not well-defined is marked, and the scalar path raises its located error."""
    fn = FUNCTIONS[node.name]
    if not fn.floats or fn.impl is None:
        raise not_vectorizable(node.name)
    args = [vc.compile(a) for a in node.args]
    impl = fn.impl

    def run(ctx) -> tuple:
        import numpy as np  # the batch path only: eval's start-up does not load numpy

        values = []
        for a in args:
            tag, v = a(ctx)
            if tag != "num":
                raise not_vectorizable(node.name)
            values.append(np.asarray(v))
        if any(v.dtype.kind != "f" for v in values):
            raise not_vectorizable(node.name)
        values = np.broadcast_arrays(*values)
        out = np.empty(values[0].shape)
        bad = np.zeros(values[0].shape, dtype=bool)
        flat_out, flat_bad = out.reshape(-1), bad.reshape(-1)
        for i, xs in enumerate(zip(*(v.reshape(-1).tolist() for v in values))):
            try:
                flat_out[i] = impl(*xs)
            except Undefined:
                flat_out[i], flat_bad[i] = 0.0, True
        if bad.any():
            ctx.mark(bad if bad.ndim else np.ones(ctx.cols.n, dtype=bool))
        return ("num", out if out.ndim else out[()])
    return run
