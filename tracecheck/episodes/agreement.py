"""A run blob against the episodes it stands for.

A block is read from its run blob only where the blob says what its episodes say. The
blob's checksums (of each episode's records and of the file's head) show that those bytes
are as the blob says — but whoever writes the blob writes those checksums too: a blob forged
with the real episodes' checksums and other columns (no crash in an episode that crashed)
would otherwise be taken over the untouched episodes it claims to summarise, and commands
that read blocks (``info``, ``replay``, ``stats``) would answer otherwise than those that read
the episodes (``render``, ``export``).

So every episode's own columns attachment — what a reader that walks the file reads for it —
is opened (its checksum, one zstd frame, its JSON header; no step message is decoded) and
must hold exactly the blob's rows for it: the same id, seed, end reason (where the columns
carry one), variables of the same kinds, and every column byte for byte — mapped through the
episode's own actions, set elements and literal tables where they are not the blob's, NaN
in the blob's rows for a column the episode does not have. The blob's actions and elements
must be those of its episodes, in the order they first come. A blob that does not agree is
not used: the block is walked, episode by episode, like a blob that does not check — and the
reader says so, naming the block and where it differs.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..errors import InputError
from .codec import COLUMNS_MEDIA_TYPE, Packed, arrays_of, unpack_columns
from .records import attachment_at

__all__ = ["block_agrees"]

#: columns an episode may lack (then the blob's rows for it are NaN: none recorded)
_MAY_LACK = ("values", "par:", "prop:", "dist")


def block_agrees(buf, blob: Packed, arrays: dict[str, np.ndarray], listed: np.ndarray
                 ) -> Optional[str]:
    """Where a run blob's block and its episodes differ, in words (None: nowhere): each
    episode's own columns attachment (the records at ``listed``: (offset, size) each, as the
    summary lists them) against the blob's rows for it (``blob``: the opened blob,
    ``arrays``: its arrays)."""
    block = _Block(blob, arrays)
    for i, (offset, size) in enumerate(listed.tolist()):
        data = attachment_at(buf, offset, size, COLUMNS_MEDIA_TYPE)
        try:
            why = "its columns do not read" if data is None else block.agrees(
                i, unpack_columns(data))
        except InputError as exc:
            why = exc.message
        except (KeyError, TypeError, ValueError, IndexError, AttributeError):
            why = "its columns do not read as tracecheck writes them"
        if why is not None:
            return f"episode {block.ids[i]}: {why}"
    return block.complete()


class _Block:
    """The blob's rows, and what its episodes so far had."""

    def __init__(self, blob: Packed, arrays: dict[str, np.ndarray]) -> None:
        header = self.header = blob.header
        self.data = blob.data
        self.starts = arrays["run:starts"].tolist()
        self.ids = arrays["run:episodes"].tolist()
        self.seeds = [s if ok else None for s, ok in zip(arrays["run:seeds"].tolist(),
                                                        arrays["run:seeded"].tolist())]
        self.reasons = [header["reasons"][k] for k in arrays["run:reasons"].tolist()]
        self.actions, self.elements = header["actions"], header["elements"]
        self.body = {k: v for k, v in arrays.items() if not k.startswith("run:")}
        #: per column: where its bytes start in the blob, its bytes per row, dtype, row shape
        self.where = {}
        for spec in header["arrays"]:
            arr = self.body.get(spec["name"])
            if arr is not None:
                self.where[spec["name"]] = (blob.base + spec["offset"],
                                            arr.itemsize * math.prod(arr.shape[1:]),
                                            arr.dtype.str, list(arr.shape[1:]))
        self.lacking = dict.fromkeys(self.body, 0)  # how many episodes lack each column
        self.seen_actions: dict = {}  # the episodes' actions and elements, in order
        self.seen_elements: dict = {}
        self._last = (None, None)
        self.plans: dict[int, tuple] = {}  # by rows: how an episode laid out so is compared

    def agrees(self, i: int, ep: Packed) -> Optional[str]:
        """Where episode ``i`` of the block (its opened columns ``ep``) differs from the
        blob's rows for it, in words (None: nowhere)."""
        h = ep.header
        s = self.starts[i]
        n = self.starts[i + 1] - s
        why = self._differs(i, h)
        if why is not None:
            return why
        self._seen(h["actions"], h["elements"])
        aligned = (h["elements"] == self.elements
                   and h["actions"] == self.actions[:len(h["actions"])])
        specs = h["arrays"]
        plan = self.plans.get(n) if aligned else None
        if plan is not None and specs == plan[0]:  # laid out as an episode before it
            return self._planned(plan, ep, s, n)
        why = self._columns(specs, ep, s, n, aligned)
        if why is None and aligned and len(specs) == len(self.body):
            self.plans[n] = self._plan(specs, n)
        return why

    def _differs(self, i: int, h: dict) -> Optional[str]:
        """Where the header of episode ``i``'s columns differs from the blob."""
        eid, seed, reason = h.get("episode"), h.get("seed"), h.get("reason", self.reasons[i])
        if type(eid) is not int or eid != self.ids[i]:
            return f"its columns say episode {eid!r}, the blob {self.ids[i]}"
        if seed != self.seeds[i] or type(seed) not in (int, type(None)):
            return f"its columns say seed {seed!r}, the blob {self.seeds[i]!r}"
        if reason != self.reasons[i]:
            return f"its columns say it ended by {reason!r}, the blob by {self.reasons[i]!r}"
        if h["kinds"] != self.header["kinds"]:
            return "its variables are not of the kinds the blob says"
        return None

    def _columns(self, specs: list, ep: Packed, s: int, n: int, aligned: bool
                 ) -> Optional[str]:
        """Where the episode's columns (``specs``) differ from the blob's rows ``s`` … ``s
        + n``: one the blob does not have, or holding other rows, or one it lacks."""
        names = set()
        for spec in specs:
            name = spec["name"]
            if name in names or name not in self.where:
                return f"its column {name}, which the blob does not have"
            if not self._column(spec, ep, s, n, aligned):
                return f"its column {name} does not hold the blob's rows for it"
            names.add(name)
        return None if len(names) == len(self.body) else self._lacks(names, s, n)

    def _plan(self, specs: list, n: int) -> tuple:
        """How an episode of ``n`` rows laid out as ``specs`` (each column checked, every
        one of the blob's there) is compared: ``specs``; how far its columns reach past
        where its arrays start; per column the spec, its offset there, where the blob's
        rows of it start and the bytes of a row; and, where the columns lie one after the
        other and none is of literals (as the writer lays them out), where the first starts:
        they are compared all at once."""
        columns = [(spec, spec["offset"], *self.where[spec["name"]][:2]) for spec in specs]
        reach = max(a + n * row for _, a, _, row in columns)
        joined = all(b[1] == a + n * row and not spec["name"].startswith("lit:")
                     for (spec, a, _, row), b in zip(columns, columns[1:] + [(None, reach)]))
        return specs, reach, columns, columns[0][1] if joined else None

    def _planned(self, plan: tuple, ep: Packed, s: int, n: int) -> Optional[str]:
        """:meth:`_columns` for an episode laid out as the one ``plan`` was made from."""
        _, reach, columns, first = plan
        data, base, blob = ep.data, ep.base, self.data
        if base + reach > ep.end:
            return "its columns run past the end of its attachment"
        if first is not None and data[base + first:base + reach] == b"".join(
                [blob[start + s * row:start + (s + n) * row] for _, _, start, row in columns]):
            return None  # every column at once
        for spec, a, start, row in columns:
            a += base
            if not (data[a:a + n * row] == blob[start + s * row:start + (s + n) * row]
                    if spec["name"][:4] != "lit:" else self._mapped(spec, ep, s, n)):
                return f"its column {spec['name']} does not hold the blob's rows for it"
        return None

    def _seen(self, actions: list, elements: list) -> None:
        if (actions, elements) != self._last:  # most episodes have their block's
            self.seen_actions.update(dict.fromkeys(actions))
            self.seen_elements.update(dict.fromkeys(elements))
            self._last = (actions, elements)

    def _column(self, spec: dict, ep: Packed, s: int, n: int, aligned: bool) -> bool:
        """The episode's column ``spec`` holds the blob's rows ``s`` … ``s + n``: byte for
        byte where both lay them out alike, else value for value (:meth:`_mapped`)."""
        name, offset = spec["name"], spec["offset"]
        start, row, dtype, tail = self.where[name]
        if (aligned and spec["dtype"] == dtype and spec["shape"] == [n, *tail]
                and type(offset) is int and offset >= 0 and not name.startswith("lit:")):
            a = ep.base + offset
            return (a + n * row <= ep.end
                    and ep.data[a:a + n * row] == self.data[start + s * row:start + (s + n) * row])
        return self._mapped(spec, ep, s, n)

    def _mapped(self, spec: dict, ep: Packed, s: int, n: int) -> bool:
        """The episode's column value for value, its indexes mapped to the blob's: actions,
        set elements and literals by name, a number of another dtype by value."""
        name = spec["name"]
        arr = arrays_of(Packed({"arrays": [spec]}, ep.data, ep.base, ep.end))[name]
        got = self.body[name][s:s + n]
        prefix, h = name.split(":")[0], ep.header
        if prefix == "action":
            want = np.array([self.actions.index(a) for a in h["actions"]] + [-1])[arr]
        elif prefix == "values":
            want = np.full((n, len(self.actions)), np.nan)
            want[:, [self.actions.index(a) for a in h["actions"]]] = arr
        elif prefix in ("fun", "def", "set"):
            want = np.zeros((n, len(self.elements)), dtype=got.dtype)
            want[:, [self.elements.index(e) for e in h["elements"]]] = arr
        elif prefix == "lit":
            texts = {t: k for k, t in enumerate(self.header["literals"][name[4:]])}
            want = np.array([texts.get(t, -1) for t in h["literals"][name[4:]]] + [-1])[arr]
        else:
            want = arr
        return want.shape == got.shape and bool(
            np.array_equal(want, got, equal_nan=got.dtype.kind == "f"))

    def _lacks(self, names: set, s: int, n: int) -> Optional[str]:
        """Where the episode lacks one of the blob's columns (those not in ``names``) that
        an episode may not lack, or whose rows for it are not NaN, in words."""
        for name in sorted(self.body.keys() - names):
            if not name.startswith(_MAY_LACK) or not np.isnan(self.body[name][s:s + n]).all():
                return f"it has no column {name}, the blob has rows of it for the episode"
            self.lacking[name] += 1
        return None

    def complete(self) -> Optional[str]:
        """After the last episode, where the blob says more than its episodes: a column
        none of them has, actions or set elements other than theirs (in the order they first
        came)."""
        none = [name for name, k in self.lacking.items() if k == len(self.ids)]
        if none:
            return f"the blob has a column {none[0]} none of its episodes has"
        if list(self.seen_actions) != self.actions:
            return (f"the blob's actions {self.actions} are not its episodes' "
                    f"{list(self.seen_actions)}")
        if list(self.seen_elements) != self.elements:
            return (f"the blob's set elements {self.elements} are not its episodes' "
                    f"{list(self.seen_elements)}")
        return None
