"""The batch compiler: one formula over many states at once, on numpy columns.

States are held as :class:`~tracecheck.b.columns.Columns`, one row per state: numbers and
booleans as 1-D arrays, functions from the elements of a set (``VehiclesX : Vehicles --> REAL``) as
``(rows, elements)`` arrays, subsets of that set as boolean masks. A quantifier over those
elements becomes a reduction along the element axis, so a guard over a whole recording is a
handful of numpy operations.

Formulas outside that shape (nested element quantifiers, comprehensions, sets of sets) are
evaluated row by row with the scalar path, with the same results. So are the rows where a
sub-expression is not well-defined (a function applied outside its domain, division by
zero): the scalar path respects the short-circuit that guards such terms and raises the
located error where the formula really has no value. The values the compiled formula
computes with, and the numpy operations on them, are in :mod:`.arrays`.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Optional

import numpy as np

from ..errors import TracecheckError
from . import ast
from .bindings import conjuncts, membership_of
from .evaluation import Compiler
from .arrays import (BatchContext, NotVectorizable, VectorValue, all_last, arith, bool_of,
                     concat_numbers, fits, integral, intern_key, is_int_array, mark_nonfinite,
                     num_of, per_row, power, shared, typed_member)
from .columns import Columns
from .records import set_element
from .library import FUNCTIONS as _LIBRARY, vector_call as _library_call
from ..limits import DEEP, deep_recursion
from .values import Elem, FuncValue

__all__ = ["evaluate_batch", "BatchFormula", "BoundFormulas"]


class _VecCompiler:
    def __init__(self, constants: Mapping[str, Any], elements: tuple[Elem, ...],
                 kinds: dict[str, str]) -> None:
        self.constants = constants
        self.index = {e: i for i, e in enumerate(elements)}
        self.k = len(elements)
        self.kinds = kinds
        self.axes: list[str] = []  # bound element variables: axis 1, then axis 2
        self.hidden: set[str] = set()  # bound outside the comprehension being compiled
        self.lets: list[str] = []  # LET variables in scope
        self.free: dict = {}  # free names by node, see ast.free_names
        #: real powers with Python's own (as the scalar path: the same bits), not numpy's
        self.python_power = False

    def compile(self, node: ast.Node) -> Callable[[BatchContext], VectorValue]:
        method = getattr(self, "v_" + type(node).__name__, None)
        if method is None:
            raise NotVectorizable(type(node).__name__)
        fn = method(node)
        if isinstance(node, _SHARED) and not (ast.free_names(node, self.free) & set(self.lets)):
            return shared(fn, intern_key((node, tuple(self.axes), tuple(sorted(self.hidden)))))
        return fn

    def constant(self, value: Any) -> VectorValue:
        if type(value) is bool:
            return ("bool", value)
        if type(value) in (int, float):
            return ("num", value)
        if isinstance(value, Elem) and value in self.index:
            return ("elem", self.index[value])
        if isinstance(value, frozenset) and not isinstance(value, FuncValue) and all(
                e in self.index for e in value):
            mask = np.zeros((1, self.k), dtype=bool)
            for e in value:
                mask[0, self.index[e]] = True
            return ("set", mask)
        raise NotVectorizable(repr(value))

    def v_Name(self, node: ast.Name) -> Callable:
        name = node.id
        if name in self.axes:
            depth = self.axes.index(name)
            return lambda ctx: ("elem", ("axis", depth))
        if name in self.lets:
            return lambda ctx: ctx.lets[name]
        if name in self.hidden:
            raise NotVectorizable(f"{name} from an enclosing scope")
        kind = self.kinds.get(name)
        if kind in ("num", "bool"):  # a value per row, broadcast along the element axes
            where = "numbers" if kind == "num" else "booleans"
            return lambda ctx: (kind, getattr(ctx.cols, where)[name][:, None, None])
        if kind in ("func", "set"):
            where = "functions" if kind == "func" else "masks"
            return lambda ctx: (kind, getattr(ctx.cols, where)[name])
        if name in self.constants:
            vec = self.constant(self.constants[name])
            return lambda ctx: vec
        if name in _TYPE_SETS:
            return lambda ctx: ("type", name)
        element = set_element(name, self.constants)  # S3: an element of a deferred set S
        if element is not None:
            vec = self.constant(element)
            return lambda ctx: vec
        raise NotVectorizable(name)

    def v_IntLit(self, node) -> Callable:
        vec = self.constant(node.value)
        return lambda ctx: vec

    v_RealLit = v_BoolLit = v_IntLit

    def v_SetExt(self, node: ast.SetExt) -> Callable:
        items = [self.compile(i) for i in node.items]

        def set_ext(ctx: BatchContext) -> VectorValue:
            values = [f(ctx) for f in items]
            if values and all(tag == "num" for tag, _ in values):
                columns = [self._row_values(ctx, v) for _, v in values]
                rows = max(len(c) for c in columns)
                table = np.stack([np.broadcast_to(c, (rows,)) for c in columns], axis=1)
                return ("nums", (table, np.ones((1, len(columns)), dtype=bool)))
            mask = np.zeros((1, self.k), dtype=bool)
            for tag, idx in values:
                if tag != "elem" or not isinstance(idx, int):
                    raise NotVectorizable("set of non-constant elements")
                mask[0, idx] = True
            return ("set", mask)
        return set_ext

    def _row_values(self, ctx: BatchContext, value: Any) -> np.ndarray:
        """A number per row (or one for all rows) as a 1-d array; one that varies along a
        quantifier's axis is not a row's number."""
        value = np.asarray(value)
        if value.ndim == 0:
            return value.reshape(1)
        if value.ndim == 3 and value.shape[1:] == (1, 1):
            return value[:, 0, 0]
        raise NotVectorizable("a set of numbers that varies with a bound element")

    def v_Comprehension(self, node: ast.Comprehension) -> Callable:
        """``{v | v : S & P}`` as a mask over the elements, ``{v . v : S & P | E}`` as the
        numbers E where P holds. Only comprehensions that use no variable bound around them
        (a set per row); the element variable gets its own axis."""
        if len(node.ids) != 1:
            raise NotVectorizable("comprehension shape")
        (var,) = node.ids
        gen = membership_of(node.pred, var)
        if gen is None:
            raise NotVectorizable("no domain")
        saved = (self.axes, self.hidden, self.lets)
        self.hidden = set(self.axes) | set(self.lets) | self.hidden
        self.axes, self.lets = [], []
        try:
            dom = self.compile(gen.right)
            self.axes = [var]
            pred = self.compile(node.pred)
            expr = self.compile(node.expr) if node.expr is not None else None
        finally:
            self.axes, self.hidden, self.lets = saved

        def comprehension(ctx: BatchContext) -> VectorValue:
            tag, mask = dom(ctx)
            if tag != "set" or np.ndim(mask) != 2:
                raise NotVectorizable("domain")
            holds = np.broadcast_to(np.asarray(bool_of(pred(ctx))), (ctx.cols.n, self.k, 1))
            member = np.broadcast_to(mask, (ctx.cols.n, self.k)) & holds[:, :, 0]
            if expr is None:
                return ("set", member)
            with ctx.only_where(member[:, :, None]):
                values = np.asarray(num_of(expr(ctx)))
            return ("nums", (np.broadcast_to(values, (ctx.cols.n, self.k, 1))[:, :, 0],
                             member))
        return comprehension

    def v_Image(self, node: ast.Image) -> Callable:
        """``F[S]`` of a function over the elements: its values at the members of S."""
        rel, arg = self.compile(node.rel), self.compile(node.arg)

        def image(ctx: BatchContext) -> VectorValue:
            f, s = rel(ctx), arg(ctx)
            if f[0] != "func" or s[0] != "set" or np.ndim(s[1]) != 2:
                raise NotVectorizable("image")
            values, defined = f[1]
            return ("nums", (values, defined & s[1]))
        return image

    def v_Let(self, node: ast.Let) -> Callable:
        """``LET x BE x = E IN B END``: the equations in the order they use each other."""
        eqs: dict[str, ast.Node] = {}
        for conj in conjuncts(node.pred):
            if (isinstance(conj, ast.Rel) and conj.op == "=" and isinstance(conj.left, ast.Name)
                    and conj.left.id in node.ids and conj.left.id not in eqs):
                eqs[conj.left.id] = conj.right
            else:
                raise NotVectorizable("LET condition")
        ordered: list[str] = []
        while len(ordered) < len(node.ids):
            ready = [i for i in node.ids if i not in ordered and i in eqs
                     and not (ast.free_names(eqs[i]) & (set(node.ids) - set(ordered)))]
            if not ready:
                raise NotVectorizable("LET order")
            ordered.extend(ready)
        steps = []
        saved = list(self.lets)
        try:
            for name in ordered:
                steps.append((name, self.compile(eqs[name])))
                self.lets.append(name)
            body = self.compile(node.body)
        finally:
            self.lets = saved

        def let(ctx: BatchContext) -> VectorValue:
            outer = dict(ctx.lets)
            try:
                for name, fn in steps:
                    ctx.lets[name] = fn(ctx)
                return body(ctx)
            finally:
                ctx.lets = outer
        return let

    def v_Neg(self, node: ast.Neg) -> Callable:
        f = self.compile(node.operand)
        return lambda ctx: ("num", -num_of(f(ctx)))

    def v_BinOp(self, node: ast.BinOp) -> Callable:
        l, r = self.compile(node.left), self.compile(node.right)
        op = node.op
        if op in ("-->", "+->"):
            return lambda ctx: ("space", (op, l(ctx), r(ctx)))
        if op == "**" and self.python_power:
            return lambda ctx: ("num", power(ctx, num_of(l(ctx)), num_of(r(ctx))))
        if op in ("+", "*", "**"):
            fn = {"+": np.add, "*": np.multiply, "**": np.power}[op]
            return lambda ctx: ("num", arith(ctx, fn, op, num_of(l(ctx)), num_of(r(ctx))))
        if op == "/":
            def div(ctx: BatchContext) -> VectorValue:
                a, b = num_of(l(ctx)), num_of(r(ctx))
                zero = np.asarray(b) == 0
                if np.any(zero):
                    ctx.mark(np.broadcast_to(zero, np.broadcast(a, b).shape)
                             if np.ndim(zero) else np.ones(ctx.cols.n, dtype=bool))
                if is_int_array(a) and is_int_array(b):
                    with np.errstate(divide="ignore", invalid="ignore"):
                        safe = np.where(zero, 1, b)
                        q = np.abs(a) // np.abs(safe)
                        return ("num", np.where((np.asarray(a) >= 0) == (np.asarray(safe) > 0),
                                                q, -q))
                with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                    q = np.true_divide(a, b)
                mark_nonfinite(ctx, q)
                return ("num", q)
            return div
        if op in ("-", "\\", "\\/", "/\\"):
            def setop(ctx: BatchContext) -> VectorValue:
                a, b = l(ctx), r(ctx)
                if a[0] == "set" and b[0] == "set":
                    x, y = a[1], b[1]
                    if op in ("-", "\\"):
                        return ("set", x & ~y)
                    return ("set", (x | y) if op == "\\/" else (x & y))
                if a[0] == "nums" and b[0] == "nums" and op == "\\/":
                    return ("nums", concat_numbers(ctx, a[1], b[1]))
                if op == "-":
                    return ("num", arith(ctx, np.subtract, op, num_of(a), num_of(b)))
                raise NotVectorizable(op)
            return setop
        raise NotVectorizable(op)

    def v_Rel(self, node: ast.Rel) -> Callable:
        l, r = self.compile(node.left), self.compile(node.right)
        op = node.op
        if op in ("<", "<=", ">", ">="):
            fn = {"<": np.less, "<=": np.less_equal, ">": np.greater,
                  ">=": np.greater_equal}[op]
            return lambda ctx: ("bool", fn(num_of(l(ctx)), num_of(r(ctx))))
        if op in ("=", "/="):
            def eq(ctx: BatchContext) -> VectorValue:
                a, b = l(ctx), r(ctx)
                if a[0] != b[0] or a[0] not in ("num", "bool", "elem", "set", "func"):
                    raise NotVectorizable("=")
                if a[0] == "set":
                    res = per_row(all_last(a[1] == b[1]))
                elif a[0] == "func":
                    (va, da), (vb, db) = a[1], b[1]
                    same = (da == db) & ((va == vb) | ~da)
                    res = per_row(all_last(same))
                elif a[0] == "elem":
                    res = np.equal(self.elem_index(a[1]), self.elem_index(b[1]))
                else:
                    res = np.equal(a[1], b[1])
                return ("bool", res if op == "=" else ~np.asarray(res))
            return eq
        if op in (":", "/:"):
            def member(ctx: BatchContext) -> VectorValue:
                a, s = l(ctx), r(ctx)
                if a[0] == "elem" and s[0] == "set":
                    res = self.pick(s[1], a[1])
                else:
                    res = typed_member(a, s, ctx.cols.n)
                return ("bool", res if op == ":" else ~res)
            return member
        if op in ("<:", "/<:"):
            def subset(ctx: BatchContext) -> VectorValue:
                a, b = l(ctx), r(ctx)
                if a[0] != "set" or b[0] != "set":
                    raise NotVectorizable("<:")
                res = per_row(all_last(~a[1] | b[1]))
                return ("bool", res if op == "<:" else ~res)
            return subset
        raise NotVectorizable(op)

    def _logic(self, node, fn, needs: Optional[bool] = None) -> Callable:
        """``fn(left, right)``; with ``needs``, the right side is evaluated (on the scalar
        path) only where the left one is ``needs``: what is ill-defined in it matters only
        in those rows, as ``&``, ``or`` and ``=>`` short-circuit."""
        l, r = self.compile(node.left), self.compile(node.right)
        if needs is None:
            return lambda ctx: ("bool", fn(bool_of(l(ctx)), bool_of(r(ctx))))

        def logic(ctx: BatchContext) -> VectorValue:
            a = np.asarray(bool_of(l(ctx)))
            with ctx.only_where(a if needs else ~a):
                b = bool_of(r(ctx))
            return ("bool", fn(a, b))
        return logic

    def v_And(self, node) -> Callable:
        return self._logic(node, np.logical_and, True)

    def v_Or(self, node) -> Callable:
        return self._logic(node, np.logical_or, False)

    def v_Implies(self, node) -> Callable:
        return self._logic(node, lambda a, b: np.logical_or(np.logical_not(a), b), True)

    def v_Equiv(self, node) -> Callable:
        return self._logic(node, np.equal)

    def v_Not(self, node: ast.Not) -> Callable:
        f = self.compile(node.operand)
        return lambda ctx: ("bool", np.logical_not(bool_of(f(ctx))))

    def v_Quant(self, node: ast.Quant) -> Callable:
        if len(node.ids) != 1 or len(self.axes) >= 2:
            raise NotVectorizable("quantifier shape")
        (var,) = node.ids
        body = node.body
        gen = membership_of(body.left if isinstance(body, ast.Implies) else body, var)
        if gen is None:
            raise NotVectorizable("no domain")
        dom = self.compile(gen.right)
        depth = len(self.axes)
        self.axes.append(var)
        try:
            f = self.compile(body)
        finally:
            self.axes.pop()
        forall = node.op == "!"
        axis = 1 + depth

        def quant(ctx: BatchContext) -> VectorValue:
            tag, mask = dom(ctx)
            if tag != "set" or np.ndim(mask) != 2:
                raise NotVectorizable("domain")
            mask = mask[:, :, None] if depth == 0 else mask[:, None, :]
            value = bool_of(f(ctx))
            if forall:
                return ("bool", np.all(value | ~mask, axis=axis, keepdims=True))
            return ("bool", np.any(value & mask, axis=axis, keepdims=True))
        return quant

    def elem_index(self, elem) -> Any:
        """An element as an index (an int) or an index array along its quantifier's axis."""
        if isinstance(elem, tuple):
            shape = [1, 1, 1]
            shape[1 + elem[1]] = self.k
            return np.arange(self.k).reshape(shape)
        return elem

    def pick(self, table: np.ndarray, elem) -> np.ndarray:
        """``table`` (rows, elements) at ``elem``, shaped (rows, axis 1, axis 2)."""
        if isinstance(elem, tuple):
            return table[:, :, None] if elem[1] == 0 else table[:, None, :]
        return table[:, elem][:, None, None]

    def v_Apply(self, node: ast.Apply) -> Callable:
        if len(node.args) != 1:
            raise NotVectorizable("arity")
        fn, arg = self.compile(node.fn), self.compile(node.args[0])

        def apply(ctx: BatchContext) -> VectorValue:
            f, x = fn(ctx), arg(ctx)
            if f[0] != "func" or x[0] != "elem":
                raise NotVectorizable("apply")
            vals, defined = f[1]
            vals, defined = self.pick(vals, x[1]), self.pick(defined, x[1])
            if not defined.all():
                ctx.mark(~defined)
            return ("num", vals)
        return apply

    def v_Call(self, node: ast.Call) -> Callable:
        if node.name in _LIBRARY:  # ProB's library files (DEFINITIONS "LibraryReals.def")
            return _library_call(self, node, NotVectorizable)
        arg = self.compile(node.args[0])
        name = node.name
        if name == "dom":
            def dom(ctx: BatchContext) -> VectorValue:
                f = arg(ctx)
                if f[0] != "func":
                    raise NotVectorizable("dom")
                return ("set", f[1][1])
            return dom
        if name == "card":
            def card(ctx: BatchContext) -> VectorValue:
                s = arg(ctx)
                if s[0] != "set":
                    raise NotVectorizable("card")
                return ("num", per_row(np.broadcast_to(s[1], (ctx.cols.n, self.k)).sum(axis=1)))
            return card
        if name in ("min", "max"):
            def extreme(ctx: BatchContext) -> VectorValue:
                tag, payload = arg(ctx)
                if tag != "nums":
                    raise NotVectorizable(name)
                values, member = payload
                values, member = np.broadcast_arrays(values, member)
                empty = ~member.any(axis=1)
                if empty.any():
                    ctx.mark(np.broadcast_to(empty, (ctx.cols.n,)) if len(empty) == 1
                             else empty)
                fill = np.inf if name == "min" else -np.inf
                masked = np.where(member, values, fill)
                result = masked.min(axis=1) if name == "min" else masked.max(axis=1)
                if values.dtype.kind in "iu":
                    result = np.where(empty, 0, result).astype(values.dtype)
                return ("num", per_row(result))
            return extreme
        if name == "bool":
            return lambda ctx: ("bool", bool_of(arg(ctx)))
        if name == "POW":
            return lambda ctx: ("pow", arg(ctx))
        if name == "RSQRT":
            def sqrt(ctx: BatchContext) -> VectorValue:
                x = num_of(arg(ctx))
                neg = np.asarray(x) < 0
                if np.any(neg):
                    ctx.mark(neg if np.ndim(neg) else np.ones(ctx.cols.n, dtype=bool))
                with np.errstate(invalid="ignore"):
                    return ("num", np.sqrt(x))
            return sqrt
        if name in ("floor", "ceiling"):
            fn = np.floor if name == "floor" else np.ceil
            return lambda ctx: ("num", integral(ctx, fn, num_of(arg(ctx))))
        simple = {"RABS": np.abs, "abs": np.abs, "real": lambda x: np.asarray(x, float)}
        if name in simple:
            f = simple[name]
            return lambda ctx: ("num", f(num_of(arg(ctx))))
        raise NotVectorizable(name)

    def v_IfExpr(self, node: ast.IfExpr) -> Callable:
        branches = [(self.compile(c), self.compile(v)) for c, v in node.branches]
        other = self.compile(node.else_)

        def if_expr(ctx: BatchContext) -> VectorValue:
            # every branch is computed for every row, but a branch's ill-defined values
            # only matter in the rows that take it (IF guards its branches)
            conds = []
            rest = np.ones(1, dtype=bool)
            for cond, _ in branches:  # a condition is evaluated where no earlier one held
                with ctx.only_where(rest):
                    conds.append(np.asarray(bool_of(cond(ctx))))
                rest = rest & ~conds[-1]
            taken = []
            rest = np.ones(1, dtype=bool)
            for c in conds:
                taken.append(c & rest)
                rest = rest & ~c
            values = []
            for (_, value), chosen in zip(branches + [(None, other)], taken + [rest]):
                with ctx.only_where(chosen):
                    values.append(value(ctx))
            tag = values[-1][0]
            if tag not in ("num", "bool") or any(v[0] != tag for v in values):
                raise NotVectorizable("IF")
            result = values[-1][1]
            for c, (_, v) in zip(reversed(conds), reversed(values[:-1])):
                result = np.where(c, v, result)
            return (tag, result)
        return if_expr


