"""Read-only lists shared by the many records of a report: a campaign's replay has 10^5
episode records and its diff 10^4 listed changes, most with the same few lists (no deadlock
states, the same enabled operations), so each distinct list is one object.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np

__all__ = ["SharedList", "NONE", "shared", "EnabledNames"]


class SharedList(list):
    """A list that refuses every change (it is shared: a change would change every record
    holding it); equal to the plain list of its items, and JSON as one."""

    def _refuse(self, *args, **kwargs):
        raise TypeError("a report's lists are shared and read-only")

    append = extend = insert = remove = pop = clear = sort = reverse = _refuse
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse

    def __reduce__(self):  # pickled (a Ray task's report) as a plain list
        return (list, (list(self),))


#: the empty list of every record that has none
NONE = SharedList()


def shared(items: Iterable) -> list:
    """``items`` as a list: the shared empty one where there are none."""
    out = list(items)
    return out if out else NONE


class EnabledNames:
    """The names of the operations a row of an enabled matrix allows, one shared list per
    pattern of the row."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.names, self.seen = names, {}

    def __call__(self, row: np.ndarray) -> list[str]:
        key = row.tobytes()
        found = self.seen.get(key)
        if found is None:
            found = self.seen[key] = SharedList(n for n, ok in zip(self.names, row.tolist())
                                                if ok)
        return found
