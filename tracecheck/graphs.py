"""Graphs: the strongly connected components of a finite directed graph (B's ``SCCS``, and
the import-cycle check of the architecture test)."""

from __future__ import annotations

from typing import Hashable, Iterable, Mapping

__all__ = ["components"]


def components(succ: Mapping[Hashable, Iterable[Hashable]]) -> list[frozenset]:
    """Every strongly connected component of the graph ``succ`` (node -> its successors;
    a successor that is no key is a node without successors), single nodes too, by
    Tarjan's algorithm without recursion (a deep graph does not exhaust Python's stack).

    >>> sorted(sorted(c) for c in components({1: [2], 2: [1, 3], 3: []}))
    [[1, 2], [3]]
    """
    index: dict = {}
    low: dict = {}
    stack: list = []
    on: set = set()
    found: list[frozenset] = []
    for root in list(succ):
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        work = [(root, iter(succ.get(root, ())))]
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on.add(nxt)
                    work.append((nxt, iter(succ.get(nxt, ()))))
                elif nxt in on:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    x = stack.pop()
                    on.discard(x)
                    comp.append(x)
                    if x == node:
                        break
                found.append(frozenset(comp))
    return found