_TYPE_SETS = {"REAL", "FLOAT", "BOOL", "INTEGER"}


# Sub-formulas worth computing once per batch: a shield's definitions are expanded at every
# use, so `min(VehiclesX[NextVehiclesInLane(LeftLane)])` occurs in several guards.
_SHARED = (ast.Comprehension, ast.Image, ast.Call, ast.IfExpr, ast.Quant, ast.Let)


def _kinds(cols: Columns) -> dict[str, str]:
    return {**{n: "num" for n in cols.numbers}, **{n: "bool" for n in cols.booleans},
            **{n: "func" for n in cols.functions}, **{n: "set" for n in cols.masks}}


class BoundFormulas:
    """Sub-formulas of a larger formula over the same columns, each compiled in the scope of
    the element variables its enclosing quantifiers bind (``!v.(v : S => … here …)``), for a
    caller that combines them itself (:mod:`.threshold_batch`).

    A value is ``(tag, array)`` broadcastable to ``(rows, elements, elements)``: the first
    bound variable along axis 1, the second along axis 2. Rows where a sub-formula is not
    well-defined are in :attr:`bad` (for the scalar path). Compiling raises
    :class:`~tracecheck.b.arrays.NotVectorizable` where the batch compiler cannot."""

    def __init__(self, constants: Mapping[str, Any], cols: Columns) -> None:
        self.cols = cols
        self._comp = _VecCompiler(constants, cols.elements, _kinds(cols))
        self._comp.python_power = True  # every number the very one the scalar path computes
        self._ctx = BatchContext(cols)
        self._done: dict[tuple, tuple] = {}  # by the node's identity (the node kept in it)

    def compile(self, node: ast.Node, bound: tuple[str, ...] = ()
                ) -> Callable[[], VectorValue]:
        """``node`` with ``bound`` (at most two names) the element variables in scope."""
        key = (id(node), bound)
        if key not in self._done:
            if len(bound) > 2:
                raise NotVectorizable("more than two bound element variables")
            self._comp.axes = list(bound)
            try:
                fn = self._comp.compile(node)
            finally:
                self._comp.axes = []
            self._done[key] = (lambda ctx=self._ctx: fn(ctx), node)
        return self._done[key][0]

    @property
    def bad(self) -> Optional[np.ndarray]:
        """The rows marked for the scalar path so far (None: none)."""
        return self._ctx.bad


