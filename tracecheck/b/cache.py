"""Caches a module keeps for each machine: typed, owned by the module that defines them.

A module that compiles something once per machine (a guard's linear form, a successor plan)
declares its own :class:`Cache` and asks the machine for it (:meth:`Machine.cached
<tracecheck.b.machine.Machine.cached>`); the machine keeps the values, keyed by the cache
object itself — never by a name another module could also use.
"""

from __future__ import annotations

from typing import Generic, TypeVar

__all__ = ["Cache"]

K = TypeVar("K")
V = TypeVar("V")


class Cache(Generic[K, V]):
    """A module's own cache of what it compiles for a machine (one per machine, kept with it):
    the module defines it, names it, and is the only one that reads or fills it.

    >>> GUARDS: Cache[str, int] = Cache("example")
    >>> GUARDS
    Cache('example')
    """

    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return f"Cache({self.name!r})"
