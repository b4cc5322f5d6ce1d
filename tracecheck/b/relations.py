"""Relations and functions for the scalar compiler: application ``f(x)``, image ``r[S]``,
inverse ``r~``, composition ``(r ; s)`` and direct product ``r >< s`` — of explicit sets,
symbolic ones (projections, function spaces) and functions held by their definition
(:mod:`.defined`). A mixin of :class:`~tracecheck.b.evaluation.Compiler`, which gives
``compile``, ``set_op``, ``wd``, ``error``, ``type_error`` and ``equal``."""

from __future__ import annotations

from typing import Any, Callable

from ..errors import EvaluationError
from . import ast
from .defined import Chain, Defined, applies
from .finite import finite as _finite, members as _members
from .spaces import Projection
from .values import (BUILTIN_SET_VALUES, FuncValue, SymbolicSet, brief, contains,
                     format_value, hashable, is_set, make_set)

__all__ = ["Relations"]

Env = dict
Fn = Callable[[Env], Any]


class Relations:
    """``c_Apply``, ``c_Image``, ``c_Inverse``, ``op_comp``, ``op_direct``."""

    def op_comp(self, node, l, r) -> Fn:
        def compose(a, b):
            by_first: dict = {}
            for y, z in b:
                by_first.setdefault(y, []).append(z)
            return make_set([(x, z) for x, y in a for z in by_first.get(y, ())])
        listed = self.set_op(node, l, r, compose)

        def composed(env: Env) -> Any:
            a, b = l(env), r(env)
            if isinstance(b, Defined) and b.relates() and not isinstance(a, SymbolicSet):
                return make_set([(x, z) for x, y in _finite(self, node.left, a)
                                 for z in b.images(y)])  # ([2, 3] ; {x, y | P})
            if not applies(b):
                return listed(env)
            if applies(a):  # (f ; g) of two lambdas: one after the other
                return Chain([a, b], f"({a.name} ; {b.name})")
            return make_set([(x, b.apply(y)) for x, y in _finite(self, node.left, a)
                             if b.in_domain(y)])
        return composed

    def op_parallel(self, node, l, r) -> Fn:
        """``(r || s)``: {((x, y), (z, w)) | (x, z) : r & (y, w) : s}."""
        return self.set_op(node, l, r, lambda a, b: make_set(
            [((x, y), (z, w)) for x, z in a for y, w in b]))

    def op_direct(self, node, l, r) -> Fn:
        def direct(a, b):
            by_first: dict = {}
            for x, z in b:
                by_first.setdefault(x, []).append(z)
            return make_set([(x, (y, z)) for x, y in a for z in by_first.get(x, ())])
        return self.set_op(node, l, r, direct)

    def c_Apply(self, node: ast.Apply) -> Fn:
        arg = self.compile(ast.pair_of(node.args))
        if isinstance(node.fn, ast.Name) and node.fn.id not in BUILTIN_SET_VALUES:
            name = node.fn.id

            def apply_name(env: Env) -> Any:
                x = arg(env)
                try:
                    return env[name].map[x]
                except (KeyError, AttributeError, TypeError):
                    if name not in env:
                        raise self.error(EvaluationError, node.fn,
                                         f"{name} has no value here") from None
                    return self.apply_value(node, env[name], x)
            return apply_name
        fn = self.compile(node.fn)
        projection = getattr(fn, "constant", None)
        if isinstance(projection, Projection):  # prj1(REAL * REAL, REAL)(p): folded, and its
            inside = projection.in_domain         # domain's test found once
            k = projection.which - 1

            def project(env: Env) -> Any:
                x = arg(env)
                if inside(x):
                    return x[k]
                return self.apply_value(node, projection, x)  # says what is wrong
            return project

        def apply(env: Env) -> Any:
            return self.apply_value(node, fn(env), arg(env))
        return apply

    def apply_value(self, node: ast.Apply, f: Any, x: Any) -> Any:
        if isinstance(f, Projection):
            try:
                return f.apply(x)
            except KeyError:
                raise self.wd(node, f"{brief(x)} is not in the domain of {f.name}") from None
        if isinstance(f, FuncValue):
            try:
                return f.map[x]
            except KeyError:
                raise self.wd(node, f"{format_value(x)} is not in the domain of the function") \
                    from None
            except TypeError:
                x = hashable(x)
                if x in f.map:
                    return f.map[x]
                raise self.wd(node, f"{brief(x)} is not in the domain of the function") \
                    from None
        if applies(f) or isinstance(f, Defined) and f.relates():  # %x.(x : INTEGER | x*x)(3)
            return f.apply(x)
        if isinstance(f, SymbolicSet):
            f = _finite(self, node.fn, f)
        if isinstance(f, frozenset):
            images = [p[1] for p in f if isinstance(p, tuple) and self.equal(node, p[0], x)]
            if len(images) != 1:
                what = "not in the domain" if not images else "mapped to several values"
                raise self.wd(node, f"{format_value(x)} is {what} of the relation")
            return images[0]
        raise self.type_error(node.fn, f, "a function")

    def c_Image(self, node: ast.Image) -> Fn:
        if isinstance(node.rel, ast.Call) and node.rel.name in ("closure", "closure1") and \
                len(node.rel.args) == 1:
            return self._reached(node, node.rel.name == "closure")
        rel, arg = self.compile(node.rel), self.compile(node.arg)

        def image(env: Env) -> frozenset:
            r, s = rel(env), arg(env)
            if not is_set(s):
                raise self.type_error(node.arg, s, "a set")
            return self._image(node.rel, node.arg, r, s)
        return image

    def _image(self, rel_node, arg_node, r: Any, s: Any) -> frozenset:
        if isinstance(r, Defined) and r.relates():  # {x, y | P}[S]: each one's images
            return make_set([y for x in _members(self, arg_node, s) for y in r.images(x)])
        if applies(r):  # f[1..10] of a lambda over INTEGER: its finite argument walked
            return make_set([r.apply(x) for x in _members(self, arg_node, s)
                             if r.in_domain(x)])
        return make_set([p[1] for p in _finite(self, rel_node, r) if contains(s, p[0])])

    def _reached(self, node: ast.Image, reflexive: bool) -> Fn:
        """``closure1(r)[S]``: what r reaches from S in one or more steps (``closure(r)[S]``:
        S too — the identity over the whole type adds exactly S), walked from S's members
        one image at a time, so r need only be finite or a function held by its
        definition; at most :data:`~tracecheck.b.values.SET_LIMIT` members."""
        from ..errors import SetLimitError
        from .values import SET_LIMIT

        rel_node = node.rel.args[0]
        rel, arg = self.compile(rel_node), self.compile(node.arg)

        def reached(env: Env) -> frozenset:
            r, s = rel(env), arg(env)
            if not is_set(s):
                raise self.type_error(node.arg, s, "a set")
            out: set = set(_members(self, node.arg, s)) if reflexive else set()
            frontier = self._image(rel_node, node.arg, r, s)
            while frontier:
                new = [x for x in frontier if x not in out]
                out.update(new)
                if len(out) > SET_LIMIT:
                    raise self.error(SetLimitError, node, f"`{self.text(node)}` reaches more "
                                     f"than {SET_LIMIT:,} elements; tracecheck builds or "
                                     f"walks at most {SET_LIMIT:,} elements of one set")
                frontier = self._image(rel_node, node.arg, r, make_set(new)) if new else ()
            return make_set(out)
        return reached

    def c_Inverse(self, node: ast.Inverse) -> Fn:
        rel = self.compile(node.rel)
        return lambda env: make_set([(p[1], p[0]) for p in _finite(self, node.rel, rel(env))])