class BatchFormula:
    """A formula prepared for batch evaluation over :class:`Columns`."""

    def __init__(self, node: ast.Node, constants: Mapping[str, Any], *,
                 source: Optional[str] = None, file: Optional[str] = None,
                 python_power: bool = False) -> None:
        self.node = node
        self.constants = dict(constants)
        self.python_power = python_power  # real powers by Python's ``**``: the scalar bits
        # called only inside __call__, which raises the recursion limit for a deep formula
        self.scalar = Compiler(source=source, file=file).compile(node, wrap=False)
        self._plans: dict[tuple, Optional[Callable]] = {}
        self._deep = ast.depth(node) > DEEP  # compiled and run with the raised recursion limit

    def _plan(self, cols: Columns) -> Optional[Callable]:
        kinds = _kinds(cols)
        key = (cols.elements, tuple(sorted(kinds.items())))
        if key not in self._plans:
            comp = _VecCompiler(self.constants, cols.elements, kinds)
            comp.python_power = self.python_power
            try:
                self._plans[key] = comp.compile(self.node)
            except NotVectorizable:
                self._plans[key] = None
        return self._plans[key]

    def vectorised(self, cols: Columns) -> bool:
        """Whether columns of the kinds of ``cols`` take the batch path (not row by row)."""
        return self._plan(cols) is not None

    def __call__(self, cols: Columns, memo: Optional[dict] = None) -> np.ndarray:
        """The value in each row: a bool array for a predicate, a float array for a number
        (``memo``: shared by formulas over the same columns and constants, so that what
        they have in common is computed once)."""
        if self._deep:
            with deep_recursion():
                return self._evaluate(cols, memo)
        return self._evaluate(cols, memo)

    def _evaluate(self, cols: Columns, memo: Optional[dict]) -> np.ndarray:
        plan = self._plan(cols)
        if plan is not None:
            ctx = BatchContext(cols)
            if memo is not None:
                ctx.memo = memo
            try:
                tag, value = plan(ctx)
            except NotVectorizable:
                plan = None
            else:
                if tag in ("num", "bool"):
                    value = np.asarray(value)
                    if value.ndim < 3:
                        value = value.reshape(value.shape + (1,) * (3 - value.ndim))
                    out = np.array(np.broadcast_to(value, (cols.n, 1, 1))[:, 0, 0])
                    bad = np.flatnonzero(ctx.bad) if ctx.bad is not None else ()
                    fixed = {int(i): self._row(cols, int(i)) for i in bad}
                    if not all(fits(out, v) for v in fixed.values()):
                        out = out.astype(object)  # exact integers, as the scalar path has them
                    for i, v in fixed.items():
                        out[i] = v
                    return out
                plan = None
        return np.array(self._rows(cols))

    def _rows(self, cols: Columns) -> list:
        """Every row on the scalar path, each distinct state evaluated once (evaluation is a
        function of the state: a grid world visits few distinct states many times). The
        states are taken in row order, so an error names the first row that has it."""
        first, which = cols.distinct()
        values = [self._row(cols, int(i)) for i in first]
        return [values[k] for k in which.tolist()]

    def _row(self, cols: Columns, i: int) -> Any:
        env = dict(self.constants)
        env.update(cols.row(i))
        try:
            return self.scalar(env)
        except TracecheckError as exc:
            where = cols.label(i) if cols.label is not None else f"state {i}"
            exc.message = f"{where}: {exc.message}"
            exc.args = (exc.render(),)
            raise


def evaluate_batch(node: ast.Node, cols: Columns, constants: Mapping[str, Any] = {},
                   *, source: Optional[str] = None) -> np.ndarray:
    """Evaluate ``node`` in every row of ``cols`` (see the module docstring).

    Args:
        node: a parsed formula.
        cols: the states as columns (:class:`Columns`).
        constants: the values of names that are the same in every row.
        source: its text, for located error messages.

    Returns:
        One value per row (a numpy array): what :func:`~tracecheck.b.evaluation.evaluate`
        gives in each state, row by row.

    >>> from tracecheck.b.parser import parse_formula
    >>> cols = Columns.from_states([{"x": 1}, {"x": 5}])
    >>> evaluate_batch(parse_formula("x > 2"), cols).tolist()
    [False, True]
    """
    return BatchFormula(node, constants, source=source)(cols)
