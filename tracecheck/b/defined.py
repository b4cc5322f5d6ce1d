"""Sets and functions held by their definition where their elements cannot be listed:
``{x | x > 1000}``, ``{x | x : NATURAL & x mod 25 = 0}``, ``%x.(x : INTEGER | x * x)``.

Membership is decided by the predicate with the element bound (and, for a lambda, its
value compared); a lambda is applied by evaluating its body where the argument satisfies
its predicate (elsewhere: not well-defined); its image of a finite set, its composition
after a finite relation (``[2, 3] ; f``) and ``iterate(f, n)`` follow. A relation given by a
predicate (``{x, y | x : NATURAL & y**2 >= x & (y-1)**2 < x}``) relates each argument to the
values of its last variable the predicate has with the others bound (``images``, found by
the evaluator or the solver, all of them or refused): its image of a finite set, and its
application where there is exactly one. Anything that needs the
elements (``card``, printing them, equality with another set) is refused, as for any set
tracecheck cannot tell is finite.
"""

from __future__ import annotations

from typing import Any, Callable, Optional

from ..errors import EvaluationError
from .memo import fresh
from .values import SymbolicSet, format_value, hashable

__all__ = ["Defined", "Chain", "cannot_list", "applies"]

Fn = Callable[[dict], Any]


def cannot_list(exc: EvaluationError) -> bool:
    """Whether ``exc`` says only that a binder's values cannot be listed (an infinite or too
    large set to walk), not that the definition is wrong."""
    from ..errors import SetLimitError

    return isinstance(exc, SetLimitError) or exc.message.startswith("cannot enumerate")


class Defined(SymbolicSet):
    """``{ids | test}`` (``value`` None) or ``%ids.(test | value)``, in the scope ``env`` it
    was built in."""

    def __init__(self, ids: tuple[str, ...], test: Fn, value: Optional[Fn], env: dict,
                 text: str, wd: Callable[[str], Exception], free: tuple[str, ...] = (),
                 why: Optional[EvaluationError] = None,
                 images: Optional[Callable[[dict, Any], list]] = None,
                 canon: Optional[str] = None) -> None:
        self.ids, self.test, self.value = ids, test, value
        self._images, self._found = images, {}  # the images by argument, found once
        self.env = fresh(env)
        self.name = text or canon or "a set"
        self._wd = wd  # the located not-well-defined error for a message
        # the same definition over the same values of its free names: the same set — the
        # definition as parsed (``canon``: big(1) and big(2) of a DEFINITION share their text)
        self._key = ("defined", canon or text, tuple((n, hashable(env.get(n))) for n in free))
        self.why = why  # why its elements cannot be listed: said where they are asked for

    def refusal(self) -> EvaluationError:
        if self.why is None:
            return EvaluationError(f"cannot list the elements of {self.name}")
        return type(self.why)(self.why.message, file=self.why.file, line=self.why.line,
                              column=self.why.column, source=self.why.source,
                              hint=self.why.hint)

    def finiteness(self) -> Optional[bool]:
        return None

    def _bound(self, args: Any) -> dict:
        env = fresh(self.env)
        for name in reversed(self.ids[1:]):
            if not isinstance(args, tuple):
                raise EvaluationError(f"{args!r} does not fit the variables of {self.name}")
            args, env[name] = args
        env[self.ids[0]] = args
        return env

    def relates(self) -> bool:
        """Whether it is a relation whose images of an argument can be found."""
        return self.value is None and self._images is not None

    def images(self, arg: Any) -> list:
        """The values a relation given by a predicate relates ``arg`` to."""
        key = hashable(arg)
        if key not in self._found:
            env = fresh(self.env)
            for name in reversed(self.ids[1:-1]):
                if not isinstance(arg, tuple):
                    raise EvaluationError(f"{arg!r} does not fit the variables of {self.name}")
                arg, env[name] = arg
            env[self.ids[0]] = arg
            self._found[key] = self._images(env, arg) if self._images else []
        return self._found[key]

    def in_domain(self, args: Any) -> bool:
        if self.relates():
            return bool(self.images(args))
        return self.test(self._bound(args)) is True

    def contains(self, value: Any) -> bool:
        if self.value is None:
            return self.test(self._bound(value)) is True
        if not isinstance(value, tuple):
            return False
        args, image = value
        env = self._bound(args)
        return self.test(env) is True and self.value(env) == image

    def apply(self, args: Any) -> Any:
        """The lambda's value at ``args`` (not well-defined outside its domain)."""
        if self.relates():
            found = self.images(args)
            if len(found) == 1:
                return found[0]
            if not found:
                raise self._wd(f"{format_value(args)} is not in the domain of {self.name}")
            raise self._wd(f"{self.name} is not a function at {format_value(args)}: it "
                           f"relates it to {', '.join(format_value(v) for v in found[:3])}"
                           f"{' …' if len(found) > 3 else ''}")
        if self.value is None:
            raise EvaluationError(f"cannot apply the set {self.name}: tracecheck applies "
                                  "functions given by a lambda (%x.(P | E)), not by a "
                                  "predicate")
        env = self._bound(args)
        if self.test(env) is not True:
            raise self._wd(f"{format_value(args)} is not in the domain of {self.name}")
        return self.value(env)

    def key(self) -> tuple:
        return self._key


class Chain(SymbolicSet):
    """Functions applied one after the other (``iterate(f, 3)``, ``(f ; g)``)."""

    def __init__(self, steps: list, name: str) -> None:
        self.steps, self.name = steps, name

    def finiteness(self) -> Optional[bool]:
        return None

    def in_domain(self, x: Any) -> bool:
        for f in self.steps:
            if not f.in_domain(x):
                return False
            x = f.apply(x)
        return True

    def apply(self, x: Any) -> Any:
        for f in self.steps:
            x = f.apply(x)
        return x

    def contains(self, value: Any) -> bool:
        return isinstance(value, tuple) and self.in_domain(value[0]) and \
            self.apply(value[0]) == value[1]

    def key(self) -> tuple:
        return ("chain", self.name, id(self))


def applies(f: Any) -> bool:
    """Whether ``f`` is a function held by its definition (it can be applied and chained;
    a relation given by a predicate is not: see :meth:`Defined.relates`)."""
    return isinstance(f, Chain) or (isinstance(f, Defined) and f.value is not None)
